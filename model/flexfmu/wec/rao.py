"""RAOs of the wave converter's floating box: the co-simulated response of the component simulators in
regular (or irregular) head seas, its steady complex amplitude, and the frequency-domain RAO of the
constant-coefficient model, the counterpart of flexfmu.wec.bem.response_amplitude_operator (eq. BEM.2) for
``hydrodynamics = "constant"``.

The co-simulation couples the three library simulators (WaveExcitation, Platform, Hydrostatics; no
harvester, no PTO) by a fixed-step Gauss-Seidel loop in the order and hold of flexfmu.cosim.masters'
Gauss-Seidel scheme: wave, then platform with the latest wave and hydro outputs, then hydro with the new
motion.  Used by tests/test_wave_bem_cosim.py, tests/test_wave_barge.py and
examples/wave_converter/rao_chart.py (docs/figures/wave_bem_rao.png).
"""
from __future__ import annotations

import math

import numpy as np

from flexfmu.wec.hydrostatics import INPUT_NAMES as HYDRO_INPUTS
from flexfmu.wec.hydrostatics import HydrostaticsConfig, HydrostaticsSimulator
from flexfmu.wec.hydrostatics import coefficients as hydro_coefficients
from flexfmu.wec.platform import PlatformConfig, PlatformSimulator
from flexfmu.wec.wave import WaveComponents, froude_krylov_transfer, wave_number
from flexfmu.wec.wave_excitation import WaveExcitationConfig, WaveExcitationSimulator

AX = "xyz"
STEP = 1e-3          # s: the example's communication step
RAMP = 10.0          # s: the regular wave's smooth start (the lightly damped pitch needs a long one)
WINDOW = 8.0         # s: the steady amplitude is fitted over the last whole periods within it
HEIGHT = 0.02        # m: a = 0.01 m (the model is linear; the value only sets the scale)


class RigidPlatform:
    """The rigid Platform in the loop (Platform's names are Hydrostatics' inputs)."""

    def __init__(self, config: PlatformConfig):
        self.sim = PlatformSimulator(config)

    def hold_loads(self, wave: dict, hydro: dict) -> None:
        self.sim.set_inputs(**{f"{g}_{q}_{a}": o[f"{q}_{a}"] for g, o in (("wave", wave), ("hydro", hydro))
                               for q in "FM" for a in AX})

    def step(self, h: float) -> None:
        self.sim.step(h)

    def motion(self) -> dict:
        """Hydrostatics' inputs (O's motion, global) from the platform's outputs."""
        out = self.sim.outputs()
        return {name: out.get(name, 0.0) for name in HYDRO_INPUTS}


def cosimulated_motion(period: float, t_end: float, h: float = STEP, wave_config: WaveExcitationConfig = None,
                       hydrodynamics: str = "bem", *, heading: float = 0.0, platform=None,
                       hydro_config: HydrostaticsConfig = None):
    """Times (n,), platform motion xi (n, 6) and elevation eta at O (n,) of the co-simulated WEC: regular waves
    of height HEIGHT, the given period and heading (deg) and a RAMP s start, or the sea of wave_config.
    ``platform``: what stands in Platform's place (hold_loads(wave outputs, hydro outputs), step(h), motion() ->
    Hydrostatics' inputs): the rigid Platform of the default box by default (flexfmu.wec.barge.BargeInLoop for the
    flexible barge); ``hydro_config``: Hydrostatics' (default: the box's, with ``hydrodynamics``)."""
    wave = WaveExcitationSimulator(wave_config or WaveExcitationConfig(
        wave_height=HEIGHT, wave_period=period, heading=heading, ramp_time=RAMP, hydrodynamics=hydrodynamics))
    platform = platform or RigidPlatform(PlatformConfig(hydrodynamics=hydrodynamics))
    hydro = HydrostaticsSimulator(hydro_config or HydrostaticsConfig(hydrodynamics=hydrodynamics))
    n = round(t_end / h)
    xi, eta = np.empty((n + 1, 6)), np.empty(n + 1)
    mo, wo, ho = platform.motion(), wave.outputs(), hydro.outputs()

    def record(k):
        xi[k] = [mo[f"pos_{a}"] for a in AX] + [mo[f"rot_{a}"] for a in AX]
        eta[k] = wo["eta"]
    record(0)
    for k in range(n):
        wave.step(h)
        wo = wave.outputs()
        platform.hold_loads(wo, ho)
        platform.step(h)
        mo = platform.motion()
        hydro.set_inputs(**mo)
        hydro.step(h)
        ho = hydro.outputs()
        record(k + 1)
    return h * np.arange(n + 1), xi, eta


def steady_amplitude(t, x, omega: float, window: float = WINDOW) -> complex:
    """Complex z of x ~ c0 + c1 t + Re(z e^{-i w t}), least squares over the last whole periods within window
    (the linear term absorbs a slow drift, e.g. surge, which has no restoring force)."""
    period = 2 * math.pi / omega
    sel = t >= t[-1] - period * math.floor(window / period) - 1e-9
    ts = t[sel]
    basis = np.column_stack([np.ones_like(ts), ts, np.cos(omega * ts), np.sin(omega * ts)])
    c, *_ = np.linalg.lstsq(basis, x[sel], rcond=None)
    return c[2] + 1j * c[3]


def constant_rao(omega, cfg: HydrostaticsConfig = HydrostaticsConfig(), heading_deg: float = 0.0) -> np.ndarray:
    """Complex RAO (n, 6) per unit wave amplitude (deep water, the database's convention Re(. e^{-i w t}),
    crest at O at t = 0) of the constant-coefficient model of the components (hydrodynamics = "constant"),
    for the box of ``cfg``: Froude-Krylov excitation (flexfmu.wec.wave.froude_krylov_transfer), the
    rigid mass matrix plus the strip-theory added mass (the Platform's), the constant stiffness and damping
    of Hydrostatics (its zeta_*)."""
    w = np.atleast_1d(np.asarray(omega, float))
    box = cfg.box()
    M = box.rigid_mass_matrix() + box.added_mass()
    C, B = hydro_coefficients(cfg)
    waves = WaveComponents(w, wave_number(w, g=box.g), np.ones_like(w), np.zeros_like(w), math.radians(heading_deg))
    X = froude_krylov_transfer(box, waves)
    return np.array([np.linalg.solve(-wn**2 * M - 1j * wn * B + C, X[:, k]) for k, wn in enumerate(w)])
