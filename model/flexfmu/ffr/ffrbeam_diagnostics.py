"""FFRBeam's failure diagnostics (flexfmu.ffr.simulator): the error of a step, an output or a set of maps that
overflows, diverges or would take too many RK4 sub-steps, naming the input or parameter behind it.

:class:`FFRBeamDiagnostics` is a base class of FFRBeamSimulator and is not used on its own: its methods read the
simulator's inputs, dynamics, configuration, state and maps."""
from __future__ import annotations

import math

import numpy as np

from flexfmu.core.checks import MIN_COMMUNICATION_STEP, culprit
from flexfmu.errors import DivergenceError, FlexfmuError, NonFiniteError, StepRejected
from flexfmu.ffr.dynamics import RK4_STABILITY_LIMIT, BaseMotion
from flexfmu.ffr.ffrbeam_config import AXES, INPUT_NAMES, OUTPUT_NAMES, RK4_STEP_FRACTION
from flexfmu.native import step_policy

# The state norm beyond which a run counts as diverged (m-scale modal coordinates of a rod).
_DIVERGENCE_LIMIT = 1e6
_NO_ROTATION = BaseMotion()


class FFRBeamDiagnostics:
    """Which input, parameter or step a failure of FFRBeamSimulator names (see the module docstring)."""

    def _base_culprit(self) -> str | None:
        """The held base input that most likely overflowed the maps: omega enters squared, alpha and (with
        geometric stiffening) a0 linearly."""
        u = self._u.tolist()                  # Python floats: w * w is inf on overflow, without a warning
        scores = {f"base_w_{a}": abs(u[9 + i]) * abs(u[9 + i]) for i, a in enumerate(AXES)}
        scores.update({f"base_dw_{a}": abs(u[12 + i]) for i, a in enumerate(AXES)})
        if self.dynamics.geometric_stiffening:
            scores.update({f"base_a_{a}": abs(u[6 + i]) for i, a in enumerate(AXES)})
        return culprit(scores)

    def _map_failure(self, h, base: BaseMotion) -> FlexfmuError:
        """The error for maps that are not finite: the held base motion, else the step size (the step's
        transition matrix overflows; a smaller step would do)."""
        name = self._base_culprit()
        if name is not None:
            try:
                with np.errstate(all="ignore"):
                    maps = self.dynamics.fast_maps(h, _NO_ROTATION)
                still = not all(np.all(np.isfinite(a)) for a in maps if a is not None)
            except (np.linalg.LinAlgError, ArithmeticError, ValueError):
                still = True
            if not still or h is None:
                unit = "m/s2" if name.startswith("base_a") else "rad/s2" if name.startswith("base_dw") else "rad/s"
                return NonFiniteError(name, f"{self.inputs[name]:.6g} {unit}: the held base motion's inertial loads "
                                            "(omega^2, alpha, a0 times the rod's mass distribution) overflow the "
                                            "model's maps (not finite); allowed: a base motion within the "
                                            "floating-point range of the model (|omega| well below 1e150 rad/s)")
        if h is None:
            return NonFiniteError(name or "base motion", "the output maps of the held inputs are not finite")
        return StepRejected("step_size", f"a communication step of {h!r} s makes the step's transition matrix "
                                         "overflow (not finite); take a smaller communication step")

    def _too_many_steps(self, h: float, limit: float, ratio: float) -> FlexfmuError:
        """More RK4 sub-steps than max_internal_steps (flexfmu.native.step_policy, in its RK4 wording): StepRejected
        when a communication step of at least MIN_COMMUNICATION_STEP would be within the cap, else ParameterError
        naming the held base rotation (when without it the limit would allow that) or the integrator (the highest
        retained mode sets the limit)."""
        cap = self.config.max_internal_steps
        return step_policy.refusal(h, ratio, cap, cap * RK4_STEP_FRACTION * limit, lambda: self._rk4_cause(limit),
                                   rk4_limit=limit)

    def _rk4_cause(self, limit: float):
        cap = self.config.max_internal_steps
        name = self._base_culprit()
        if name is not None:
            try:
                free = self.dynamics.rk4_step_limit(_NO_ROTATION)
            except (np.linalg.LinAlgError, ArithmeticError, ValueError):
                free = 0.0
            if cap * RK4_STEP_FRACTION * free >= MIN_COMMUNICATION_STEP:
                return step_policy.Cause(name, "a smaller base rotation, or integrator exact (no step limit)",
                                         f"{self.inputs[name]:.6g}: the held base motion makes ")
        f_top = RK4_STABILITY_LIMIT / limit / (2 * math.pi)
        return step_policy.Cause("integrator", "integrator exact (no step limit), fewer modes, or a larger "
                                 "max_internal_steps", after=f" (highest retained mode {f_top:.6g} Hz)")

    def _divergence(self, t: float, size: float, Ad, Bu, b0) -> FlexfmuError:
        """The error of a step whose state left the linear model's range: NonFiniteError when not finite,
        ParameterError ("diverged") when beyond _DIVERGENCE_LIMIT; named after the load input or the held base
        motion when one alone does it in this step, else the state (a dynamic instability)."""
        with np.errstate(all="ignore"):
            scores = {name: float(np.max(np.abs(Bu[:, j] * self._u[j]))) for j, name in enumerate(INPUT_NAMES[:9])}
            base = self._base_culprit()
            if base is not None and b0 is not None:
                scores[base] = float(np.max(np.abs(b0)))
        name = culprit({k: v for k, v in scores.items() if not v <= _DIVERGENCE_LIMIT})
        if not math.isfinite(t):
            return NonFiniteError("step_size", f"the time t + step_size overflows at t = {self.state.t!r} s")
        if not np.isfinite(size):
            cause = name or "state"
            shown = f"{self.inputs[cause]:.6g} makes" if name else "the modal state"
            return NonFiniteError(cause, f"{shown} the modal state overflow (not finite) at t = {t:.6g} s: the state "
                                         "diverged; allowed: inputs within the linear model's range")
        return DivergenceError(name or "state", f"diverged at t = {t:.6g} s (modal state norm {size:.3g})"
                              + (f": {name} = {self.inputs[name]:.6g} alone moves it beyond {_DIVERGENCE_LIMIT:g}"
                                 if name else ""),
                              "inputs within the linear model's range; spin below the first bending frequency")

    def _output_failure(self, y) -> NonFiniteError:
        """NonFiniteError naming the input that alone makes an output overflow (the outputs are affine in F, M,
        a0 with the base rotation held, the energy quadratic)."""
        maps = self._maps(None)
        Cx, Cu, energy = maps.Cx, maps.Cu, maps.energy
        eta = self.state.eta
        bad = [OUTPUT_NAMES[i] for i in np.nonzero(~np.isfinite(y))[0]] if y is not None else ["the outputs"]
        scores = {}
        with np.errstate(all="ignore"):
            for j, name in enumerate(INPUT_NAMES[:9]):
                uj = self._u[j]
                part = np.abs(Cu[:, j] * uj)
                if energy is not None:
                    part = np.append(part, abs(energy[0][j, j] * uj * uj) + abs(energy[1][j] * uj))
                scores[name] = float(np.max(part)) if np.all(np.isfinite(part)) else math.inf
            scores["state"] = float(np.max(np.abs(Cx @ np.concatenate((eta, self.state.eta_dot)))))
        name = culprit({k: v for k, v in scores.items() if not v < 1e300}) or culprit(scores) or "state"
        shown = f"{self.inputs[name]:.6g} makes" if name in self.inputs else "the modal state makes"
        return NonFiniteError(name, f"{shown} {', '.join(bad)} overflow (not finite) at t = {self.time:.6g} s; "
                                    "allowed: inputs within the linear model's range")
