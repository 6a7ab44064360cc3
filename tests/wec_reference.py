"""A numpy transcription of the point absorber's four components as the lead's specification writes them
(/work/pa_spec.md: wave, float, hydro, PTO), independent of both the Python simulators (flexfmu.wec.absorber) and
the native C kind (csrc/native_wec.c), and a stand-in hull of random but valid data with stand-in FMU specs, so the
native kind is tested without the BEM database (Capytaine, minutes) and with data that exercise every coupling
(full 6x6 mass, stiffness and radiation matrices, where the real cylinder's are mostly diagonal)."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, make_dataclass

import numpy as np
import scipy.linalg

DOFS = ("x", "y", "z", "rx", "ry", "rz")
AXES = ("F_x", "F_y", "F_z", "M_x", "M_y", "M_z")
GROUPS = ("wave", "hydro", "pto", "mooring")


# ---------------------------------------------------------------------------------------------- stand-in hull
@dataclass(frozen=True, eq=False)
class StandInRadiation:
    A_r: np.ndarray
    B_r: np.ndarray
    C_r: np.ndarray

    def discretize(self, h: float):
        """(Phi, Gamma) = expm([[A_r, B_r], [0, 0]] h), as flexfmu.wec.radiation.RadiationModel.discretize."""
        n, m = self.B_r.shape
        aug = np.zeros((n + m, n + m))
        aug[:n, :n], aug[:n, n:] = self.A_r * h, self.B_r * h
        E = scipy.linalg.expm(aug)
        return E[:n, :n], E[:n, n:]


@dataclass(frozen=True, eq=False)
class StandInHull:
    """The fields of flexfmu.wec.absorber.hull.AbsorberHull the native kind reads."""

    rho: float
    M_rb: np.ndarray
    A_inf: np.ndarray
    C: np.ndarray
    radiation: StandInRadiation
    omega: np.ndarray
    X: np.ndarray

    @property
    def M_total(self) -> np.ndarray:
        return self.M_rb + self.A_inf


def _spd(rng, scale: float) -> np.ndarray:
    """A symmetric positive definite 6x6 of order ``scale`` with condition number < 10."""
    Q, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    return scale * (Q * rng.uniform(1.0, 8.0, 6)) @ Q.T


def stand_in_hull(seed: int = 7, order: int = 10) -> StandInHull:
    """Random but valid data of the point absorber's size: masses ~2.4e5 kg, stiffness ~8e5 N/m, a stable
    radiation model of ``order`` states (eigenvalues -0.2 .. -3 +- 0.5 .. 4 i 1/s), a smooth complex excitation
    ~1e5 N/m over 0.05 .. 5 rad/s (100 frequencies, as the real database's)."""
    rng = np.random.default_rng(seed)
    M_rb, A_inf = _spd(rng, 2.4e5), _spd(rng, 1.0e5)
    C = _spd(rng, 8.0e5)
    blocks = []
    for _ in range(order // 2):
        sigma, w = rng.uniform(0.2, 3.0), rng.uniform(0.5, 4.0)
        blocks.append(np.array([[-sigma, w], [-w, -sigma]]))
    T = rng.normal(size=(order, order)) + 3 * np.eye(order)
    A_r = T @ scipy.linalg.block_diag(*blocks) @ np.linalg.inv(T)
    B_r, C_r = rng.normal(size=(order, 6)), 1e5 * rng.normal(size=(6, order))
    omega = np.linspace(0.05, 5.0, 100)
    phase = np.outer(omega, rng.uniform(0.2, 2.0, 6)) + rng.uniform(0, 2 * np.pi, 6)
    X = 1e5 * rng.uniform(0.3, 1.0, 6) * np.exp(-0.3 * omega)[:, None] * np.exp(1j * phase)
    return StandInHull(1025.0, M_rb, A_inf, C, StandInRadiation(A_r, B_r, C_r), omega, X)


# ---------------------------------------------------------------------------------------------- stand-in specs
WAVE_DEFAULTS = {"sea_state": "regular", "wave_height": 2.0, "wave_period": 8.0, "gamma": 3.3, "seed": 1,
                 "n_components": 0, "record_length": 1200.0, "ramp_time": 20.0}
FLOAT_DEFAULTS = {"heave_only": False}
HYDRO_DEFAULTS = {"drag": True, **{f"drag_coefficient_{d}": 0.0 if d.startswith("r") else 1.0 for d in DOFS},
                  **{f"drag_area_{d}": a for d, a in zip(DOFS, (30.0, 30.0, math.pi * 25, 0.0, 0.0, 0.0))}}
PTO_DEFAULTS = {"damping": 2.0e5, "stiffness": 0.0, "force_limit": 0.0}

WAVE_OUTPUTS = ("elevation", *AXES)
FLOAT_INPUTS = tuple(f"{g}_{a}" for g in GROUPS for a in AXES)
MOTION = tuple(f"{q}_{a}" for q in ("pos", "rot", "vel", "omega") for a in "xyz")
FLOAT_OUTPUTS = (*MOTION, *(f"{q}_{a}" for q in ("acc", "alpha") for a in "xyz"), "kinetic_energy",
                 *(f"work_{g}" for g in GROUPS))
HYDRO_OUTPUTS = (*AXES, "drag_power")


def _unit(name: str) -> str:
    if name.startswith(("F_", "wave_F", "hydro_F", "pto_F", "mooring_F")):
        return "N"
    if name.startswith(("M_", "wave_M", "hydro_M", "pto_M", "mooring_M")):
        return "N.m"
    return {"pos": "m", "vel": "m/s", "acc": "m/s2", "omega": "rad/s", "alpha": "rad/s2", "work": "J",
            "kinetic": "J", "elevation": "m", "wave": "m", "ramp": "s", "record": "s"}.get(name.split("_")[0], "")


@dataclass(frozen=True)
class StandInSpec:
    """What flexfmu.fmi.native and native_build ask of an FMU spec (flexfmu.fmi.registry.FmuSpec)."""

    name: str
    config_class: type
    input_names: tuple
    output_names: tuple
    description: str = "stand-in point-absorber component (tests/wec_reference.py)"
    experiment: dict = field(default_factory=lambda: {"startTime": "0", "stopTime": "20", "stepSize": "0.01"})
    deferred_outputs: tuple = ()
    module: str = "tests.wec_reference"

    @property
    def variable_info(self) -> dict:
        names = (*asdict(self.config_class()), *self.input_names, *self.output_names)
        return {n: (_unit(n), n.replace("_", " ")) for n in names}


def _config(name: str, defaults: dict) -> type:
    return make_dataclass(name, [(k, type(v), field(default=v)) for k, v in defaults.items()], frozen=True)


SPECS = {
    "AbsorberWave": StandInSpec("AbsorberWave", _config("WaveConfig", WAVE_DEFAULTS), (), WAVE_OUTPUTS),
    "AbsorberFloat": StandInSpec("AbsorberFloat", _config("FloatConfig", FLOAT_DEFAULTS), FLOAT_INPUTS,
                                 FLOAT_OUTPUTS),
    "AbsorberHydro": StandInSpec("AbsorberHydro", _config("HydroConfig", HYDRO_DEFAULTS), MOTION, HYDRO_OUTPUTS),
    "HeavePTO": StandInSpec("HeavePTO", _config("PtoConfig", PTO_DEFAULTS), ("pos_z", "vel_z"), ("F_z", "power")),
}


# ---------------------------------------------------------------------------------------------- the reference
def splitmix64(seed: int, n: int) -> np.ndarray:
    """n uniforms in [0, 1) from SplitMix64 seeded with ``seed`` (the specification's recipe, Python integers)."""
    mask, state, out = (1 << 64) - 1, seed & ((1 << 64) - 1), []
    for _ in range(n):
        state = (state + 0x9E3779B97F4A7C15) & mask
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
        z ^= z >> 31
        out.append((z >> 11) * 2.0**-53)
    return np.array(out)


def wave_components(p: dict, hull) -> tuple:
    """(w, a, phi, X per unit amplitude (n, 6)) of the wave's parameters ``p``."""
    if p["sea_state"] == "regular":
        w, a, phi = np.array([2 * np.pi / p["wave_period"]]), np.array([p["wave_height"] / 2]), np.zeros(1)
    else:
        wp = 2 * np.pi / p["wave_period"]
        n = p["n_components"] or math.ceil(2.5 * p["record_length"] / p["wave_period"] - 1e-9)
        dw = 2.5 * wp / n
        w = 0.5 * wp + (np.arange(n) + 0.5) * dw
        sigma = np.where(w <= wp, 0.07, 0.09)
        s = w**-5.0 * np.exp(-1.25 * (wp / w) ** 4) * p["gamma"] ** np.exp(-(w - wp) ** 2 / (2 * sigma**2 * wp**2))
        S = (p["wave_height"] / 4) ** 2 * s / (dw * s.sum())
        a, phi = np.sqrt(2 * S * dw), 2 * np.pi * splitmix64(p["seed"], n)
    X = np.stack([np.interp(w, hull.omega, hull.X[:, i].real) + 1j * np.interp(w, hull.omega, hull.X[:, i].imag)
                  for i in range(6)], axis=1)
    return w, a, phi, X


def ramp(t: float, ramp_time: float) -> float:
    if ramp_time <= 0 or t >= ramp_time:
        return 1.0
    return 0.0 if t <= 0 else 0.5 * (1 - math.cos(math.pi * t / ramp_time))


def wave_outputs(p: dict, hull, t: float, components=None) -> np.ndarray:
    """[elevation, F (3), M (3)] at t: r(t) sum_k Re(X_k a_k e^{i phi_k} e^{-i w_k t})."""
    w, a, phi, X = components or wave_components(p, hull)
    r = ramp(t, p["ramp_time"])
    phasor = a * np.exp(1j * (phi - w * t))
    return r * np.concatenate([[np.sum(a * np.cos(w * t - phi))], (X.T @ phasor).real])


class FloatReference:
    def __init__(self, p: dict, hull):
        self.heave_only, self.M = p["heave_only"], hull.M_total
        self.M_inv = np.linalg.inv(self.M)
        self.xi, self.v, self.work = np.zeros(6), np.zeros(6), np.zeros(4)

    def acc(self, u):
        Q = np.asarray(u, float).reshape(4, 6).sum(axis=0)
        if self.heave_only:
            return np.array([0, 0, Q[2] / self.M[2, 2], 0, 0, 0])
        return self.M_inv @ Q

    def step(self, u, h):
        acc = self.acc(u)
        d = h * self.v + h**2 / 2 * acc
        self.work += np.asarray(u, float).reshape(4, 6) @ d
        self.xi, self.v = self.xi + d, self.v + h * acc

    def outputs(self, u):
        return np.concatenate([self.xi, self.v, self.acc(u), [0.5 * self.v @ self.M @ self.v], self.work])


class HydroReference:
    def __init__(self, p: dict, hull):
        self.p, self.hull = p, hull
        self.x = np.zeros(hull.radiation.A_r.shape[0])
        self.maps = {}

    def step(self, u, h):
        if h not in self.maps:
            self.maps[h] = self.hull.radiation.discretize(h)
        Phi, Gamma = self.maps[h]
        self.x = Phi @ self.x + Gamma @ np.asarray(u[6:], float)

    def outputs(self, u):
        xi, v = np.asarray(u[:6], float), np.asarray(u[6:], float)
        cd = np.array([self.p[f"drag_coefficient_{d}"] for d in DOFS])
        area = np.array([self.p[f"drag_area_{d}"] for d in DOFS])
        drag = 0.5 * self.hull.rho * cd * area * np.abs(v) * v if self.p["drag"] else np.zeros(6)
        F = -self.hull.C @ xi - self.hull.radiation.C_r @ self.x - drag
        return np.concatenate([F, [drag @ v]])


def pto_outputs(p: dict, u) -> np.ndarray:
    z, v = u
    F = -(p["damping"] * v + p["stiffness"] * z)
    if p["force_limit"] > 0:
        F = min(max(F, -p["force_limit"]), p["force_limit"])
    return np.array([F, -F * v])
