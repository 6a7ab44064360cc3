"""WaveExcitation: the wave excitation force and moment of a regular Airy wave or a JONSWAP sea on a
floating box (what WaveExcitation.fmu wraps; the variable names are the FMU's).

hydrodynamics = "constant": the Froude-Krylov force (flexfmu.wec.wave, any depth).  hydrodynamics = "bem":
the BEM excitation X(w, beta) of the box's database (flexfmu.wec.bem: Froude-Krylov + diffraction, deep
water), F(t) = Re(sum_j X(w_j, beta) a_j e^{i (phi_j - w_j t)}): the same components, amplitudes and phases
as the elevation eta = sum_j a_j cos(phi_j - w_j t) at O, whose complex amplitude a_j e^{i phi_j} is the
database's wave (Re(. e^{-i w t}), crest at O at t = 0 for phi = 0), so force and eta are in phase as the
database says.

No inputs: the load is a function of time, evaluated at each communication point.  The start is
ramped (``ramp_time``) so that the load and its rate start from zero.  See flexfmu.wec.wave.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the wave brings the energy in: the work its
force does on the body it loads, as that body accounts for it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import (HYDRODYNAMICS_INFO, MemorylessSimulator, bem_database, bem_excitation,
                                    check_config, check_finite_build, check_hydrodynamics, vector_info)
from flexfmu.wec.roles import WORK_IN, Panel, Role, Term, change, integral
from flexfmu.wec.wave import (RHO_SEA, G, BoxParameters, FloatingBox, froude_krylov_transfer, jonswap_sea, ramp,
                              regular_wave)

SEA_STATES = ("regular", "jonswap")
INPUT_NAMES: tuple = ()
OUTPUT_NAMES = ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z", "eta")


@dataclass(frozen=True)
class WaveExcitationConfig:
    """Parameters, named and defaulted as in the FMU."""

    sea_state: str = "regular"
    wave_height: float = 0.05       # H (regular) or Hs (jonswap), m
    wave_period: float = 1.4        # T (regular) or Tp (jonswap), s
    gamma: float = 3.3
    n_components: int = 64
    seed: int = 1
    heading: float = 0.0            # deg, direction of travel from x
    depth: float = 0.0              # m; <= 0: deep water
    ramp_time: float = 3.0          # s
    length: float = 1.0
    beam: float = 0.6
    draft: float = 0.25
    rho: float = RHO_SEA
    g: float = G
    hydrodynamics: str = "constant"


def _check(cfg: WaveExcitationConfig) -> None:
    """Every parameter's type and range (also those the chosen sea state does not use: a config is valid or not
    whatever sea_state says)."""
    check_config(cfg)
    require(cfg.sea_state in SEA_STATES, "sea_state", f"got {cfg.sea_state!r}", " | ".join(SEA_STATES))
    check_hydrodynamics(cfg)
    require(cfg.ramp_time >= 0, "ramp_time", f"got {cfg.ramp_time!r}", ">= 0 s")
    for name in ("length", "beam", "draft", "rho", "g"):
        require(getattr(cfg, name) > 0, name, f"got {getattr(cfg, name)!r}", "> 0")
    require(cfg.wave_height >= 0, "wave_height", f"got {cfg.wave_height!r}", ">= 0 m")
    require(cfg.wave_period > 0, "wave_period", f"got {cfg.wave_period!r}", "> 0 s")
    require(cfg.gamma >= 1, "gamma", f"got {cfg.gamma!r}", ">= 1")
    require(1 <= cfg.n_components <= 2000, "n_components", f"got {cfg.n_components!r}", "1 .. 2000")
    require(0 <= cfg.seed <= 2**63 - 1, "seed", f"got {cfg.seed!r}", "0 .. 2^63 - 1 (numpy.random.default_rng)")
    # a box deeper than the water is aground: the pressure integral would reach below the sea floor
    require(cfg.depth <= 0 or cfg.depth > cfg.draft, "depth", f"{cfg.depth!r} m is not deeper than the draft "
            f"{cfg.draft!r} m", f"<= 0 (deep water) or > draft = {cfg.draft!r} m")
    # the BEM database is solved for infinite depth
    require(cfg.hydrodynamics != "bem" or cfg.depth <= 0, "depth", f"got {cfg.depth!r} m with hydrodynamics = bem",
            "<= 0 (deep water) with hydrodynamics = bem")


@lru_cache(maxsize=16)
def _build(cfg: WaveExcitationConfig):
    box = FloatingBox(cfg.length, cfg.beam, cfg.draft, rho=cfg.rho, g=cfg.g)
    heading = math.radians(cfg.heading)
    names = ("wave_height", "wave_period", "length", "beam", "draft", "depth", "rho", "g")
    try:
        with np.errstate(all="ignore"):                               # overflow: checked by value below
            if cfg.sea_state == "regular":
                waves = regular_wave(cfg.wave_height, cfg.wave_period, heading, cfg.depth, cfg.g)
            else:
                waves = jonswap_sea(cfg.wave_height, cfg.wave_period, cfg.gamma, cfg.n_components, cfg.seed, heading,
                                    cfg.depth, cfg.g)
            if cfg.hydrodynamics == "constant":
                X = froude_krylov_transfer(box, waves) * waves.amplitude    # per component, (6, n)
    except (OverflowError, ZeroDivisionError, ValueError):            # Python float arithmetic (math.sqrt, ...)
        check_finite_build(cfg, names, np.array([np.nan]))
    if cfg.hydrodynamics == "bem":
        # the excitation does not depend on the mass distribution: BoxParameters' defaults stand in for it
        params = BoxParameters(length=cfg.length, beam=cfg.beam, draft=cfg.draft, rho=cfg.rho, g=cfg.g)
        check_finite_build(cfg, names, waves.omega, waves.k, waves.amplitude)
        ds = bem_database(params, cfg.heading)
        X = bem_excitation(ds, waves.omega, cfg.heading, "wave_period") * waves.amplitude
    check_finite_build(cfg, names, waves.omega, waves.k, waves.amplitude, X)
    return waves, X


class WaveExcitationSimulator(MemorylessSimulator):
    """Time and outputs of one WaveExcitation instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: WaveExcitationConfig = WaveExcitationConfig()):
        super().__init__(config)
        _check(config)                     # before _build's cache: it hashes the config
        self.waves, self._X = _build(config)

    def load(self, t: float) -> np.ndarray:
        """Force and moment about O (global), (6,), at time t."""
        waves = self.waves
        phasor = np.exp(1j * (waves.phase - waves.omega * t))
        return ramp(t, self.config.ramp_time) * (self._X @ phasor).real

    def _outputs(self) -> dict[str, float]:
        eta = ramp(self.t, self.config.ramp_time) * self.waves.elevation(self.t)
        return dict(zip(OUTPUT_NAMES, self.load(self.t).tolist() + [eta]))


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "sea_state": ("", "regular (one Airy wave) or jonswap (a long-crested JONSWAP sea)"),
    "wave_height": ("m", "wave height H (regular) or significant height Hs (jonswap), >= 0"),
    "wave_period": ("s", "wave period T (regular) or peak period Tp (jonswap), > 0"),
    "gamma": ("", "JONSWAP peak enhancement factor, >= 1"),
    "n_components": ("", "JONSWAP components over 0.5 .. 3 wp, 1 .. 2000"),
    "seed": ("", "JONSWAP random-phase seed, >= 0"),
    "heading": ("", "direction of wave travel from the x axis, deg"),
    "depth": ("m", "water depth; <= 0 = deep water, else > draft"),
    "ramp_time": ("s", "the load is ramped up as 0.5 (1 - cos(pi t / ramp_time)), >= 0"),
    "length": ("m", "box length (x), > 0"),
    "beam": ("m", "box beam (y), > 0"),
    "draft": ("m", "box draft, > 0"),
    "rho": ("", "water density, kg/m3, > 0"),
    "g": ("m/s2", "gravity, > 0"),
    "hydrodynamics": HYDRODYNAMICS_INFO,
    **vector_info("F", "N", "wave excitation force on the box (Froude-Krylov; bem: with diffraction)", "global"),
    **vector_info("M", "N.m", "wave excitation moment about the waterplane centre (Froude-Krylov; bem: with "
                              "diffraction)", "global"),
    "eta": ("m", "undisturbed surface elevation at the waterplane centre"),
}


