"""FlexBody's simulator: a reduced body (flexfmu.body.model.FlexBody) with named inputs and outputs, what an exported
FMU wraps through flexfmu.fmi.plumbing (the Simulator protocol there).  What differs between the kinds is the body's
class's (flexfmu.body.model: FreeBody, ClampedBody: the parameters, variables and engine); the simulator is one.

Variables of a body with interfaces I (names from input_names / output_names):

    free body      inputs  I.F_x, I.F_y, I.F_z (N), I.M_x, I.M_y, I.M_z (N.m; where the patch carries a moment),
                           global frame, held over a communication step
                   outputs I.pos_*, I.vel_*, I.acc_* (global: the rigid fit of the patch's motion, Eq. (I3));
                           pos_*, vel_* (frame origin), q_w .. q_z (body -> global), omega_1..3, alpha_1..3 (body
                           frame), com_pos_*, com_vel_* (global; the deformed body's centre of mass,
                           flexfmu.body.free), max_elastic_displacement; f_1 .. f_k
    clamped body   inputs  I.F_*, I.M_* (body frame); base_a_* (m/s2), base_w_* (rad/s), base_dw_* (rad/s2): the
                           base's acceleration, angular velocity and angular acceleration, body frame (as FFRBeam)
                   outputs I.pos_* (x_I + u_I), I.vel_* (elastic, relative to the base), I.acc_* (absolute:
                           accelerometer), body frame; reaction_F_*, reaction_M_* (on the base, about the body
                           origin, body frame); f_1 .. f_k; q_1 .. q_m (the retained coordinates: eigenmodes,
                           then static-correction vectors; u = Psi q); per gauge G (flexfmu export --gauge):
                           G.sigma_xx .. G.sigma_xz (Pa), G.von_mises (Pa), G.eps_xx .. G.eps_xz (1), body frame

f_1 .. f_k (Hz, constant) are the body's lowest natural frequencies: k = 6, or fewer when the structure has fewer
elastic DOFs (free: without the rigid modes; clamped: of the clamped structure).

Inputs are held over a communication step.  Free body: equal internal steps, counted before stepping (scheme
"consistent": 90 % of the RK4 stability limit; "exponential": by the rotation per step, as ReframeBody); clamped
body: one exact zero-order-hold step of any length (or internal_step sub-steps).  More than max_internal_steps
is refused (StepRejected when a smaller communication step would do); a non-finite input or state is a
NonFiniteError naming the input; a failed step keeps the state of its start.
"""
from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from flexfmu.body.engines import _frame_global  # noqa: F401  (its former home; tests compare the native FMU with it)
# the parameters are declared in flexfmu.body.variables and named here too, where the simulator's callers look
from flexfmu.body.variables import (INITIAL_MOTION, TOLERANCE_RANGE, ClampedBodyConfig, FlexBodyConfig,  # noqa: F401
                                    check_config)
from flexfmu.core.checks import finite_input, shown
from flexfmu.core.stress import evaluate_derived, von_mises
from flexfmu.errors import NonFiniteError, ParameterError

__all__ = ["FlexBodyConfig", "ClampedBodyConfig", "TOLERANCE_RANGE", "FlexBodySimulator", "config_class",
           "input_names", "output_names", "deferred_outputs", "variable_info"]


# what each kind of body has is its class's (flexfmu.body.model: FreeBody, ClampedBody); these name it for the
# callers that hold a body (flexfmu.fmi.body_fmu, tests)
def config_class(body):
    """The parameters of ``body``'s FMU: FlexBodyConfig for a free body, ClampedBodyConfig for a clamped one
    (initial motion, scheme and its tolerance do not apply to a body that moves with its base)."""
    return body.config_class


def input_names(body) -> tuple[str, ...]:
    """The body's inputs in the order of set_input_vector (module docstring)."""
    return body.input_names()


def output_names(body) -> tuple[str, ...]:
    """The body's outputs in the order of output_vector (module docstring)."""
    return body.output_names()


def deferred_outputs(body) -> tuple[str, ...]:
    """Outputs whose cost grows with the mesh (computed only when read, flexfmu.fmi.plumbing)."""
    return tuple(body.deferred_outputs)


def variable_info(body) -> dict[str, tuple[str, str]]:
    """name -> (unit, description) of every parameter, input and output of the body's FMU."""
    return body.variable_info()


