"""ReframeBody: the reframe integrator with named inputs and outputs (what ReframeBody.fmu wraps).

Inputs are held over each communication step (zero-order hold); the step is split into equal
internal RK4 steps no longer than ``internal_step`` (0: automatic, 90 % of the RK4 stability
limit 2.8 / omega_max of the highest retained flexible mode).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np

from flexfmu.errors import ParameterError, require
from flexfmu.modal_basis import modal_basis
from flexfmu.models import load_model
from flexfmu.reframe import RK4_STABILITY_LIMIT, SCHEMES, PointLoad, ReframeIntegrator, ReframeState

AXES = ("x", "y", "z")
INPUT_NAMES = tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
OUTPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"vel_{a}" for a in AXES)
                + ("q_w", "q_x", "q_y", "q_z") + tuple(f"omega_{i}" for i in (1, 2, 3))
                + tuple(f"alpha_{i}" for i in (1, 2, 3)) + tuple(f"com_pos_{a}" for a in AXES)
                + tuple(f"com_vel_{a}" for a in AXES) + tuple(f"out_pos_{a}" for a in AXES)
                + tuple(f"out_vel_{a}" for a in AXES) + tuple(f"out_acc_{a}" for a in AXES)
                + tuple(f"out_acc_rigid_{a}" for a in AXES) + ("max_elastic_displacement",))
_AUTO_STEP_FRACTION = 0.9   # of the RK4 stability limit, for internal_step = 0


def output_values(outputs) -> np.ndarray:
    """The OUTPUT_NAMES columns of a reframe Snapshot (shape (34,)) or ReframeResult ((n_t, 34)); the
    output point is the first recorded point.  Used by the FMU and by ``flexfmu reframe --out``."""
    parts = [outputs.frame_origin, outputs.frame_origin_velocity, outputs.quaternion, outputs.omega,
             outputs.alpha, outputs.com_position, outputs.com_velocity, outputs.point_position[..., 0, :],
             outputs.point_velocity[..., 0, :], outputs.point_acceleration[..., 0, :],
             outputs.point_acceleration_rigid[..., 0, :], np.asarray(outputs.max_elastic_displacement)[..., None]]
    return np.concatenate(parts, axis=-1)


@dataclass(frozen=True)
class ReframeBodyConfig:
    """Parameters, named and defaulted as in the FMU (defaults: the paper's plate and load case)."""

    model: str = "paper_plate"
    scheme: str = "consistent"
    n_flexible_modes: int = 10
    damping_ratio: float = 0.05
    internal_step: float = 0.0
    load_point_x: float = -0.5      # the paper's load point, midway between P5 and P8
    load_point_y: float = 0.0
    load_point_z: float = 0.01
    output_point_x: float = -0.5    # P1
    output_point_y: float = -0.025
    output_point_z: float = 0.0
    force_follows_body: bool = False
    v0_x: float = 0.0
    v0_y: float = 0.0
    v0_z: float = 0.0
    omega0_1: float = 0.0
    omega0_2: float = 0.0
    omega0_3: float = 0.0


@lru_cache(maxsize=4)
def _integrator(model: str, n_flexible_modes: int, damping_ratio: float, scheme: str) -> ReframeIntegrator:
    """Model, modes and integrator set-up, shared by instances (``advance`` does not touch its state)."""
    require(scheme in SCHEMES, "scheme", f"got {scheme!r}", " | ".join(SCHEMES))
    require(np.isfinite(damping_ratio) and 0.0 <= damping_ratio < 1.0, "damping_ratio",
            f"got {damping_ratio!r}", "0 <= damping_ratio < 1")
    structure = load_model(model)
    require(isinstance(n_flexible_modes, (int, np.integer)) and 0 <= n_flexible_modes <= structure.n_dof - 6,
            "n_flexible_modes", f"got {n_flexible_modes!r}", f"0 .. {structure.n_dof - 6}")
    basis = modal_basis(structure, int(n_flexible_modes), damping_ratio)
    return ReframeIntegrator(structure, basis, scheme=scheme)


class ReframeBodySimulator:
    """State and step of one ReframeBody instance."""

    def __init__(self, config: ReframeBodyConfig = ReframeBodyConfig()):
        self.config = c = config
        for name in ("load_point_x", "load_point_y", "load_point_z", "output_point_x", "output_point_y",
                     "output_point_z", "v0_x", "v0_y", "v0_z", "omega0_1", "omega0_2", "omega0_3"):
            require(math.isfinite(getattr(c, name)), name, f"got {getattr(c, name)!r}", "a finite number")
        self.integrator = integ = _integrator(c.model, c.n_flexible_modes, c.damping_ratio, c.scheme)
        limit = RK4_STABILITY_LIMIT / integ.data.omega_max if integ.data.omega_max > 0 else math.inf
        require(math.isfinite(c.internal_step) and 0.0 <= c.internal_step <= limit, "internal_step",
                f"{c.internal_step!r} s exceeds the RK4 stability limit 2.8 / omega_max"
                if c.internal_step > limit else f"got {c.internal_step!r}",
                f"0 (automatic) .. {limit:.6g} s for {c.n_flexible_modes} flexible modes")
        self.max_internal_step = c.internal_step if c.internal_step > 0 else _AUTO_STEP_FRACTION * limit
        self._force = np.zeros(3)
        self._moment = np.zeros(3)
        rotational = integ.data.structure.dofs_per_node == 6
        # Constant histories, replaced by the held input at each set_inputs (Prepared.set_held).
        load = PointLoad((c.load_point_x, c.load_point_y, c.load_point_z), force=self._force.copy(),
                         moment=self._moment.copy() if rotational else None, follower=c.force_follows_body)
        self._accepts_moment = rotational
        self._loads = integ.prepare_loads(load)
        self._points = integ.point_indices([(c.output_point_x, c.output_point_y, c.output_point_z)])
        nf = integ.data.nf
        o = 23 + 2 * nf                 # flexfmu.reframe.ReframeIntegrator.output_vector layout, one point
        self._columns = np.r_[0:22, o:o + 9, o + 15:o + 18, 22 + 2 * nf]
        self.state = integ.initial_state(v0=(c.v0_x, c.v0_y, c.v0_z), omega0=(c.omega0_1, c.omega0_2, c.omega0_3))
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)

    @property
    def time(self) -> float:
        return self.state.t

    def internal_steps(self, step_size: float) -> int:
        """Number of equal internal steps a communication step of step_size (s) is split into."""
        return max(1, math.ceil(step_size / self.max_internal_step * (1 - 1e-12)))

    def set_inputs(self, **inputs: float) -> None:
        for name, value in inputs.items():
            require(name in INPUT_NAMES, name, "unknown input", ", ".join(INPUT_NAMES))
            require(math.isfinite(value), name, f"input is {value!r}", "a finite number")
            if name.startswith("M_") and value != 0.0:
                require(self._accepts_moment, name, "moments need a model with rotational DOFs (beam:<scene>)",
                        "0 for models with 3 DOFs per node")
        self.inputs.update({k: float(v) for k, v in inputs.items()})
        self._hold(np.array([self.inputs[f"F_{a}"] for a in AXES]), np.array([self.inputs[f"M_{a}"] for a in AXES]))

    def _hold(self, force, moment) -> None:
        if not (np.array_equal(force, self._force) and np.array_equal(moment, self._moment)):
            self._force, self._moment = force, moment
            self._loads.set_held(0, force, moment if self._accepts_moment else None)

    def set_input_vector(self, values) -> None:
        """All inputs at once, in INPUT_NAMES order (the FMU's per-step path)."""
        vals = [float(v) for v in values]
        if len(vals) != len(INPUT_NAMES) or not all(map(math.isfinite, vals)) or \
                (not self._accepts_moment and any(vals[3:6])):
            self.set_inputs(**dict(zip(INPUT_NAMES, vals)))
            return
        self.inputs = dict(zip(INPUT_NAMES, vals))
        self._hold(np.array(vals[0:3]), np.array(vals[3:6]))

    def step(self, step_size: float) -> None:
        """Equal internal RK4 steps over step_size (s) with the inputs held, in one kernel call."""
        require(math.isfinite(step_size) and step_size > 0, "step_size", f"got {step_size!r}", "> 0 s")
        n = self.internal_steps(step_size)
        self.state = self.integrator.advance_steps(self.state, step_size / n, n, self._loads)

    def output_vector(self) -> np.ndarray:
        """All outputs (OUTPUT_NAMES order) of the current state."""
        integ = self.integrator
        if integ.scheme == "consistent":
            return integ.output_vector(self.state, self._loads, self._points)[self._columns]
        return output_values(integ.snapshot(self.state, self._loads, self._points))

    def outputs(self) -> dict[str, float]:
        return dict(zip(OUTPUT_NAMES, self.output_vector().tolist()))

    # ---- state for FMI get/set/serialize: plain JSON-able data
    def get_state(self) -> dict:
        s = self.state
        return {"t": s.t, "position": s.position.tolist(), "rotation": s.rotation.tolist(), "eta": s.eta.tolist(),
                "rotvec": None if s.rotvec is None else s.rotvec.tolist(), "inputs": dict(self.inputs),
                "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        if data.get("config") != asdict(self.config):
            raise ParameterError("FMUstate", "was taken with other parameters", "a state of this configuration")
        self.state = ReframeState(t=float(data["t"]), position=np.array(data["position"]),
                                  rotation=np.array(data["rotation"]), eta=np.array(data["eta"]),
                                  rotvec=None if data["rotvec"] is None else np.array(data["rotvec"]))
        self.set_inputs(**data["inputs"])


def _info(names, unit, text):
    return {n: (unit, f"{text}, {n.rsplit('_', 1)[-1]}") for n in names}


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "model": ("", "paper_plate | beam:<scene> (free-free bent rod) | path to a .npz structure file"),
    "scheme": ("", "consistent (default) | paper (the printed scheme, first order)"),
    "n_flexible_modes": ("", "retained flexible modes; 0 = a rigid body"),
    "damping_ratio": ("", "modal damping ratio of every flexible mode, 0 <= zeta < 1"),
    "internal_step": ("s", "longest internal RK4 step; 0 = automatic (90% of the stability limit)"),
    **_info(("load_point_x", "load_point_y", "load_point_z"), "m", "load point, undeformed body coordinates"),
    **_info(("output_point_x", "output_point_y", "output_point_z"), "m", "output point, undeformed body coordinates"),
    "force_follows_body": ("", "false: F, M in the global frame; true: in the body frame"),
    **_info(("v0_x", "v0_y", "v0_z"), "m/s", "initial velocity of the centre of mass, global"),
    **_info(("omega0_1", "omega0_2", "omega0_3"), "rad/s", "initial angular velocity, body frame"),
    **_info(("F_x", "F_y", "F_z"), "N", "force at the load point (global unless force_follows_body)"),
    **_info(("M_x", "M_y", "M_z"), "N.m", "moment at the load point (6-DOF models only)"),
    **_info(OUTPUT_NAMES[0:3], "m", "frame origin position, global"),
    **_info(OUTPUT_NAMES[3:6], "m/s", "frame origin velocity (rigid with the dummy body), global"),
    **_info(OUTPUT_NAMES[6:10], "", "orientation quaternion body -> global, scalar first"),
    **_info(OUTPUT_NAMES[10:13], "rad/s", "angular velocity, body frame"),
    **_info(OUTPUT_NAMES[13:16], "rad/s2", "angular acceleration, body frame"),
    **_info(OUTPUT_NAMES[16:19], "m", "centre of mass of the dummy rigid body, global (the deformed body's "
                                      "differs by second-order elastic terms on beam models)"),
    **_info(OUTPUT_NAMES[19:22], "m/s", "centre of mass velocity, global"),
    **_info(OUTPUT_NAMES[22:25], "m", "output point position, global, full motion"),
    **_info(OUTPUT_NAMES[25:28], "m/s", "output point velocity, global, full motion"),
    **_info(OUTPUT_NAMES[28:31], "m/s2", "output point acceleration, global, full motion"),
    **_info(OUTPUT_NAMES[31:34], "m/s2", "output point acceleration, embedded rigid part, global"),
    "max_elastic_displacement": ("m", "largest elastic nodal displacement"),
}