class WaveRole(Role):
    """The energy brought in: the work the wave force did on the body it loads in the co-simulation (the force held
    over each step: that body's own account, e.g. the Platform's work_wave, exact); the diagnostics give the
    trapezoid of the continuous force's power over the samples too, which differs by the excitation's sampling."""

    kind = "wave"

    def energy(self, m, r):
        fed = r.work_on_target(m.name, "F_x")
        return [] if fed is None else [Term(WORK_IN, "work done by the wave force" + m.suffix, change(fed[2]))]

    def diagnostics(self, m, r):
        fed = r.work_on_target(m.name, "F_x")
        if fed is None:
            return {}
        body = fed[0].name
        f_wave = np.hstack([r.vec(m.name, "F_{}"), r.vec(m.name, "M_{}")])
        xi_dot = np.hstack([r.vec(body, "vel_{}"), r.vec(body, "omega_{}")])
        return {"wave work of the continuous force (trapezoid over the samples)" + m.suffix:
                integral(np.einsum("ij,ij->i", f_wave, xi_dot), r.t)}

    def panels(self, m, r):
        return [Panel("translation", "platform translation", "m",
                      [(r.col(m.name, "eta"), {"color": "k", "lw": 0.8, "label": "wave elevation at O" + m.suffix})])]


#: what the wave is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = WaveRole()
