"""Small helpers shared by the wave-energy-converter component façades (flexfmu.wec.wave_excitation,
flexfmu.wec.hydrostatics, flexfmu.wec.platform, flexfmu.wec.pto): input checks, plain-data state, variable
descriptions."""
from __future__ import annotations

import math
from dataclasses import asdict, fields

import numpy as np

from flexfmu.core.checks import blame_inputs, finite, finite_input, is_int, parameter_culprit, shown
from flexfmu.errors import NonFiniteError, ParameterError, require

AXES = ("x", "y", "z")
#: the six generalised (rigid-body) directions, in the order of the 6-vectors
DOF6 = ("x", "y", "z", "rx", "ry", "rz")


def check_config(cfg) -> None:
    """Every field of its declared type: float a finite real number (not a bool), int an integer (not a bool),
    bool a bool, str a string.  The ranges are the components' own checks."""
    for f in fields(cfg):
        value = getattr(cfg, f.name)
        kind = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", "")
        if kind == "float":
            require(finite(value), f.name, f"got {value!r}", "a finite number")
        elif kind == "int":
            require(is_int(value), f.name, f"got {value!r}", "an integer")
        elif kind == "bool":
            require(isinstance(value, (bool, np.bool_)), f.name, f"got {value!r}", "true | false")
        elif kind == "str":
            require(isinstance(value, str), f.name, f"got {value!r}", "a string")


def check_finite_build(cfg, names, *arrays) -> None:
    """ParameterError naming the parameter (of ``names``) farthest from its default when a component's
    coefficients built from them overflow: they multiply (rho g H L B ..., or 1 / T^2)."""
    if all(np.all(np.isfinite(a)) for a in arrays):
        return
    name = parameter_culprit(cfg, type(cfg)(), names)
    raise ParameterError(name, f"{getattr(cfg, name)!r} makes the component's coefficients overflow (not finite)",
                         "values whose products stay within the floating-point range")


def check_outputs(sim, values) -> None:
    """NonFiniteError naming the input that alone makes an output overflow (memoryless components: the outputs
    are functions of the inputs); called only when ``values`` are not all finite."""
    bad = [name for name, v in values.items() if not math.isfinite(v)]
    if not bad:
        return

    def evaluate(inputs):
        saved = sim.inputs
        sim.inputs = inputs
        try:
            return list(sim._outputs().values())
        finally:
            sim.inputs = saved
    name = blame_inputs(dict(sim.inputs), evaluate) if sim.inputs else None
    if name is None:
        raise NonFiniteError(", ".join(bad), f"not finite at t = {sim.time!r} s (the parameters drive the "
                                             "component beyond the floating-point range)")
    raise NonFiniteError(name, f"{sim.inputs[name]:.6g} makes {', '.join(bad)} overflow (not finite) at t = "
                               f"{sim.time!r} s; allowed: inputs within the model's range")


def check_inputs(inputs: dict, names: tuple) -> None:
    """Every name an input, every value finite (per step: the messages are built only on failure)."""
    for name, value in inputs.items():
        if name not in names:
            raise ParameterError(name, "unknown input", ", ".join(names))
        if not finite_input(value):
            raise ParameterError(name, f"input is {shown(value)}", "a finite number")


def check_step(step_size: float) -> None:
    require(finite(step_size) and step_size > 0, "step_size", f"got {step_size!r}", "> 0 s")


def check_state_config(data: dict, config) -> None:
    require(data.get("config") == asdict(config), "FMUstate", "was taken with other parameters",
            "a state of this instance's configuration")


def checked_outputs(sim) -> dict[str, float]:
    """``sim._outputs()``, checked: an overflow names the input that caused it (check_outputs)."""
    try:
        values = sim._outputs()
    except ArithmeticError:                           # numpy's error mode set to raise: again without it
        with np.errstate(all="ignore"):
            values = sim._outputs()
    if not math.isfinite(sum(values.values())):       # one sum; the culprit only on failure
        check_outputs(sim, values)
    return values


