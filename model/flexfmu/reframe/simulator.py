"""ReframeBody: the reframe integrator with named inputs and outputs (what ReframeBody.fmu wraps).

Inputs are held over each communication step (zero-order hold); the step is split into equal
internal steps (one kernel call).  ``internal_step`` > 0 is the longest internal step; 0 chooses:

* schemes "consistent" and "paper" (RK4, stable while dt omega_max <= 2.8): 90 % of the stability
  limit 2.8 / omega_max of the highest retained flexible mode, so a communication step beyond the
  limit is sub-stepped; an explicit ``internal_step`` beyond the limit is refused;
* scheme "exponential" (exact for the modes' linear part, no stability limit): by accuracy.  With
  the inputs held, the only thing that varies inside a communication step is the rigid motion, so the
  step is split until the rotation per internal step, |omega| h + |alpha| h^2 / 2 (at the start of the
  communication step, with the new inputs), is at most ``0.5 tolerance^(1/4)`` rad (RK4's error in the
  attitude is ~ (|omega| h)^4 per step): one internal step per communication step for a body that
  does not spin fast.

The count is known before stepping; more than ``max_internal_steps`` is refused (flexfmu.native.step_policy):
StepRejected (fmi2Discard) when a communication step of at least 1e-5 s would be within the cap, else a
ParameterError naming the input (the force behind the angular acceleration) or the initial spin.  Overflow of the
state or the outputs is a NonFiniteError naming its likely cause; a failed step keeps the state of its start.

The messages list collects what was chosen and why (model size with ``n_flexible_modes = -1``, the
internal step and its reason, logged once and again when it changes); the FMU logs them (status OK).

``n_flexible_modes = -1`` chooses the model: every flexible mode up to ``f_max`` (Hz), then more, until the
estimated dynamic truncation error (flexfmu.sizing.model_size Eq. (E): omitted modes' static shares times their
dynamic amplification at f_max, mode-acceleration method) of the elastic deflection of the load point and
of the output point, under a force (and, on 6-DOF models, a moment) at the load point with inertia relief,
is within ``tolerance`` / 2; then a static correction: if the static deflection of the load or output
point from these modes differs from the full model's (inertia relief, one sparse solve) by more than
``tolerance`` (relative, worst direction), the residual flexibility of the load point is added as up to
6 extra Ritz vectors (residual-flexibility method: the exact static deflections minus their modal part,
M-orthonormalised and K-diagonalised), so the static deflection under loads at the load point is exact
everywhere.  The Ritz vectors respond dynamically at their Rayleigh frequency (at least the first omitted
mode's), which the estimate includes.  They are stiff (Rayleigh frequencies well above f_max): pair
them with scheme "exponential" (no stability limit; O(nf^2) per step like the modes), with an RK4 scheme
they set the step limit.
"""
from __future__ import annotations

import math
from dataclasses import asdict
from functools import lru_cache

import numpy as np

from flexfmu.core.step_size import StepSizes
from flexfmu.core.blas import limited_for
from flexfmu.core.checks import MIN_COMMUNICATION_STEP, culprit, finite_input, shown
from flexfmu.errors import FlexfmuError, NonFiniteError, ParameterError, require
from flexfmu.sizing.solid import BasisChoice, auto_basis
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.native import step_policy
from flexfmu.reframe.models import load_model
from flexfmu.reframe.layout import output_layout
from flexfmu.reframe.integrator import RK4_STABILITY_LIMIT, SCHEMES, PointLoad, ReframeIntegrator, ReframeState
# the parameters, their checks and the variables' names and meaning (importable from here, as the registry does)
from flexfmu.reframe.body_config import (AXES, DEFERRED_OUTPUTS, INPUT_NAMES, OUTPUT_NAMES,  # noqa: F401
                                         TOLERANCE_RANGE, VARIABLE_INFO, ReframeBodyConfig, _INITIAL,
                                         check_config, check_model_size, check_points)

_INF = math.inf             # a module constant: cheaper than math.inf on the per-step path
_AUTO_STEP_FRACTION = 0.9   # of the RK4 stability limit, for internal_step = 0


