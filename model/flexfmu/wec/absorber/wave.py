"""AbsorberWave: the sea at the point absorber (what AbsorberWave.fmu wraps; variable names are the FMU's): the
surface elevation at O and the wave excitation force and moment about O of the hull's BEM database
(flexfmu.wec.absorber.hull; Froude-Krylov + diffraction, heading 0: travelling along global x).

Components (w_k rad/s, a_k m, phi_k rad):
  regular   one component, w = 2 pi / T, a = H / 2, phi = 0
  jonswap   n bins of width dw = 2.5 w_p / n over [0.5 w_p, 3 w_p] (w_p = 2 pi / Tp), w_k = 0.5 w_p + (k + 1/2) dw;
            n = n_components, or (0) ceil(2.5 w_p record_length / (2 pi)): dw <= 2 pi / record_length, so the record
            does not repeat within record_length.
            s(w) = w^-5 exp(-1.25 (w_p / w)^4) gamma^exp(-(w - w_p)^2 / (2 sigma^2 w_p^2)), sigma = 0.07 (w <= w_p)
            else 0.09; S_k = (Hs / 4)^2 s_k / (dw sum_j s_j), a_k = sqrt(2 S_k dw): Hs = 4 sqrt(sum S_k dw) exactly,
            the significant height of the discrete band (not of the infinite spectrum, whose tails beyond the band
            hold 1.0 % of m0 at gamma = 3.3).
            phi_k = 2 pi u_k, u_k the k-th draw of SplitMix64 seeded with ``seed`` (:func:`splitmix64_uniforms`).
Outputs at t, r(t) the ramp (flexfmu.wec.wave.ramp: 0.5 (1 - cos(pi t / T_r)) for 0 < t < T_r, 0 at t <= 0, 1 after):
  elevation = r(t) sum_k a_k cos(w_k t - phi_k)
  load_i    = r(t) sum_k a_k |X_ki| cos(w_k t - phi_k - arg X_ki)  = r(t) Re(sum_k X_ki a_k e^{i phi_k} e^{-i w_k t})
X_k: the database's X (Capytaine's Re(X a e^{-i w t}), crest at O at t = 0) at w_k, re and im interpolated linearly.
No inputs; state: the time.

In the wave-energy converter system (SYSTEM_ROLE) the wave brings the energy in, as flexfmu.wec.wave_excitation's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.components import MemorylessSimulator, check_config, vector_info
from flexfmu.wec.roles import Panel
from flexfmu.wec.wave import ramp
from flexfmu.wec.wave_excitation import WaveRole

SEA_STATES = ("regular", "jonswap")
INPUT_NAMES: tuple = ()
OUTPUT_NAMES = ("elevation", "F_x", "F_y", "F_z", "M_x", "M_y", "M_z")
MAX_COMPONENTS = 5000
MAX_SEED = 2**31 - 1            # an FMI Integer
_MASK64 = (1 << 64) - 1


def splitmix64_uniforms(seed: int, n: int) -> list[float]:
    """The first n uniforms u in [0, 1) of SplitMix64 (Steele, Lea & Flood 2014; Vigna's splitmix64.c) seeded with
    ``seed``: per draw state += 0x9E3779B97F4A7C15, z = state, z = (z ^ z >> 30) * 0xBF58476D1CE4E5B9,
    z = (z ^ z >> 27) * 0x94D049BB133111EB, z ^= z >> 31 (mod 2^64), u = (z >> 11) 2^-53."""
    return [(z >> 11) * 2.0**-53 for z in splitmix64(seed, n)]


def splitmix64(seed: int, n: int) -> list[int]:
    """The first n 64-bit outputs of SplitMix64 seeded with ``seed`` (as a uint64)."""
    state = int(seed) & _MASK64
    out = []
    for _ in range(n):
        state = (state + 0x9E3779B97F4A7C15) & _MASK64
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK64
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK64
        out.append(z ^ (z >> 31))
    return out


def jonswap_shape(omega, wp: float, gamma: float) -> np.ndarray:
    """The unnormalised JONSWAP shape s(w) of the module docstring (w > 0)."""
    w = np.asarray(omega, float)
    sigma = np.where(w <= wp, 0.07, 0.09)
    return w**-5 * np.exp(-1.25 * (wp / w) ** 4) * gamma ** np.exp(-((w - wp) ** 2) / (2 * sigma**2 * wp**2))


@dataclass(frozen=True)
class AbsorberWaveConfig:
    """Parameters, named and defaulted as in the FMU."""

    sea_state: str = "regular"
    wave_height: float = 2.0        # H (regular) or Hs (jonswap), m
    wave_period: float = 8.0        # T (regular) or Tp (jonswap), s
    gamma: float = 3.3
    seed: int = 1
    n_components: int = 0           # 0: automatic (record_length)
    record_length: float = 1200.0   # s
    ramp_time: float = 20.0         # s


@dataclass(frozen=True)
class SeaComponents:
    """omega (rad/s), amplitude (m), phase (rad), spectral density S_k (m^2 s/rad; regular: none), bin width dw."""

    omega: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    density: np.ndarray | None
    dw: float


def component_count(cfg: AbsorberWaveConfig) -> int:
    if cfg.sea_state == "regular":
        return 1
    if cfg.n_components > 0:
        return int(cfg.n_components)
    # ceil(2.5 w_p L / (2 pi)) = ceil(2.5 L / Tp), with a guard: evaluated through w_p, a whole 2.5 L / Tp rounded
    # up to the next integer (Tp = 9 s, L = 1800 s: 501 instead of 500)
    return math.ceil(2.5 * cfg.record_length / cfg.wave_period - 1e-9)


def _check(cfg: AbsorberWaveConfig) -> None:
    """Every parameter's type and range (also those the chosen sea state does not use)."""
    check_config(cfg)
    require(cfg.sea_state in SEA_STATES, "sea_state", f"got {cfg.sea_state!r}", " | ".join(SEA_STATES))
    require(cfg.wave_height >= 0, "wave_height", f"got {cfg.wave_height!r}", ">= 0 m")
    require(cfg.wave_period > 0, "wave_period", f"got {cfg.wave_period!r}", "> 0 s")
    require(cfg.gamma >= 1, "gamma", f"got {cfg.gamma!r}", ">= 1")
    require(0 <= cfg.seed <= MAX_SEED, "seed", f"got {cfg.seed!r}", f"0 .. {MAX_SEED}")
    require(cfg.n_components == 0 or 1 <= cfg.n_components <= MAX_COMPONENTS, "n_components",
            f"got {cfg.n_components!r}", f"0 (automatic) or 1 .. {MAX_COMPONENTS}")
    require(cfg.record_length > 0, "record_length", f"got {cfg.record_length!r}", "> 0 s")
    if cfg.sea_state == "jonswap" and cfg.n_components == 0:
        n = component_count(cfg)
        require(n <= MAX_COMPONENTS, "record_length", f"{cfg.record_length!r} s needs {n} components at Tp = "
                f"{cfg.wave_period!r} s", f"<= {MAX_COMPONENTS} components: record_length <= "
                f"{MAX_COMPONENTS * cfg.wave_period / 2.5:.6g} s (or set n_components)")


def sea_components(cfg: AbsorberWaveConfig) -> SeaComponents:
    """The components of the module docstring."""
    _check(cfg)
    if cfg.sea_state == "regular":
        return SeaComponents(np.array([2 * math.pi / cfg.wave_period]), np.array([cfg.wave_height / 2]),
                             np.zeros(1), None, 0.0)
    n = component_count(cfg)
    wp = 2 * math.pi / cfg.wave_period
    dw = 2.5 * wp / n
    w = 0.5 * wp + (np.arange(n) + 0.5) * dw
    s = jonswap_shape(w, wp, cfg.gamma)
    S = (cfg.wave_height / 4) ** 2 * s / (dw * np.sum(s))
    phase = 2 * math.pi * np.array(splitmix64_uniforms(cfg.seed, n))
    return SeaComponents(w, np.sqrt(2 * S * dw), phase, S, dw)


def interpolate_excitation(hull, omega, parameter: str = "wave_period") -> np.ndarray:
    """X (n, 6) per unit amplitude at ``omega``: re and im of the hull's X interpolated linearly; a frequency outside
    the database's range is a ParameterError naming ``parameter``."""
    w = np.atleast_1d(np.asarray(omega, float))
    w0 = hull.omega
    if not (np.all(w >= w0[0]) and np.all(w <= w0[-1])):
        from flexfmu.errors import ParameterError
        raise ParameterError(parameter, f"wave frequencies {w.min():.6g} .. {w.max():.6g} rad/s lie outside the BEM "
                             f"database's", f"wave frequencies within {w0[0]:.6g} .. {w0[-1]:.6g} rad/s: a regular "
                             f"period {2 * math.pi / w0[-1]:.6g} .. {2 * math.pi / w0[0]:.6g} s; a JONSWAP Tp whose "
                             f"band 0.5 .. 3 w_p lies within it, about {3 * 2 * math.pi / w0[-1]:.4g} .. "
                             f"{0.5 * 2 * math.pi / w0[0]:.4g} s")
    return np.column_stack([np.interp(w, w0, hull.X[:, d].real) + 1j * np.interp(w, w0, hull.X[:, d].imag)
                            for d in range(6)])


@lru_cache(maxsize=16)
def _build(cfg: AbsorberWaveConfig):
    from flexfmu.wec.absorber.hull import absorber_hull
    sea = sea_components(cfg)
    X = interpolate_excitation(absorber_hull(), sea.omega)
    return sea, X * sea.amplitude[:, None]


class AbsorberWaveSimulator(MemorylessSimulator):
    """Time and outputs of one AbsorberWave instance."""

    INPUTS = INPUT_NAMES

    def __init__(self, config: AbsorberWaveConfig = AbsorberWaveConfig()):
        super().__init__(config)
        _check(config)                     # before _build's cache: it hashes the config
        self.sea, self._aX = _build(config)

    def _outputs(self) -> dict[str, float]:
        sea, t = self.sea, self.t
        arg = sea.omega * t - sea.phase
        r = ramp(t, self.config.ramp_time)
        elevation = r * float(sea.amplitude @ np.cos(arg))
        load = r * (np.exp(-1j * arg) @ self._aX).real          # Re(X a e^{i phi} e^{-i w t})
        return dict(zip(OUTPUT_NAMES, [elevation] + load.tolist()))


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "sea_state": ("", "regular (one Airy wave) or jonswap (a long-crested JONSWAP sea), travelling along global x"),
    "wave_height": ("m", "wave height H (regular) or significant height Hs = 4 sqrt(m0) of the discrete band "
                         "(jonswap), >= 0"),
    "wave_period": ("s", "wave period T (regular) or peak period Tp (jonswap), > 0; the components must lie within "
                         "the BEM database's 0.05 .. 5 rad/s"),
    "gamma": ("", "JONSWAP peak enhancement factor, >= 1"),
    "seed": ("", f"JONSWAP random-phase seed (SplitMix64), 0 .. {MAX_SEED}"),
    "n_components": ("", f"JONSWAP components over 0.5 .. 3 w_p, 1 .. {MAX_COMPONENTS}; 0: automatic, "
                         "ceil(2.5 w_p record_length / (2 pi))"),
    "record_length": ("s", "with n_components = 0: the record does not repeat within this length, > 0"),
    "ramp_time": ("s", "the outputs are ramped up as 0.5 (1 - cos(pi t / ramp_time)); <= 0: no ramp"),
    "elevation": ("m", "undisturbed surface elevation at O (the waterplane centre)"),
    **vector_info("F", "N", "wave excitation force on the hull (Froude-Krylov + diffraction, BEM)", "global"),
    **vector_info("M", "N.m", "wave excitation moment on the hull about O (Froude-Krylov + diffraction, BEM)",
                  "global"),
}


class AbsorberWaveRole(WaveRole):
    """The energy brought in: the work of the wave loads on the float, as the float accounts for it."""

    def panels(self, m, r):
        return [Panel("translation", "float translation", "m",
                      [(r.col(m.name, "elevation"), {"color": "k", "lw": 0.8,
                                                     "label": "wave elevation at O" + m.suffix})])]


#: what the wave is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = AbsorberWaveRole()
