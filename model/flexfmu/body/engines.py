"""The two engines behind flexfmu.body.simulator.FlexBodySimulator: a free body (reframe kernels,
flexfmu.body.free) and a clamped one (exact zero-order hold, flexfmu.body.clamped_dynamics).  Each holds the
state and the held inputs, splits a communication step into internal steps (counted before stepping, by
flexfmu.native.step_policy) and gives the outputs in the order of the body's output_names (output_vector).  A body's
class names its engine (flexfmu.body.model: FreeBody.engine_class, ClampedBody.engine_class)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from flexfmu.body.clamped_dynamics import MAP_MEMO_SIZE, ClampedDynamics, HeldMaps, MovingBase
from flexfmu.body.free import FreeDynamics
from flexfmu.core.cache import BoundedCache
from flexfmu.core.checks import MIN_COMMUNICATION_STEP, culprit
from flexfmu.core.rotation import rotation_matrix
from flexfmu.errors import NonFiniteError, ParameterError
from flexfmu.native import lti_taylor, step_policy
from flexfmu.reframe.layout import output_layout
from flexfmu.reframe.modeldata import RK4_STABILITY_LIMIT

AUTO_STEP_FRACTION = 0.9           # of the RK4 stability limit, for internal_step = 0 (as ReframeBody)
_OMEGA, _ALPHA = output_layout(0, 0).omega, output_layout(0, 0).alpha     # their places do not depend on nf


#: what a refusal allows when not even a MIN_COMMUNICATION_STEP step fits the cap (flexfmu.native.step_policy);
#: it names internal_step, or for the rotation count of a free body the held input behind it
_ALLOWED = "a smaller value, or a larger max_internal_steps"
_INTERNAL_STEP = step_policy.Cause("internal_step", _ALLOWED)


def _frame_global(q_omega_alpha: np.ndarray) -> np.ndarray:
    """[rotation vector, omega, alpha] in global components from [q (scalar first), omega, alpha (body)]:
    omega_g = R omega, and alpha_g = d(R omega)/dt = R alpha since R (omega x omega) = 0."""
    q = q_omega_alpha[:4]
    n = float(np.linalg.norm(q))
    if not n > 0.0:
        return np.full(9, np.nan)
    w, v = q[0] / n, q[1:] / n
    if w < 0.0:                                    # the same rotation, angle in [0, pi]
        w, v = -w, -v
    s = float(np.linalg.norm(v))
    angle = 2.0 * math.atan2(s, w)
    rot = v * (angle / s) if s > 1e-12 else 2.0 * v
    R = rotation_matrix(rot).T                    # body -> global
    return np.concatenate([rot, R @ q_omega_alpha[4:7], R @ q_omega_alpha[7:10]])


def stress_rows(body, m: int) -> np.ndarray:
    """The outputs after a body's natural frequencies as rows on x = [eta; eta_d] (flexfmu.body.model:
    shape_names, gauge_names): q = eta, then per gauge its stress S eta, a zero row for its von Mises (a derived
    output, filled by the simulator) and its strain E eta.  A free body uses the eta half (FreeEngine)."""
    rows = [np.eye(m)] if body.shape_outputs else []
    for g in body.gauges:
        rows += [g.stress, np.zeros((1, m)), g.strain]
    if not rows:
        return np.zeros((0, 2 * m))
    eta = np.vstack(rows)
    return np.hstack([eta, np.zeros_like(eta)])


class FreeEngine:
    """A free body: state y (flexfmu.reframe.layout.STATE) and t; inputs [F (3), M (3 if moments)] per interface,
    global."""

    def __init__(self, body, config, zeta: float, names):
        c = config
        self.names = list(names)
        ifs = body.interfaces
        self.dyn = dyn = FreeDynamics(body.arrays, body.eigenvalues, zeta, c.scheme, [i.rows for i in ifs],
                                      [i.point for i in ifs], [i.moments for i in ifs])
        self.moments = [i.moments for i in ifs]
        self.SV = np.zeros((1, 3, len(ifs), 6))
        self.y = dyn.initial_state(np.array([c.v0_x, c.v0_y, c.v0_z]), np.array([c.omega0_1, c.omega0_2, c.omega0_3]))
        self.t = 0.0
        self.cap = c.max_internal_steps
        self.scheme = c.scheme
        #: internal steps by the RK4 stability limit (automatic: 90 % of it), else by the rotation per step
        self.stability_limited = dyn.scheme_class.stability_limited
        self.limit = (RK4_STABILITY_LIMIT / dyn.omega_max if (self.stability_limited and dyn.omega_max > 0)
                      else math.inf)
        shortest = MIN_COMMUNICATION_STEP / self.cap
        if c.internal_step > self.limit:
            raise ParameterError("internal_step", f"{c.internal_step:g} s exceeds the RK4 stability limit 2.8 / "
                                 f"omega_max = {self.limit:.6g} s", f"0 (automatic) or {shortest:.3g} .. "
                                 f"{self.limit:.6g} s, or scheme exponential")
        self.internal_step = c.internal_step
        self.max_step = c.internal_step if c.internal_step > 0 else (AUTO_STEP_FRACTION * self.limit
                                                                    if self.stability_limited else math.inf)
        if self.max_step < shortest:
            raise ParameterError("scheme" if c.internal_step == 0 else "internal_step",
                                 f"internal steps of {self.max_step:.3g} s need more than max_internal_steps = "
                                 f"{self.cap} for a {MIN_COMMUNICATION_STEP:g} s communication step",
                                 "scheme exponential, fewer modes, or a larger max_internal_steps")
        self.theta_max = 0.5 * c.tolerance ** 0.25           # rad per internal step (exponential, automatic)
        self.inputs_vec = np.zeros(sum(6 if m else 3 for m in self.moments))
        # output_vector: the kernels' output columns of the body's outputs (the interfaces' pos, vel, acc, the
        # frame, the centre of mass, max_elastic_displacement), then the frame's rotation in global components
        # (from the columns ``rotation``) and the natural frequencies
        L = output_layout(dyn.nf, len(ifs))
        per = [L.points.start + 18 * k + j for k in range(len(ifs)) for j in range(9)]
        self.columns = np.r_[per, L.frame_origin, L.frame_origin_velocity, L.quaternion, L.omega, L.alpha,
                             L.com_position, L.com_velocity, L.max_elastic_displacement]
        self.rotation = np.r_[L.quaternion, L.omega, L.alpha]
        self.frequencies = np.asarray(body.natural_frequencies_hz, float)
        # after the frequencies: the shape coordinates q_1 .. q_nf (the kernels' flexible coordinates, columns q)
        # and the gauges' stress S q and strain E q (rows of stress_rows on q; the rigid coordinates strain
        # nothing), von Mises a zero row the simulator fills (derived_outputs)
        self.flexible = L.q
        self.shape_rows = np.ascontiguousarray(stress_rows(body, dyn.nf)[:, :dyn.nf])

    def hold(self, u: np.ndarray) -> None:
        self.inputs_vec = u
        k = 0
        for i, mom in enumerate(self.moments):
            n = 6 if mom else 3
            self.SV[0, :, i, :n] = u[k:k + n]
            k += n

    def split(self, h: float):
        """(internal steps, reason) for a communication step h (s); StepRejected / ParameterError beyond the cap."""
        if not self.stability_limited and self.internal_step == 0:
            out = self.dyn.outputs(self.y, self.SV, max_elastic=False)
            w, a = float(np.linalg.norm(out[_OMEGA])), float(np.linalg.norm(out[_ALPHA]))
            if not (math.isfinite(w) and math.isfinite(a)):
                raise NonFiniteError(self.culprit() or "state", "the angular velocity or acceleration overflows "
                                     "(not finite)")
            ratio = self._rotation_count(h, w, a)
            n = step_policy.step_count(ratio, step_policy.GUARD, self.cap)       # capped as it is, counted guarded
            if not n:
                lo, hi = 0.0, h                              # the longest step within the cap (bisection)
                for _ in range(200):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if self._rotation_count(mid, w, a) <= self.cap else (lo, mid)
                cause = step_policy.Cause(self.culprit() or "state", _ALLOWED)
                raise step_policy.refusal(h, ratio, self.cap, lo, cause)
            return n, (f"scheme {self.scheme}: rotation per internal step <= 0.5 tolerance^(1/4) = "
                       f"{self.theta_max:.3g} rad (|omega| = {w:.4g} rad/s, |alpha| = {a:.4g} rad/s^2, held)")
        n = step_policy.split_step(h, self.max_step, self.cap)
        if not n:
            raise step_policy.split_refusal(h, self.max_step, self.cap, _INTERNAL_STEP)
        why = (f"internal_step = {self.internal_step:g} s" if self.internal_step > 0 else
               f"scheme {self.scheme} (RK4): 90 % of the stability limit {self.limit:.4g} s")
        return n, why

    def _rotation_count(self, h: float, w: float, a: float) -> float:
        """h / x with x the longest internal step whose rotation (w + a h) x + a x^2 / 2 stays within theta_max:
        the angular velocity bounded by its value at the end of the communication step."""
        wm = w + a * h
        root = math.sqrt(wm * wm + 2.0 * a * self.theta_max)
        return h * (wm + root) / (2.0 * self.theta_max) if math.isfinite(root) else math.inf

    def culprit(self) -> str | None:
        """The held input of largest magnitude (a force or moment), else None."""
        return culprit(dict(zip(self.names, np.abs(self.inputs_vec).tolist())))

    def advance(self, h: float, n: int) -> bool:
        y, t, _, status = self.dyn.steps(self.y, self.t, h / n, n, self.SV)
        if status:
            return False
        self.y, self.t = y, t
        return True

    def outputs(self, include_deferred: bool = True) -> np.ndarray:
        return self.dyn.outputs(self.y, self.SV, include_deferred)

    def output_vector(self, include_deferred: bool = True) -> np.ndarray:
        """All outputs in the body's output_names order (max_elastic_displacement = -1 when include_deferred is
        False).  Called under np.errstate(all="ignore") (FlexBodySimulator.output_vector)."""
        raw = self.outputs(include_deferred)
        return np.concatenate([raw[self.columns], _frame_global(raw[self.rotation]), self.frequencies,
                               self.shape_rows @ raw[self.flexible]])

    def get(self) -> dict:
        return {"t": self.t, "y": self.y.tolist()}

    def put(self, data: dict) -> None:
        y = np.array(data["y"], dtype=float)
        if y.shape != self.y.shape or not np.all(np.isfinite(y)) or not math.isfinite(float(data["t"])):
            raise ParameterError("FMUstate", "state of the wrong size or not finite", "a state of this body")
        self.y, self.t = y, float(data["t"])


class ClampedEngine:
    """A clamped body: x = [eta; eta_d] and t; inputs [F, M] per interface then a0, w, alpha (body frame).

    Per step and output read only matrix-vector products: the modal force and the outputs are affine maps of the
    load vector ul = [F, M per interface, a0] (a prefix of the inputs) and x for the held base rotation
    (ClampedDynamics.held_maps, cached per (w, alpha) as the step maps are per (h, w, alpha)).  A step whose held
    rotation differs from the step's before it (a base that moves at every step) goes instead by the series of its
    exponential on the state (flexfmu.native.lti_taylor's rule, as the native kernel), its outputs by the held
    maps' polynomial in the rotation (MovingBase): no new exponential or held maps per step."""

    def __init__(self, body, config, zeta: float, names):
        self.names = list(names)
        ifs = body.interfaces
        self.dyn = ClampedDynamics(body.arrays, body.eigenvalues, zeta, [i.rows for i in ifs], [i.point for i in ifs],
                                   [i.moments for i in ifs])
        self.moments = [i.moments for i in ifs]
        self.x = np.zeros(2 * self.dyn.m)
        self.t = 0.0
        self.cap = config.max_internal_steps
        self.internal_step = config.internal_step
        if 0 < self.internal_step < MIN_COMMUNICATION_STEP / self.cap:
            raise ParameterError("internal_step", f"{self.internal_step:g} s needs more than max_internal_steps = "
                                 f"{self.cap} for a {MIN_COMMUNICATION_STEP:g} s communication step",
                                 f"0 (one exact step) or >= {MIN_COMMUNICATION_STEP / self.cap:.3g} s")
        self.n_loads = self.dyn.n_loads()
        # where each load input goes in the (n_if, 6) [F, M] table of the term-by-term formulas
        self._load_slots = np.array([6 * i + j for i, mom in enumerate(self.moments) for j in range(6 if mom else 3)],
                                    dtype=np.intp)
        self._frequencies = np.asarray(body.natural_frequencies_hz, dtype=float)
        self._n_outputs = 9 * len(ifs) + 6              # before the frequencies
        self._extra_Cx = stress_rows(body, self.dyn.m)  # after them: the shape coordinates and the gauges
        self._held_maps = BoundedCache(MAP_MEMO_SIZE)
        #: False: every step by the maps (one exponential per new rotation: the comparisons of tests and benchmarks)
        self.moving_base_series = True
        self._held_before = None        # (w, alpha) the last step held (None: no step yet)
        self._series_last = False       # the last step went by the series (its outputs then by the polynomials)
        self._moving_base = None        # MovingBase, built when the rotation first moves
        self._moving_outputs = None     # ((w, alpha), HeldMaps) from the polynomials
        self.hold(np.zeros(self.n_loads + 6))

    def hold(self, u: np.ndarray) -> None:
        self.inputs_vec = u
        k = self.n_loads
        self._loads_held = u[:k]
        self._w_key, self._alpha_key = tuple(u[k:k + 3].tolist()), tuple(u[k + 3:k + 6].tolist())

    # the held inputs as the term-by-term formulas of ClampedDynamics take them (copies: the caller may keep them)
    @property
    def loads(self) -> np.ndarray:
        """(n_if, 6) [F, M] per interface, body frame (M zero where the interface carries no moment)."""
        table = np.zeros(6 * len(self.moments))
        table[self._load_slots] = self.inputs_vec[:self.n_loads - 3]
        return table.reshape(-1, 6)

    @property
    def a0(self) -> np.ndarray:
        return self.inputs_vec[self.n_loads - 3:self.n_loads].copy()

    @property
    def w(self) -> np.ndarray:
        return np.array(self._w_key)

    @property
    def alpha(self) -> np.ndarray:
        return np.array(self._alpha_key)

    def _maps(self) -> HeldMaps:
        """The HeldMaps of the held base rotation for the outputs: after a step by the series with this rotation
        from the polynomials, else exact_maps."""
        key = self._w_key + self._alpha_key
        if self._series_last and key == self._held_before:
            return self._series_output_maps(key)
        return self.exact_maps()

    def exact_maps(self) -> HeldMaps:
        """The HeldMaps of the held base rotation (cached), their outputs followed by the natural frequencies
        (constant rows): output_vector in one product."""
        key = self._w_key + self._alpha_key
        hit = self._held_maps.get(key)
        if hit is None:
            with np.errstate(all="ignore"):          # a huge rotation: found by value in the step and the outputs
                hit = self._held_maps[key] = self._with_frequencies(self.dyn, self._w_key, self._alpha_key)
        return hit

    def _with_frequencies(self, dyn, w, alpha) -> HeldMaps:
        """The held maps followed by the constant rows of the frequencies and the rows of the shape coordinates and
        gauges (stress_rows: linear in eta, whatever the base does)."""
        maps = dyn.held_maps(w, alpha)
        nf, extra = self._frequencies.size, self._extra_Cx
        return dataclasses.replace(maps, Cx=np.vstack([maps.Cx, np.zeros((nf, maps.Cx.shape[1])), extra]),
                                   Cu=np.vstack([maps.Cu, np.zeros((nf + extra.shape[0], maps.Cu.shape[1]))]),
                                   y0=np.concatenate([maps.y0, self._frequencies, np.zeros(extra.shape[0])]))

    # ---- moving base (flexfmu.native.lti_taylor)
    def _output_values(self, dyn, w, alpha) -> np.ndarray:
        maps = self._with_frequencies(dyn, w, alpha)
        return np.concatenate([maps.Cx.ravel(), maps.Cu.ravel(), maps.y0])

    def _moving_model(self) -> MovingBase:
        if self._moving_base is None:
            with np.errstate(all="ignore"):
                self._moving_base = MovingBase(self.dyn, self._output_values)
        return self._moving_base

    def _series_advance(self, h: float, n: int, key) -> bool | None:
        """n exact steps h / n by the series when flexfmu.native.lti_taylor's rule takes them (None: take the
        maps); False when the state overflows (kept)."""
        prepared = self._moving_model().system.prepare(np.array(key), np.array(self._held_before), h / n,
                                                       self._loads_held, n)
        if prepared is None:
            return None
        A, g, plan = prepared
        x = lti_taylor.taylor_steps(A, g, self.x, h / n, plan, n)
        if not x.dot(x) < math.inf and not np.all(np.isfinite(x)):
            return False
        self.x, self.t = x, self.t + h
        self._held_before, self._series_last = key, True
        return True

    def _series_output_maps(self, key) -> HeldMaps:
        if self._moving_outputs is not None and self._moving_outputs[0] == key:
            return self._moving_outputs[1]
        mb = self._moving_model()
        v = mb.outputs(np.array(key))
        ny, nx, nl = self._n_outputs + self._frequencies.size + self._extra_Cx.shape[0], 2 * self.dyn.m, self.n_loads
        force0 = mb.step(np.array(key))[nx * nx:]
        maps = HeldMaps(mb.force, force0, v[:ny * nx].reshape(ny, nx), v[ny * nx:ny * (nx + nl)].reshape(ny, nl),
                        v[ny * (nx + nl):], mb.moment_arm, mb.moment)
        self._moving_outputs = (key, maps)
        return maps

    def split(self, h: float):
        if self.internal_step == 0:
            return 1, "exact zero-order hold: one internal step of any length"
        n = step_policy.split_step(h, self.internal_step, self.cap)
        if not n:
            raise step_policy.split_refusal(h, self.internal_step, self.cap, _INTERNAL_STEP)
        return n, f"internal_step = {self.internal_step:g} s (each exact)"

    def culprit(self) -> str | None:
        """The held input most likely behind an overflow (the spin enters squared), else None."""
        u = np.abs(self.inputs_vec).tolist()
        k = len(u) - 9
        scores = {self.names[i]: (u[i] * u[i] if k + 3 <= i < k + 6 else u[i]) for i in range(len(u))}
        return culprit(scores)

    def advance(self, h: float, n: int) -> bool:
        """Step by h in n exact steps; False (the state kept) when the state overflows.  Called under
        np.errstate(all="ignore") (FlexBodySimulator.step): overflow is found by value."""
        key = self._w_key + self._alpha_key
        if self._held_before is not None and key != self._held_before and self.moving_base_series:
            done = self._series_advance(h, n, key)
            if done is not None:
                return done
        Ad, Bd = self.dyn.transition(h / n, self._w_key, self._alpha_key)
        maps = self.exact_maps()
        r = maps.force @ self._loads_held                   # right side of (B2)
        r += maps.force0
        b = Bd @ r
        x = self.x
        for _ in range(n):                                  # n <= max_internal_steps (split)
            x = Ad @ x
            x += b
        # x.x is finite when x is (unless |x| > 1e154): the element-wise check only then
        if not x.dot(x) < math.inf and not np.all(np.isfinite(x)):
            return False
        self.x, self.t = x, self.t + h
        self._held_before, self._series_last = key, False
        return True

    def output_vector(self, include_deferred: bool = True) -> np.ndarray:
        """All outputs in the body's output_names order: outputs() and the natural frequencies (Hz); a clamped body
        defers none (``include_deferred`` is the free engine's).
        Where the held maps overflow, the term-by-term formulas decide (they may not).  Called under
        np.errstate(all="ignore") (FlexBodySimulator.output_vector)."""
        maps, x, ul = self._maps(), self.x, self._loads_held
        y = maps.Cx @ x
        y += maps.Cu @ ul
        y += maps.y0
        y[maps.moment] += ul @ (maps.moment_arm @ x[:self.dyn.m]).reshape(-1, 3)
        if not y.dot(y) < math.inf and not np.all(np.isfinite(y)):
            y = np.concatenate([self.outputs_by_terms(), self._frequencies, self._extra_Cx @ x])
        return y

    def outputs(self, include_deferred: bool = True) -> np.ndarray:
        """Interface motion then reactions (ClampedDynamics.interface_motion, reactions), from the held maps."""
        return self.output_vector()[:self._n_outputs]

    def outputs_by_terms(self) -> np.ndarray:
        """outputs() by the term-by-term formulas of ClampedDynamics (what the held maps multiply out)."""
        d, x, loads = self.dyn, self.x, self.loads
        a0, w, al = self.a0, self.w, self.alpha
        eta_dd = d.acceleration(x, loads, a0, w, al)
        motion = d.interface_motion(x, eta_dd, a0, w, al)
        F, M = d.reactions(x, eta_dd, loads, a0, w, al)
        return np.concatenate([motion.ravel(), F, M])

    def get(self) -> dict:
        # held_before, series_last: what the next step compares its rotation with and how the last step went (the
        # outputs' maps), so that a restored state steps and reads as the original did, bit for bit
        return {"t": self.t, "x": self.x.tolist(),
                "held_before": None if self._held_before is None else list(self._held_before),
                "series_last": self._series_last}

    def put(self, data: dict) -> None:
        x = np.array(data["x"], dtype=float)
        if x.shape != self.x.shape or not np.all(np.isfinite(x)) or not math.isfinite(float(data["t"])):
            raise ParameterError("FMUstate", "state of the wrong size or not finite", "a state of this body")
        self.x, self.t = x, float(data["t"])
        before = data.get("held_before")          # absent from a state of an older version: as before any step
        self._held_before = None if before is None else tuple(float(v) for v in before)
        self._series_last = bool(data.get("series_last", False)) and self._held_before is not None
        self._moving_outputs = None