def output_values(outputs) -> np.ndarray:
    """The OUTPUT_NAMES columns of a reframe Snapshot (shape (34,)) or ReframeResult ((n_t, 34)); the
    output point is the first recorded point.  Used by the FMU and by ``flexfmu reframe --out``."""
    parts = [outputs.frame_origin, outputs.frame_origin_velocity, outputs.quaternion, outputs.omega,
             outputs.alpha, outputs.com_position, outputs.com_velocity, outputs.point_position[..., 0, :],
             outputs.point_velocity[..., 0, :], outputs.point_acceleration[..., 0, :],
             outputs.point_acceleration_rigid[..., 0, :], np.asarray(outputs.max_elastic_displacement)[..., None]]
    return np.concatenate(parts, axis=-1)


def _output_columns(nf: int) -> np.ndarray:
    """Where the OUTPUT_NAMES are in the integrator's output vector for one output point."""
    layout = output_layout(nf, 1)
    point = layout.points.start     # per point: position, velocity, acceleration, then their rigid parts
    return np.r_[layout.frame_origin, layout.frame_origin_velocity, layout.quaternion, layout.omega,
                 layout.alpha, layout.com_position, layout.com_velocity, point:point + 9, point + 15:point + 18,
                 layout.max_elastic_displacement]


@lru_cache(maxsize=4)
def _structure(model: str):
    return load_model(model)


@lru_cache(maxsize=4)
def _integrator(model: str, n_flexible_modes: int, damping_ratio: float, scheme: str, f_max=None, tolerance=None,
                load_node=None, output_node=None):
    """(integrator, BasisChoice): model, modes and integrator set-up, shared by instances (``advance`` does not
    touch its state).  f_max, tolerance, load_node only for n_flexible_modes = -1 (None otherwise)."""
    require(scheme in SCHEMES, "scheme", f"got {scheme!r}", " | ".join(SCHEMES))
    require(np.isfinite(damping_ratio) and 0.0 <= damping_ratio < 1.0, "damping_ratio",
            f"got {damping_ratio!r}", "0 <= damping_ratio < 1")
    structure = _structure(model)
    require(isinstance(n_flexible_modes, (int, np.integer)) and -1 <= n_flexible_modes <= structure.n_dof - 6,
            "n_flexible_modes", f"got {n_flexible_modes!r}",
            f"-1 (choose from f_max, tolerance) or 0 .. {structure.n_dof - 6}")
    # modes, sizing and the integrator's invariants: the set-up's one choke point for the BLAS threads
    with limited_for(structure.n_dof):
        choice = _basis(model, int(n_flexible_modes), damping_ratio, f_max, tolerance, load_node, output_node)
        return ReframeIntegrator(structure, choice.basis, scheme=scheme), choice


@lru_cache(maxsize=4)
def _basis(model: str, n_flexible_modes: int, damping_ratio: float, f_max, tolerance, load_node, output_node=None):
    """The basis and its messages (a BasisChoice; none for a given n_flexible_modes), shared by the schemes."""
    structure = _structure(model)
    if n_flexible_modes == -1:
        return auto_basis(structure, f_max, tolerance, damping_ratio, load_node, output_node)
    return BasisChoice(modal_basis(structure, n_flexible_modes, damping_ratio))


def _smallest_inertia(integ) -> float:
    """Smallest principal moment of inertia (kg m^2) about the centre of mass of the undeformed body."""
    J0 = getattr(integ, "_J0", None)
    if J0 is None:                                 # scheme "paper" does not keep it: S0^T M S0 as reframe does
        d = integ.data
        S0 = np.zeros((d.n_dof, 3))
        for k in range(3):
            S0[d.trans_rows, k] = np.cross(np.eye(3)[k], d.Xc)
            if d.rot_rows is not None:
                S0[d.rot_rows[:, k], k] = 1.0
        J0 = S0.T @ (d.M @ S0)
    return float(np.linalg.eigvalsh(0.5 * (J0 + J0.T))[0])