class MemorylessSimulator:
    """Plumbing of a component whose outputs depend only on its inputs, parameters and time (no
    dynamic state): the time, the held inputs, the step and the plain-data state for FMI get/set.
    Subclasses set INPUTS (the input names) and compute outputs()."""

    INPUTS: tuple = ()

    def __init__(self, config):
        self.config = config
        self.t = 0.0
        self.inputs = dict.fromkeys(self.INPUTS, 0.0)

    @property
    def time(self) -> float:
        return self.t

    def set_inputs(self, **inputs: float) -> None:
        check_inputs(inputs, self.INPUTS)
        self.inputs.update({k: float(v) for k, v in inputs.items()})

    def step(self, step_size: float) -> None:
        check_step(step_size)
        if not math.isfinite(self.t + step_size):
            raise NonFiniteError("step_size", f"the time {self.t!r} s + {step_size!r} s overflows")
        self.t += step_size

    def outputs(self) -> dict[str, float]:
        """The outputs (subclasses compute them in _outputs), checked: an overflow names its input."""
        return checked_outputs(self)

    def _outputs(self) -> dict[str, float]:
        raise NotImplementedError

    def get_state(self) -> dict:
        return {"t": self.t, "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        self.t = float(data["t"])
        self.inputs = dict(data.get("inputs", {}))


def vector_info(prefix: str, unit: str, text: str, frame: str = "body") -> dict:
    return {f"{prefix}_{a}": (unit, f"{text}, {frame} {a}") for a in AXES}


# ------------------------------------------------------------------ the hydrodynamic model switch
#: the ``hydrodynamics`` parameter of WaveExcitation, Hydrostatics and Platform
HYDRODYNAMICS = ("constant", "bem")
HYDRODYNAMICS_INFO = ("", "hydrodynamic model: constant (the box's closed-form coefficients, Froude-Krylov "
                          "excitation) or bem (Capytaine database of the box: excitation with diffraction, "
                          "radiation memory, infinite-frequency added mass; deep water)")


def check_hydrodynamics(cfg) -> None:
    require(cfg.hydrodynamics in HYDRODYNAMICS, "hydrodynamics", f"got {cfg.hydrodynamics!r}",
            " | ".join(HYDRODYNAMICS))


def box_parameters(params):
    """The BoxParameters part of a component's config (its other fields do not change the BEM database)."""
    from flexfmu.wec.wave import BoxParameters
    return BoxParameters(**{f.name: getattr(params, f.name) for f in fields(BoxParameters)})


_DATABASES: dict = {}


def bem_database(params, heading_deg: float | None = None):
    """The BEM database (flexfmu.wec.bem.hydro_database) of the box ``params`` describes: default frequencies
    and headings, plus ``heading_deg`` (taken modulo 360) when it is not one of them.  Loaded once per
    process; computed once per machine (the disk cache, ~15 s)."""
    from flexfmu.wec import bem
    headings = tuple(float(h) for h in bem.DEFAULT_HEADINGS_DEG)
    if heading_deg is not None:
        h = float(heading_deg) % 360.0
        if not np.any(np.isclose(headings, h, rtol=0, atol=1e-9)):
            headings = tuple(sorted(headings + (h,)))
    key = (box_parameters(params), headings)
    if key not in _DATABASES:
        _DATABASES[key] = bem.hydro_database(key[0], headings_deg=headings)
    return _DATABASES[key]


def bem_excitation(ds, omega, heading_deg: float, parameter: str) -> np.ndarray:
    """X(w, beta) per unit wave amplitude (flexfmu.wec.bem eq. BEM.2), (6, n) complex (N/m, N m/m about O), at
    the angular frequencies ``omega`` (rad/s): re and im interpolated linearly between the database's
    frequencies, as bem.response_amplitude_operator does.  A frequency outside the database's range is a
    ParameterError naming ``parameter``."""
    from flexfmu.wec import bem
    from flexfmu.wec.wave import DOF_NAMES
    w = np.atleast_1d(np.asarray(omega, float))
    headings = np.degrees(ds["wave_direction"].values.astype(float)) % 360.0
    j = np.flatnonzero(np.isclose(headings, float(heading_deg) % 360.0, rtol=0, atol=1e-9))
    require(j.size == 1, "heading", f"got {heading_deg!r}", f"one of the database's {headings.round(6).tolist()}")
    c = bem.coefficients(ds, DOF_NAMES)
    w0 = c.omega
    require(bool(np.all(w >= w0[0]) and np.all(w <= w0[-1])), parameter,
            f"wave frequencies {w.min():.4g} .. {w.max():.4g} rad/s lie outside the BEM database's",
            f"wave frequencies within {w0[0]:.4g} .. {w0[-1]:.4g} rad/s (periods {2 * math.pi / w0[-1]:.3g} .. "
            f"{2 * math.pi / w0[0]:.3g} s)")
    X = c.X[:, j[0], :]
    return np.array([np.interp(w, w0, X[:, d].real) + 1j * np.interp(w, w0, X[:, d].imag)
                     for d in range(len(DOF_NAMES))])


def bem_added_mass_inf(ds) -> np.ndarray:
    """A_inf about O, 6x6 (kg, kg m, kg m^2), symmetrised: the BEM's is symmetric to its discretisation
    error, and a mass matrix must be."""
    from flexfmu.wec import bem
    A = bem.coefficients(ds).A_inf
    return 0.5 * (A + A.T)
