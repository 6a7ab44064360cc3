"""The units the FMUs' variables use, as SI base-unit exponents (a modelDescription's UnitDefinitions): read by the
FMI 2.0 build (flexfmu.fmi.build) and the FMI 3.0 modelDescription (flexfmu.fmi.description_fmi3), which builds on
it, so they live below both."""
from __future__ import annotations

#: unit -> {SI base unit: exponent}
UNITS = {
    "m": {"m": 1}, "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2}, "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2}, "Hz": {"s": -1}, "J": {"kg": 1, "m": 2, "s": -2},
    "rad/s": {"rad": 1, "s": -1}, "rad/s2": {"rad": 1, "s": -2}, "s": {"s": 1}, "kg": {"kg": 1},
    "W": {"kg": 1, "m": 2, "s": -3}, "N/m": {"kg": 1, "s": -2}, "m2": {"m": 2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
}