class ReframeBodySimulator:
    """State and step of one ReframeBody instance."""

    def __init__(self, config: ReframeBodyConfig = ReframeBodyConfig()):
        self.config = c = config
        check_config(c)
        check_model_size(c)                   # a beam:<scene> too large to set up: refused before it is built
        self.messages: list[str] = []
        auto = c.n_flexible_modes == -1
        load_node, output_node = check_points(c, _structure(c.model))      # the nearest nodes of points on the body
        if not auto:
            load_node = output_node = None                               # the set-up's cache key: not needed
        self.integrator, self.model_choice = _integrator(c.model, c.n_flexible_modes, c.damping_ratio, c.scheme,
                                                         c.f_max if auto else None, c.tolerance if auto else None,
                                                         load_node, output_node)
        integ = self.integrator
        self.messages.extend(self.model_choice.messages)
        omega_max = integ.data.omega_max
        self.stability_limit = RK4_STABILITY_LIMIT / omega_max if omega_max > 0 else math.inf
        limit = self.stability_limit if integ.stability_limited else math.inf
        cap = c.max_internal_steps
        shortest = MIN_COMMUNICATION_STEP / cap          # shorter internal steps: not even that step fits the cap
        upper = (f"{limit:.6g} s for {integ.data.nf} flexible coordinates (RK4 stability limit), or scheme exponential"
                 if math.isfinite(limit) else "any longer step (no stability limit)")
        require(c.internal_step <= limit and (c.internal_step == 0.0 or c.internal_step >= shortest), "internal_step",
                f"{c.internal_step!r} s exceeds the RK4 stability limit 2.8 / omega_max = {limit:.6g} s "
                f"(highest flexible mode {omega_max / (2 * math.pi):.6g} Hz)"
                if c.internal_step > limit else
                f"{c.internal_step!r} s: even a {MIN_COMMUNICATION_STEP:g} s communication step would need more than "
                f"max_internal_steps = {cap} of them",
                f"0 (automatic), or {shortest:.3g} s .. {upper}")
        if c.internal_step > 0:
            self.max_internal_step = c.internal_step
        elif integ.stability_limited:
            self.max_internal_step = _AUTO_STEP_FRACTION * limit
            require(self.max_internal_step >= shortest, "scheme",
                    f"{c.scheme}: the RK4 stability limit {limit:.3g} s of the highest flexible coordinate "
                    f"({omega_max / (2 * math.pi):.6g} Hz) needs more than max_internal_steps = {cap} internal steps "
                    f"even for a {MIN_COMMUNICATION_STEP:g} s communication step",
                    "scheme exponential (no stability limit), fewer modes, or a larger max_internal_steps")
        else:
            self.max_internal_step = math.inf            # exponential: chosen per step by accuracy
        self._theta_max = 0.5 * c.tolerance ** 0.25       # rad per internal step (exponential, automatic)
        # plausible initial spin: a MIN_COMMUNICATION_STEP step of the exponential scheme within the cap
        omega_cap = cap * self._theta_max / MIN_COMMUNICATION_STEP
        omega0 = math.hypot(c.omega0_1, c.omega0_2, c.omega0_3)
        if not omega0 <= omega_cap:
            name = max(("omega0_1", "omega0_2", "omega0_3"), key=lambda n: abs(getattr(c, n)))
            raise ParameterError(name, f"{getattr(c, name):g} rad/s (|omega0| = {omega0:.4g} rad/s): at that spin "
                                 f"even a {MIN_COMMUNICATION_STEP:g} s communication step needs more than "
                                 f"max_internal_steps = {cap} internal steps of at most 0.5 tolerance^(1/4) = "
                                 f"{self._theta_max:.3g} rad",
                                 f"|omega0| <= {omega_cap:.4g} rad/s (max_internal_steps x 0.5 tolerance^(1/4) / "
                                 f"{MIN_COMMUNICATION_STEP:g} s)")
        self._last_split = None
        # this instance's step sizes: a host's last-bit variants of a step share its exponential coefficients
        # (flexfmu.core.step_size); per instance, as the integrator is shared by instances of one model
        self._steps = StepSizes()
        self._force = np.zeros(3)
        self._moment = np.zeros(3)
        self._held_list = [0.0] * 6                 # the held force and moment as a list (set_input_vector)
        rotational = integ.data.structure.dofs_per_node == 6
        # Constant histories, replaced by the held input at each set_inputs (Prepared.set_held).
        load = PointLoad((c.load_point_x, c.load_point_y, c.load_point_z), force=self._force.copy(),
                         moment=self._moment.copy() if rotational else None, follower=c.force_follows_body)
        self._accepts_moment = rotational
        self._loads = integ.prepare_loads(load)
        self._points = integ.point_indices([(c.output_point_x, c.output_point_y, c.output_point_z)])
        self._columns = _output_columns(integ.data.nf)
        self.state = integ.initial_state(v0=(c.v0_x, c.v0_y, c.v0_z), omega0=(c.omega0_1, c.omega0_2, c.omega0_3))
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)
        # (state, |omega|, |alpha|, force, moment) of a state with the inputs its step held (see _rates)
        self._last_rates = None
        self._rates_needed = not integ.stability_limited and c.internal_step == 0
        # |d alpha| <= (|arm| |dF| + |dM|) / J_min: the change of alpha when the held inputs change (also used
        # to name the input behind a failure)
        self._arm = float(np.linalg.norm(integ.data.Xc[self._loads.items[0].node]))
        self._J_min = _smallest_inertia(integ)
        self._size = float(np.max(np.linalg.norm(integ.data.Xc, axis=1)))      # body radius about the CoM, m

    @property
    def time(self) -> float:
        return self.state.t

    def internal_steps(self, step_size: float) -> int:
        """Number of equal internal steps a communication step of step_size (s) is split into."""
        n, _ = self._split(step_size)
        return n

    def _split(self, step_size: float):
        """(number of internal steps, reason) for a communication step of step_size (s); the count is known
        before anything is stepped, and more than max_internal_steps is refused (_too_many_steps)."""
        c = self.config
        cap = c.max_internal_steps
        n = step_policy.split_step(step_size, self.max_internal_step, cap)
        if not n:
            raise self._too_many_steps(step_size)
        wmax = self.integrator.data.omega_max
        if c.internal_step > 0:
            why = f"internal_step = {c.internal_step:g} s requested"
            if self.integrator.stability_limited:
                why += f" (RK4 stability limit {self.stability_limit:.4g} s)"
        elif self.integrator.stability_limited:
            if n == 1:
                why = (f"dt * omega_max = {step_size * wmax:.3g} <= {RK4_STABILITY_LIMIT}: within the RK4 stability "
                       "limit")
            else:
                why = (f"dt * omega_max = {step_size:g} s * {wmax:.6g} rad/s = {step_size * wmax:.3g} > "
                       f"{RK4_STABILITY_LIMIT}: RK4 would diverge on the highest flexible mode "
                       f"({wmax / (2 * math.pi):.6g} Hz); sub-stepped at 90 % of the limit")
        else:
            w, a = self._rates()
            if not (w < math.inf and a < math.inf):      # the state's own rates overflow (NaN or inf)
                raise self._overflow(step_size, "the angular velocity or acceleration")
            theta = w * step_size + 0.5 * a * step_size**2
            n = step_policy.split_step(theta, self._theta_max, cap)     # theta / theta_max, counted as h / step
            if not n:
                raise self._too_many_steps(step_size, theta / self._theta_max * step_policy.GUARD, (w, a))
            if n > 1:                                      # then the rotation per internal step is <= theta_max
                # (w h + a h^2 / 2 <= theta / n for h = step_size / n; the few extra steps cover the rounding)
                h = step_size / n
                for _ in range(8):
                    if not w * h + 0.5 * a * h * h > self._theta_max:
                        break
                    n += 1
                    h = step_size / n
                else:
                    n = math.ceil(theta / self._theta_max * (1 + 1e-9))
                if n > cap:
                    raise self._too_many_steps(step_size, n, (w, a))
            why = (f"scheme exponential: no stability limit (dt * omega_max = {step_size / n * wmax:.3g}); by "
                   f"accuracy, rotation per internal step {theta / n:.3g} rad <= 0.5 tolerance^(1/4) = "
                   f"{self._theta_max:.3g} rad (|omega| = {w:.4g} rad/s, |alpha| ~ {a:.4g} rad/s^2)")
        return n, why

    def _too_many_steps(self, step_size: float, needed: float | None = None, rates=None) -> FlexfmuError:
        """More internal steps than max_internal_steps (flexfmu.native.step_policy): StepRejected when a communication
        step of at least MIN_COMMUNICATION_STEP would be within the cap (the largest such step is named), else
        ParameterError naming what makes it so (the internal step; the held input behind the angular acceleration,
        or the spin).  rates: None for fixed or stability-limited internal steps (needed is then the policy's)."""
        cap = self.config.max_internal_steps
        if rates is None:
            return step_policy.split_refusal(step_size, self.max_internal_step, cap, step_policy.Cause(
                "internal_step", "a longer internal step or a larger max_internal_steps",
                f"{self.max_internal_step:g} s: "))
        w, a = rates
        theta = self._theta_max
        # the largest h with w h + a h^2 / 2 <= theta, then cap of them (Python floats: inf, no exception)
        disc = w * w + 2.0 * a * theta
        root = math.sqrt(disc) if math.isfinite(disc) else math.inf
        h_ok = cap * 2.0 * theta / (w + root) if w + root > 0 else math.inf
        return step_policy.refusal(step_size, needed, cap, h_ok, lambda: self._spin_cause(w, a))

    def _spin_cause(self, w: float, a: float):
        """Why not even a MIN_COMMUNICATION_STEP step fits the cap (exponential scheme): the held input behind the
        angular acceleration, else the initial spin (t = 0) or the state's spin."""
        cap, theta, h_min = self.config.max_internal_steps, self._theta_max, MIN_COMMUNICATION_STEP
        after = f" of at most 0.5 tolerance^(1/4) = {theta:.3g} rad (scheme exponential)"
        a_ok = max(2.0 * (cap * theta - w * h_min) / h_min ** 2, 0.0)
        if 0.5 * a * h_min * h_min >= w * h_min:           # the angular acceleration of the held inputs
            scores = {f"F_{x}": abs(self._force[i]) * self._arm for i, x in enumerate(AXES)}
            scores.update({f"M_{x}": abs(self._moment[i]) for i, x in enumerate(AXES)})
            name = culprit(scores) or "F_x"
            unit, lever = ("N", self._arm) if name.startswith("F") else ("N.m", 1.0)
            allowed = (f"|{name[0]}| <= about {a_ok * self._J_min / lever:.3g} {unit} at this load point "
                       f"(|alpha| <= {a_ok:.3g} rad/s^2)" if lever > 0 else "a smaller input")
            return step_policy.Cause(name, allowed, f"{self.inputs[name]:g} {unit} gives an angular acceleration of "
                                     f"up to {a:.3g} rad/s^2: ", after)
        omega_ok = cap * theta / h_min
        if self.state.t == 0.0:
            c = self.config
            name = max(("omega0_1", "omega0_2", "omega0_3"), key=lambda n: abs(getattr(c, n)))
            return step_policy.Cause(name, f"|omega0| <= {omega_ok:.4g} rad/s", f"the body spins at {w:.4g} rad/s: ",
                                     after)
        return step_policy.Cause("state", f"inputs that keep |omega| <= {omega_ok:.4g} rad/s", f"the body spins at "
                                 f"{w:.4g} rad/s at t = {self.state.t:.6g} s (spun up by the inputs held so far): ",
                                 after)

    def _rates(self):
        """|omega| and |alpha| at the start of a communication step with the new inputs, for the exponential
        split: those of the state with the inputs its step held (output_vector's, when the outputs were
        read; else computed), alpha then raised by a bound of the input change.  Always computed this way
        (_ensure_rates runs before any input change), so the split, and so the results, do not depend on
        whether or when the outputs were read."""
        self._ensure_rates()
        _, w, a, f, m = self._last_rates
        if f is self._force and m is self._moment:
            return w, a
        da = (self._arm * math.dist(self._force, f) + math.dist(self._moment, m)) / self._J_min
        return w, a + da

    def _ensure_rates(self) -> None:
        """Remember |omega|, |alpha| of the current state with the inputs now held (call before they change)."""
        last = self._last_rates
        if last is None or last[0] is not self.state:
            self._remember_rates(self.integrator.output_vector(self.state, self._loads, self._points,
                                                               max_elastic=False))

    def _remember_rates(self, out) -> None:
        rates = out[10:16].tolist()
        self._last_rates = (self.state, math.hypot(*rates[0:3]), math.hypot(*rates[3:6]), self._force, self._moment)

    def set_inputs(self, **inputs: float) -> None:
        for name, value in inputs.items():
            require(name in INPUT_NAMES, name, "unknown input", ", ".join(INPUT_NAMES))
            if not finite_input(value):
                raise ParameterError(name, f"input is {shown(value)}", "a finite number")
            if name.startswith("M_") and value != 0.0:
                require(self._accepts_moment, name, "moments need a model with rotational DOFs (beam:<scene>)",
                        "0 for models with 3 DOFs per node")
        self.inputs.update({k: float(v) for k, v in inputs.items()})
        self._hold(np.array([self.inputs[f"F_{a}"] for a in AXES]), np.array([self.inputs[f"M_{a}"] for a in AXES]))

    def _hold(self, force, moment) -> None:
        if not (np.array_equal(force, self._force) and np.array_equal(moment, self._moment)):
            if self._rates_needed:
                self._ensure_rates()
            self._force, self._moment = force, moment
            self._loads.set_held(0, force, moment if self._accepts_moment else None)
        self._held_list = force.tolist() + moment.tolist()

    def set_input_vector(self, values) -> None:
        """All inputs at once, in INPUT_NAMES order (the FMU's per-step path)."""
        try:
            vals = [float(v) for v in values]
        except (TypeError, ValueError, OverflowError):      # a string, an int too large for a float: named
            self.set_inputs(**dict(zip(INPUT_NAMES, list(values))))
            raise ParameterError("inputs", "not all numbers", f"{len(INPUT_NAMES)} finite numbers") from None
        if len(vals) != len(INPUT_NAMES) or not all(map(math.isfinite, vals)) or \
                (not self._accepts_moment and any(vals[3:6])):
            self.set_inputs(**dict(zip(INPUT_NAMES, vals)))
            return
        self.inputs = dict(zip(INPUT_NAMES, vals))
        if vals != self._held_list:                 # lists: cheaper than arrays and np.array_equal
            if self._rates_needed:
                self._ensure_rates()
            self._held_list = vals
            self._force, self._moment = np.array(vals[0:3]), np.array(vals[3:6])
            self._loads.set_held(0, self._force, self._moment if self._accepts_moment else None, checked=True)

    def step(self, step_size: float) -> None:
        """Equal internal steps over step_size (s) with the inputs held, in one kernel call (see _split)."""
        require(math.isfinite(step_size) and step_size > 0, "step_size", f"got {step_size!r}", "> 0 s")
        n, why = self._split(step_size)
        if n != self._last_split:                         # log the decision once, and when it changes
            self.messages.append(f"t = {self.state.t:.6g} s: communication step {step_size:g} s in {n} internal "
                                 f"step(s) of {step_size / n:.4g} s: {why}")
            self._last_split = n
        try:
            dt = step_size / n
            self.state = self.integrator.advance_steps(self.state, dt, n, self._loads,
                                                       coefficients_dt=self._steps.canonical(dt))
        except FlexfmuError as exc:
            if type(exc) is not FlexfmuError:               # ParameterError of a load history etc.: as raised
                raise
            raise self._overflow(step_size, "the state") from None      # the kernel's non-finite state
        except ArithmeticError:
            if np.geterr()["over"] != "ignore":            # numpy's error mode set to raise: again without it
                with np.errstate(all="ignore"):
                    return self.step(step_size)
            raise self._overflow(step_size, "the state") from None
        except ValueError:                                 # scheme paper's Python step: math domain errors of NaN
            raise self._overflow(step_size, "the state") from None
        # the kernels check the state; the step is not committed on failure (self.state is that of its start)

    def _overflow(self, step_size: float, what: str) -> NonFiniteError:
        """NonFiniteError naming the likely cause of an overflow over a step of step_size (s) (or of the
        outputs, step_size = 0): the held input with the largest effect (displacement, rotation, acceleration
        over the step), else the body's own motion (v0, omega0 at t = 0)."""
        c, h = self.config, max(step_size, 1.0)
        mass, J, arm, size = self.integrator.data.mass, self._J_min, self._arm, self._size
        scores = {f"F_{x}": abs(self._force[i]) * (1.0 / mass + arm * size / J) * h * h for i, x in enumerate(AXES)}
        scores.update({f"M_{x}": abs(self._moment[i]) * size / J * h * h for i, x in enumerate(AXES)})
        try:
            with np.errstate(all="ignore"):
                snap = self.integrator.snapshot(self.state, self._loads, self._points)
            speed, spin = math.hypot(*snap.com_velocity.tolist()), math.hypot(*snap.omega.tolist())
        except (FlexfmuError, ArithmeticError, ValueError):
            speed = spin = math.nan
        # at the start, or NaN: rank the initial conditions themselves (a start that overflows makes the snapshot's
        # spin infinite from a huge v0 alone, which would blame an omega0 of 0)
        if self.state.t == 0.0 or not (speed == speed and spin == spin):
            speed, spin = math.hypot(c.v0_x, c.v0_y, c.v0_z), math.hypot(c.omega0_1, c.omega0_2, c.omega0_3)
        if speed or spin:
            scores["velocity"] = speed * h
            scores["spin"] = spin * size * h + spin * spin * size * h * h
        name = culprit(scores) or "state"
        if name in ("velocity", "spin"):
            group = _INITIAL[:3] if name == "velocity" else _INITIAL[3:]
            initial = math.hypot(*(getattr(c, n) for n in group))
            if self.state.t == 0.0 or initial >= 0.5 * (speed if name == "velocity" else spin):   # still the start's
                name = max(group, key=lambda n: abs(getattr(c, n)))
                return NonFiniteError(name, f"{getattr(c, name):g} makes {what} overflow (not finite) at t = "
                                      f"{self.state.t:.6g} s; allowed: initial conditions within the model's range")
            return NonFiniteError("state", f"the body's {name} (from the inputs held so far) makes {what} overflow "
                                  f"(not finite) at t = {self.state.t:.6g} s")
        if name == "state":
            return NonFiniteError("state", f"{what} overflows (not finite) at t = {self.state.t:.6g} s")
        unit = "N" if name.startswith("F") else "N.m"
        return NonFiniteError(name, f"{self.inputs[name]:g} {unit} makes {what} overflow (not finite) at t = "
                              f"{self.state.t:.6g} s; allowed: inputs within the model's range")

    def output_vector(self, include_deferred: bool = True) -> np.ndarray:
        """All outputs (OUTPUT_NAMES order) of the current state.  include_deferred=False leaves the
        DEFERRED_OUTPUTS out of the computation (their places hold -1; scheme "paper": computed anyway)."""
        integ = self.integrator
        try:
            if integ.stepper.kernel_outputs:
                out = integ.output_vector(self.state, self._loads, self._points, max_elastic=include_deferred)
                if self._rates_needed and (self._last_rates is None or self._last_rates[0] is not self.state):
                    self._remember_rates(out)        # the inputs are the state's own: see _rates
                y = out[self._columns]
            else:
                y = output_values(integ.snapshot(self.state, self._loads, self._points))
            if not y.dot(y) < _INF and not np.all(np.isfinite(y)):     # ~0.3 us; the culprit only on failure
                bad = [OUTPUT_NAMES[i] for i in np.nonzero(~np.isfinite(y))[0]]
                raise self._overflow(0.0, ", ".join(bad))
        except ArithmeticError:                      # numpy's error mode set to raise: again without it, then checked
            with np.errstate(all="ignore"):
                return self.output_vector(include_deferred)
        return y

    def deferred_output_vector(self) -> list[float]:
        """The DEFERRED_OUTPUTS of the current state, in their order."""
        value = self.integrator.max_elastic_displacement(self.state)
        if not math.isfinite(value):
            raise self._overflow(0.0, "max_elastic_displacement")
        return [value]

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
        needed, self._rates_needed = self._rates_needed, False     # not with the inputs held before the restore
        try:
            self.set_inputs(**data["inputs"])
        finally:
            self._rates_needed = needed
        self._last_rates = None          # then computed with the state's own inputs, as in an uninterrupted run
