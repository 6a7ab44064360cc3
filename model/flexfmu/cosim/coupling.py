"""The interface-Jacobian coupling scheme of our fixed-step master (flexfmu.cosim.masters, ``scheme =
"interface-jacobian"``): a linearly implicit, non-iterative coupling that solves the coupling equations at every
communication point with each slave's outputs linearised in its inputs.

The algorithm.  Slave i has the state x_i, the inputs u_i (those fed by connections) and the outputs
y_i = g_i(x_i, u_i); the FMUs and the library façades compute their outputs from the state and the inputs
*held* over the last step (flexfmu_native.c: from ``held``; the façades: from the inputs of their last
``set_inputs``).  The connections are u = L y with L a 0/1 matrix (each connected input reads one output).
One communication step from t_n to t_{n+1} = t_n + h:

1. every slave steps from t_n with its inputs u_i^n held (as in Jacobi: the order does not matter);
2. at the new state each slave gives its outputs for the held inputs and their interface Jacobian
   (the direct feedthrough of the output function at fixed state)

       y^_i = g_i(x_i(t_{n+1}), u_i^n),      D_i = dg_i/du_i (x_i(t_{n+1}), u_i^n);

3. the master solves the coupling equations u = L y with the outputs linearised about the held inputs,
   y_i(u_i) = y^_i + D_i (u_i - u_i^n), for every connected input at once (D = diag D_i):

       (I - L D) u^{n+1} = L (y^ - D u^n);

4. u^{n+1} is set and held over the next step; the outputs recorded at t_{n+1} are the linearised ones,
   y^ + D (u^{n+1} - u^n), the outputs that belong to the inputs the step ends with.

At t_0 the same solve (step 3) gives the consistent start inputs.  For outputs affine in the inputs (every output
the wave-energy converter's components exchange: the platform's accelerations are M^-1 times the held loads, the
harvester's clamp reaction is affine in its base acceleration and tip load at fixed modal state) the solve is the
exact solution of the coupling equations at t_{n+1}; no step is repeated and no slave is rolled back.

What it removes, against Jacobi (u^{n+1} = L y^: the outputs of the old inputs, exchanged one step late) and
Gauss-Seidel: the algebraic loops through direct feedthrough.  On a floating body carrying a clamped flexible body,
the body's acceleration depends at once on the reaction (compliance M_p^-1), and the reaction on the acceleration
(minus the rigid inertia its retained modes do not carry, B_res); held one exchange late the loop multiplies the
acceleration by -T M_p^-1 T^T B_res per exchange, unstable at any step once that exceeds 1 in spectral radius
(docs/stability.md, study 3).  Solved at each communication point the loop costs nothing in stability.  What it does
not remove: the zero-order hold itself.  An input that depends on another slave's *state* (no feedthrough,
D = 0: a damper force from a velocity) is exchanged as Gauss-Seidel would give it, the newest value held over
the next step, with the same lag of about h/2 (docs/stability.md: "Interface-Jacobian coupling" has the numbers).

The scheme is the linearly implicit coupling of Kübler & Schiehlen ("Two methods of simulator coupling", 2000)
with interface Jacobians, as in the IJCSA of Sadjina et al. (2017) at fixed step, without their step-size control.

Where D comes from: a library façade's output function at fixed state (LibrarySlave.output_jacobian: central
differences, exact for outputs of degree <= 2 in each input), or the FMU's fmi2GetDirectionalDerivative
(FmuSlave.output_jacobian; an FMU whose modelDescription does not say providesDirectionalDerivative="true" is
refused before the run, naming the instance: :func:`check_interface_jacobians`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.linalg import lapack

from flexfmu.cosim.slaves import model_description, where
from flexfmu.errors import CosimulationError, ParameterError

INTERFACE_JACOBIAN = "interface-jacobian"
#: the interface Jacobian over the step (InterfaceCoupling.step): for loops that close through states
STEP_JACOBIAN = "step-jacobian"
#: How the master couples the slaves in a step: Jacobi, Gauss-Seidel (file order), interface-Jacobian (above),
#: step-Jacobian (implicit in the held inputs)
COUPLING_SCHEMES = ("jacobi", "gauss-seidel", INTERFACE_JACOBIAN, STEP_JACOBIAN)
#: step-Jacobian: the central-difference step of a held input, relative to its size (at least 1 in SI units): exact
#: for a step whose outputs are affine in the held input (every linear slave's), else an error delta^2 |y'''| / 6;
#: rounding about u_r |y| / delta, ~1e-12 |y|
STEP_DIFFERENCE = 1e-4
#: step-Jacobian: the weight of the step's end in the outputs the held inputs follow, u = L (theta y(t + h) +
#: (1 - theta) y(t)) (the theta-method).  theta = 1 (the end alone) left unstable bands where a lightly damped mode
#: sits at the step's Nyquist frequency (a force held over a step against a velocity reversing within it feeds the
#: mode: the wave converter's rod at 4.479 ms, spectral radius 1.0097, and 20 ms, 1.035); theta = 1/2 (the step's
#: trapezoidal mean, exact in the power a held force exchanges with a linearly varying velocity) leaves no
#: damping for the instantaneous loops (1.09 at 1 ms on docs/stability.md's mass-ratio-10 harvester); 0.6, the
#: damped theta-method's usual choice, is stable on both up to 15 ms and 1 ms (tests/test_cosim_step_jacobian.py)
STEP_THETA = 0.6
#: The coupling matrix I - L D counts as singular (the loop has no unique solution: a loop gain of 1) when its
#: condition number exceeds this: beyond it the solved inputs would keep fewer than 4 of their 16 digits.
MAX_COUPLING_CONDITION = 1e12


class InterfaceCoupling:
    """The coupling equations u = L y of one system: which output feeds each connected input, and the solve of
    steps 2 to 4 (module docstring).

    order: the slaves' names; plan: target -> [(source, outputs, inputs)] (flexfmu.cosim.masters.Master.plan)."""

    def __init__(self, order, plan):
        self.order = tuple(order)
        # the unknowns: every connected input, grouped per slave in the master's order, and the output feeding each
        self.inputs = {name: tuple(i for _, _, ins in plan[name] for i in ins) for name in self.order}
        self.unknowns = [(name, i) for name in self.order for i in self.inputs[name]]
        self.feeds = [(src, out) for name in self.order for src, outs, _ in plan[name] for out in outs]
        self.offsets, at = {}, 0
        for name in self.order:
            self.offsets[name] = at
            at += len(self.inputs[name])
        self.size = at

    def solve(self, slaves, t: float) -> dict:
        """Steps 2 to 4 at the slaves' current state (time t, for messages): sets every connected input to the
        solution of the coupling equations and returns {slave: its outputs (output_names order) for them}."""
        held, outputs, jacobians = {}, {}, {}
        for name in self.order:
            slave, names = slaves[name], self.inputs[name]
            held[name] = np.array(slave.get(names), float)
            outputs[name] = np.array(slave.get(slave.output_names), float)
            jacobians[name] = slave.output_jacobian(names) if names else np.zeros((outputs[name].size, 0))
        u = self._linearised_solution(slaves, held, outputs, jacobians, t)
        result = {}
        for name in self.order:
            names = self.inputs[name]
            if names:
                slaves[name].set(names, u[name])
            result[name] = outputs[name] + jacobians[name] @ (u[name] - held[name])
        return result

    def step(self, slaves, t: float, h: float) -> None:
        """One step-Jacobian communication step from t to t + h: the inputs held over the step solve the coupling
        equations over it, u = L (theta y(t + h; u) + (1 - theta) y(t)) (STEP_THETA), with each slave's outputs at
        t + h linearised in the inputs it holds over the step, y_i(u_i) = y_i(u_i^n) + S_i (u_i - u_i^n), S_i = d y_i(t + h) / d u_i (held): the interface
        Jacobian over the step, the instantaneous D_i plus what the state does over the step (C_i dx_i/du_i).  So a
        loop that closes through a state (a damper's force from a velocity: D = 0) is solved too, as backward Euler
        solves a stiff term, where the instantaneous interface Jacobian and Gauss-Seidel lag it by about h/2.

        Each slave steps from its state at t (an FMU state, or the façade's) with u_i^n, then with each input moved by
        +/- delta (central differences: S exact for outputs affine in the inputs held over the step, every linear
        slave's), then once more with the solved inputs: 2 m_i + 2 steps of a slave with m_i connected inputs; a slave
        with none steps once.  Non-iterative: for linear slaves the result solves the step's coupling exactly."""
        held, outputs, jacobians, states = {}, {}, {}, {}
        try:
            for name in self.order:
                slave, names = slaves[name], self.inputs[name]
                held[name] = np.array(slave.get(names), float)
                before = np.array(slave.get(slave.output_names), float)
                if names:
                    states[name] = slave.snapshot()
                slave.do_step(t, h)
                outputs[name] = np.array(slave.get(slave.output_names), float)
                S = np.zeros((outputs[name].size, len(names)))
                for j, input_name in enumerate(names):
                    delta = STEP_DIFFERENCE * max(1.0, abs(held[name][j]))
                    moved = []
                    for sign in (1.0, -1.0):
                        slave.restore(states[name])
                        slave.set([input_name], [held[name][j] + sign * delta])
                        slave.do_step(t, h)
                        moved.append(np.array(slave.get(slave.output_names), float))
                    slave.set([input_name], [held[name][j]])
                    S[:, j] = (moved[0] - moved[1]) / (2.0 * delta)
                jacobians[name] = STEP_THETA * S
                outputs[name] = STEP_THETA * outputs[name] + (1.0 - STEP_THETA) * before
            u = self._linearised_solution(slaves, held, outputs, jacobians, t + h)
            for name in states:
                slaves[name].restore(states[name])
                slaves[name].set(self.inputs[name], u[name])
                slaves[name].do_step(t, h)
        finally:
            for name, state in states.items():
                slaves[name].discard(state)

    def _linearised_solution(self, slaves, held: dict, outputs: dict, jacobians: dict, t: float) -> dict:
        """{slave: its connected inputs} solving u = L (y + J (u - u_held)), J each slave's Jacobian."""
        position = {name: {o: k for k, o in enumerate(slaves[name].output_names)} for name in self.order}
        A = np.eye(self.size)
        b = np.empty(self.size)
        for k, (src, out) in enumerate(self.feeds):
            # row k: u_k - D_src[out, :] u_src = y^_src[out] - D_src[out, :] u^n_src
            row = jacobians[src][position[src][out]]
            j0 = self.offsets[src]
            A[k, j0:j0 + row.size] -= row
            b[k] = outputs[src][position[src][out]] - row @ held[src]
        u = self._solved(A, b, t)
        return {name: u[self.offsets[name]:self.offsets[name] + len(self.inputs[name])] for name in self.order}

    def _solved(self, A: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
        """u of A u = b; a matrix that is not finite or (numerically) singular is a CosimulationError."""
        if self.size == 0:
            return np.zeros(0)
        where = f"interface-jacobian at t = {t:.9g} s: the coupling equations (I - L D) u = L (y - D u_held)"
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
            bad = sorted({self.unknowns[k] for k in np.nonzero(~np.isfinite(A).all(axis=1) | ~np.isfinite(b))[0]})
            raise CosimulationError(f"{where} are not finite (the outputs or interface Jacobians feeding "
                                    f"{', '.join(f'{s}.{v}' for s, v in bad[:6])})")
        # LU and LAPACK's estimate of the 1-norm condition number (O(n^2) once factored); the SVD only on failure
        lu, pivots, info = lapack.dgetrf(A)
        rcond = lapack.dgecon(lu, np.linalg.norm(A, 1), norm="1")[0] if info == 0 else 0.0
        if not rcond * MAX_COUPLING_CONDITION >= 1.0:
            # the inputs the (near-)null vector moves most: the algebraic loop with a gain of 1
            loop = [self.unknowns[k] for k in np.argsort(-np.abs(np.linalg.svd(A)[2][-1]))[:4]]
            raise CosimulationError(f"{where} are singular (condition number {1 / max(rcond, 1e-300):.3g} > "
                                    f"{MAX_COUPLING_CONDITION:g}): an algebraic loop of gain 1 through "
                                    f"{', '.join(f'{s}.{v}' for s, v in loop)} has no unique solution "
                                    "(an ill-posed system: no scheme settles such a loop)")
        return lapack.dgetrs(lu, pivots, b)[0]


def check_interface_jacobians(system, checked, backend: str) -> None:
    """Before a run with the interface-Jacobian scheme over FMUs: every instance with a connected input
    (``checked``: flexfmu.cosim.checks.CheckedSystem, its connections output -> input) must provide directional
    derivatives, its modelDescription.xml saying providesDirectionalDerivative="true"; else a ParameterError naming
    the instance.  The library backend needs nothing: D comes from the façades."""
    if backend != "fmu":
        return
    fed = {target for _, _, target, _ in checked.connections}
    for spec in system.simulators:
        if spec.name in fed and not getattr(model_description(spec).coSimulation,
                                            "providesDirectionalDerivative", False):
            raise ParameterError(
                where(spec),
                f"{spec.name}: its FMU {Path(spec.source).name} provides no directional derivatives (its "
                "modelDescription.xml does not say providesDirectionalDerivative=\"true\"), which the "
                "interface-jacobian scheme needs for the interface Jacobian of its outputs in its inputs",
                "an FMU that provides them; or --master library (the flexfmu models the FMUs wrap, Jacobians from "
                "their output functions), or --scheme gauss-seidel | jacobi")