class FlexBodySimulator:
    """State and step of one body (module docstring); ``messages``: what the model holds and chose, logged once,
    and the internal-step decisions when they change."""

    def __init__(self, body, config=None):
        if config is None:
            config = body.config_class()
        self.body, self.config = body, config
        zeta = check_config(config, body)
        self.input_names = body.input_names()
        self.output_names = body.output_names()
        #: outputs computed from other outputs after the linear ones (flexfmu.core.stress.DerivedStress): the gauges'
        #: von Mises; the native extraction leaves them out of its linear fit
        self.derived_outputs = body.derived_outputs()
        # every derived output a tensor's von Mises (a body's gauges): their places, for one vectorised von_mises
        # per output vector (what evaluate_derived computes, by the same function, without its per-call lookups)
        index = {name: k for k, name in enumerate(self.output_names)}
        self._von_mises = None
        if self.derived_outputs and all(d.kind == "tensor_von_mises" for d in self.derived_outputs):
            self._von_mises = (np.array([index[d.output] for d in self.derived_outputs]),
                               np.array([[index[s] for s in d.sources] for d in self.derived_outputs]))
        self.engine = body.engine_class(body, config, zeta, self.input_names)
        self.inputs = dict.fromkeys(self.input_names, 0.0)
        self._u = np.zeros(len(self.input_names))
        self._last_split = None
        self.messages = [f"model: {body.summary()}", *body.messages,
                         f"damping ratio {zeta:g}" + (" (the body's)" if config.damping_ratio == -1.0 else "")]

    @property
    def time(self) -> float:
        return self.engine.t

    # ---- inputs
    def set_inputs(self, **inputs: float) -> None:
        index = {n: k for k, n in enumerate(self.input_names)}
        for name, value in inputs.items():
            if name not in index:
                raise ParameterError(name, "unknown input", ", ".join(self.input_names))
            if not finite_input(value):
                if isinstance(value, (int, float, np.floating, np.integer)):
                    raise NonFiniteError(name, f"input is {shown(value)}; allowed: a finite number")
                raise ParameterError(name, f"input is {shown(value)}", "a finite number")
        u = self._u.copy()
        for name, value in inputs.items():
            u[index[name]] = float(value)
        self._u = u
        self.inputs.update({k: float(v) for k, v in inputs.items()})
        self.engine.hold(u)

    def set_input_vector(self, values) -> None:
        """All inputs at once, in input_names order."""
        values = list(values)
        if len(values) != len(self.input_names):
            raise ParameterError("inputs", f"{len(values)} values", f"{len(self.input_names)} values")
        # the FMU's per-step path (finite floats, checked at once); anything else set_inputs checks and names
        if all(type(v) is float for v in values) and all(map(math.isfinite, values)):
            self._u = np.array(values)
            self.inputs = dict(zip(self.input_names, values))
            self.engine.hold(self._u)
            return
        self.set_inputs(**dict(zip(self.input_names, values)))

    # ---- stepping
    def step(self, step_size: float) -> None:
        """Advance by step_size (s) with the inputs held; the state is unchanged on failure."""
        if not (finite_input(step_size) and step_size > 0):
            raise ParameterError("step_size", f"got {shown(step_size)}", "> 0 s")
        with np.errstate(all="ignore"):          # overflow is found by value, whatever numpy's error mode
            n, why = self.engine.split(float(step_size))
            if n != self._last_split:
                self.messages.append(f"t = {self.time:.6g} s: communication step {step_size:g} s in {n} internal "
                                     f"step(s) of {step_size / n:.4g} s: {why}")
                self._last_split = n
            try:
                ok = self.engine.advance(float(step_size), n)
            except (ArithmeticError, ValueError, np.linalg.LinAlgError):
                ok = False
        if not ok:
            raise self._overflow("the state")

    def _overflow(self, what: str) -> NonFiniteError:
        name = self.engine.culprit()
        if name is not None:
            return NonFiniteError(name, f"{self.inputs[name]:g} makes {what} overflow (not finite) at t = "
                                  f"{self.time:.6g} s; allowed: inputs within the model's range")
        # the initial motion a free body started with (a clamped body's config has none, or zeros: check_config)
        start = {n: getattr(self.config, n, 0.0) for n in INITIAL_MOTION}
        if any(start.values()):
            name = max(INITIAL_MOTION, key=lambda n: abs(start[n]))
            return NonFiniteError(name, f"{start[name]:g} makes {what} overflow (not finite) at t = "
                                  f"{self.time:.6g} s")
        return NonFiniteError("state", f"{what} overflows (not finite) at t = {self.time:.6g} s")

    # ---- outputs
    def output_vector(self, include_deferred: bool = True) -> np.ndarray:
        """All outputs in output_names order (max_elastic_displacement = -1 when include_deferred is False)."""
        with np.errstate(all="ignore"):
            y = self.engine.output_vector(include_deferred)
            if self._von_mises is not None:
                y[self._von_mises[0]] = von_mises(y[self._von_mises[1]])
            elif self.derived_outputs:
                evaluate_derived(self.derived_outputs, self.output_names, y)
        # y.y is finite when y is (unless |y| > 1e154): the element-wise check only then
        if not y.dot(y) < math.inf and not np.all(np.isfinite(y)):
            bad = [self.output_names[i] for i in np.flatnonzero(~np.isfinite(y))]
            raise self._overflow(", ".join(bad[:4]))
        return y

    def deferred_output_vector(self) -> list[float]:
        """The body's deferred_outputs (flexfmu.fmi.plumbing reads them only when asked)."""
        y = self.output_vector()
        return [float(y[self.output_names.index(name)]) for name in self.body.deferred_outputs]

    def outputs(self) -> dict[str, float]:
        return dict(zip(self.output_names, self.output_vector().tolist()))

    def lti_probe(self):
        """A clamped body's maps as flexfmu.native.lti's Probe (flexfmu.body.lti_probe), for
        ``LtiModel.from_clamped_body``: the native FMU's linear system is extracted from them (the body's
        lti_probe: ParameterError for a free body)."""
        return self.body.lti_probe(self)

    # ---- state (JSON): the body's kind is recorded so that a state is refused by a body of the other kind
    def get_state(self) -> dict:
        return {"kind": self.body.kind, **self.engine.get(), "inputs": dict(self.inputs), "config": asdict(self.config)}

    def set_state(self, data: dict) -> None:
        if data.get("config") != asdict(self.config) or data.get("kind") != self.body.kind:
            raise ParameterError("FMUstate", "was taken with other parameters or another body",
                                 "a state of this configuration")
        inputs = data.get("inputs")
        if not isinstance(inputs, dict) or set(inputs) != set(self.input_names):
            raise ParameterError("FMUstate", "inputs of another body", "a state of this body")
        self.engine.put(data)
        self.set_inputs(**inputs)
