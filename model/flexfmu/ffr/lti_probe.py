"""An FFRBeamSimulator's maps as flexfmu.native.lti's :class:`~flexfmu.native.lti.Probe`: what
``LtiModel.from_ffrbeam`` evaluates to extract the simulator's linear system (FFRBeamDynamics.system_matrix and
modal_force, the simulator's output maps and outputs, and the static correction's energy as a term of degree 4 in
p).  Here, beside the simulator, so that flexfmu.native imports no simulator (native sits below ffr:
docs/architecture.md, "Layers"); FFRBeamSimulator.lti_probe calls it.
"""
from __future__ import annotations

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.ffr.dynamics import BaseMotion, ModalState
from flexfmu.native.lti import (BASE_A, BASE_DW, BASE_OFFSET, BASE_W, Probe, fit_quadratic, inputs_of,
                                sample_points)


def ffrbeam_probe(sim, input_names: tuple, output_names: tuple) -> Probe:
    """The probe of an FFRBeamSimulator ``sim`` whose FMU variables are ``input_names`` and ``output_names``
    (flexfmu.ffr.simulator's INPUT_NAMES and OUTPUT_NAMES): x = [eta; eta_dot], u = [F, M, base_a] (body frame, at
    load_s), p = (damping_ratio, base_w, base_dw) and with geometric stiffening also base_a.  Integrator "exact" only
    (ParameterError naming ``integrator``)."""
    dyn0 = sim.dynamics
    if dyn0.integrator != "exact":
        raise ParameterError("integrator", f"got {dyn0.integrator!r}: the native kernel advances only the exact "
                                           "zero-order hold", "exact")
    gs = bool(dyn0.geometric_stiffening)
    index = {name: k for k, name in enumerate(input_names)}
    param_names = ("damping_ratio", *BASE_W, *BASE_DW, *(BASE_A if gs else ()))
    p_from_input = np.array([-1] + [index[n] for n in param_names[1:]])
    u_from_input = np.arange(9)
    p_start = np.zeros(len(param_names))
    p_start[0] = dyn0.damping_ratio
    m = dyn0.m
    copies = {}

    def at(zeta: float):
        zeta = float(zeta)
        if zeta not in copies:
            copies[zeta] = sim.with_damping(zeta)
        return copies[zeta]

    def base_of(p, a0=None):
        p = np.asarray(p, float)
        if a0 is None:
            a0 = p[7:10] if gs else np.zeros(3)
        return BaseMotion(a0=np.array(a0, float), omega=p[1:4].copy(), alpha=p[4:7].copy())

    def dynamics(p):
        d = at(p[0]).dynamics
        A = d.system_matrix(base_of(p))
        zero = np.zeros(3)
        f0 = d.modal_force(zero, zero, base_of(p, zero))          # K_eff's a0 is p's, the load's a0 is u's
        B = np.zeros((2 * m, 9))
        b = np.zeros(2 * m)
        b[m:] = f0
        for j in range(9):
            e = np.zeros(9)
            e[j] = 1.0
            B[m:, j] = d.modal_force(e[0:3], e[3:6], base_of(p, e[6:9])) - f0
        return A, B, b

    def output_maps(p):
        s = at(p[0])
        s.set_input_vector(inputs_of(probe, np.r_[np.zeros(6), p[7:10] if gs else np.zeros(3)], p))
        maps = s._maps(None)
        Cu = maps.Cu.copy()
        if maps.energy is not None:
            Cu[output_names.index("elastic_energy")] += maps.energy[1]   # the static correction's energy: u-linear part
        return maps.Cx.copy(), Cu, maps.y0.copy()

    def outputs(x, v, p):
        s = at(p[0])
        s.set_input_vector(v)
        s.state = ModalState(np.array(x[:m], float), np.array(x[m:], float), 0.0)
        return s.output_vector().copy()

    mono_quadratic = None
    n_p = len(param_names)
    offsets = [(0.25, 0.5)] + [(BASE_OFFSET, -BASE_OFFSET)] * (n_p - 1)
    if sim.static_correction is not None:
        # 1/2 X_ab^T R X_ab (R: the correction's energy matrix on the rotation patterns) with X_ab = T mono(p):
        # T fitted from the library's X_ab (sim.static_correction_weights)
        pts = sample_points(offsets)
        T = fit_quadratic(np.array([sim.static_correction_weights(base_of(p)) for p in pts]), offsets).T
        R = np.asarray(sim.static_correction.energy, float)[9:, 9:]
        V = [None] * len(output_names)
        V[output_names.index("elastic_energy")] = 0.5 * T.T @ R @ T
        mono_quadratic = V

    probe = Probe("FFRBeam", input_names, param_names, output_names, u_from_input, p_from_input, p_start,
                  dynamics, output_maps, outputs, offsets, mono_quadratic)
    return probe
