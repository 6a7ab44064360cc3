"""A clamped body's FlexBodySimulator maps as flexfmu.native.lti's :class:`~flexfmu.native.lti.Probe`: what
``LtiModel.from_clamped_body`` evaluates to extract the body's linear system (ClampedDynamics.system_matrix and
modal_force, and the simulator's outputs, differenced in x and u).  Here, beside the simulator, so that
flexfmu.native imports no simulator (native sits below body: docs/architecture.md, "Layers");
FlexBodySimulator.lti_probe calls it through ClampedBody.lti_probe.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from flexfmu.native.lti import BASE_DW, BASE_OFFSET, BASE_W, Probe, inputs_of


def clamped_body_probe(sim) -> Probe:
    """The probe of a clamped body's FlexBodySimulator ``sim``: x = [eta; eta_d], u = the interface loads and
    base_a, p = (damping_ratio, base_w, base_dw); outputs the simulator's output_names.  ClampedBody.lti_probe
    calls it; a free body has no such form (FlexBody.lti_probe: ParameterError naming ``body``)."""
    body = sim.body
    names = tuple(sim.input_names)
    index = {name: k for k, name in enumerate(names)}
    param_names = ("damping_ratio", *BASE_W, *BASE_DW)
    p_from_input = np.array([-1] + [index[n] for n in param_names[1:]])
    u_from_input = np.array([k for k, n in enumerate(names) if n not in param_names])
    zeta0 = float(sim.engine.dyn.zeta)
    p_start = np.zeros(len(param_names))
    p_start[0] = zeta0
    m = sim.engine.dyn.m
    copies = {}

    def at(zeta: float):
        zeta = float(zeta)
        if zeta not in copies:
            copies[zeta] = type(sim)(body, dataclasses.replace(sim.config, damping_ratio=zeta))
        return copies[zeta]

    def dynamics(p):
        s = at(p[0])
        e = s.engine
        d = e.dyn
        v = inputs_of(probe, np.zeros(len(u_from_input)), p)
        s.set_input_vector(v)
        A = d.system_matrix(e.w, e.alpha)
        f0 = d.modal_force(e.loads, e.a0, e.w, e.alpha)
        B = np.zeros((2 * m, len(u_from_input)))
        b = np.zeros(2 * m)
        b[m:] = f0
        for j in range(len(u_from_input)):
            u = np.zeros(len(u_from_input))
            u[j] = 1.0
            s.set_input_vector(inputs_of(probe, u, p))
            B[m:, j] = d.modal_force(e.loads, e.a0, e.w, e.alpha) - f0
        return A, B, b

    def outputs(x, v, p):
        s = at(p[0])
        state = s.get_state()
        state["x"] = np.asarray(x, float).tolist()
        state["inputs"] = dict(zip(names, np.asarray(v, float).tolist()))
        s.set_state(state)
        return s.output_vector().copy()

    def output_maps(p):
        """Central differences of the outputs in x (u = 0) and in u (x = 0): exact for outputs affine in each
        (terms quadratic in x or in u cancel, those in x and u vanish)."""
        nx, nu = 2 * m, len(u_from_input)
        v0 = inputs_of(probe, np.zeros(nu), p)
        zx = np.zeros(nx)
        y0 = outputs(zx, v0, p)
        Cx = np.zeros((y0.size, nx))
        Cu = np.zeros((y0.size, nu))
        for a in range(nx):
            e = np.zeros(nx)
            e[a] = 1.0
            Cx[:, a] = 0.5 * (outputs(e, v0, p) - outputs(-e, v0, p))
        for j in range(nu):
            e = np.zeros(nu)
            e[j] = 1.0
            Cu[:, j] = 0.5 * (outputs(zx, inputs_of(probe, e, p), p) - outputs(zx, inputs_of(probe, -e, p), p))
        return Cx, Cu, y0

    offsets = [(0.25, 0.5)] + [(BASE_OFFSET, -BASE_OFFSET)] * (len(param_names) - 1)
    probe = Probe("clamped body", names, param_names, tuple(sim.output_names), u_from_input, p_from_input, p_start,
                  dynamics, output_maps, outputs, offsets, None)
    return probe
