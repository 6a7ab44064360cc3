"""The harvester of the wave-energy converter: FFRBeam (flexfmu.ffr.simulator) clamped on the platform, its role in
the system (SYSTEM_ROLE; FFRBeam's registry row names this module, since the simulator lives in flexfmu.ffr) and
the harvester point per boundary.

The rod's energy: its strain energy (an FFRBeam output), its rigid-body kinetic energy (its inertia about the mount
point and the motion of the platform that carries it) and, with the library backend, what only its state holds:
its elastic kinetic energy (with the coupling to the base velocity) and the power of its modal damping.
"""
from __future__ import annotations

import numpy as np

from flexfmu.errors import require
from flexfmu.wec.roles import (DISSIPATED, KINETIC, POTENTIAL, Panel, Role, Term, amplitude, change, integral,
                               summary_line)

#: arc length (m) of the harvester point (PTO and sensor) per boundary: the free tip, except for XFX,
#: whose tip is clamped: there the second corner.
HARVESTER_POINT_S = {"XFF": 0.45, "FXF": 0.45, "FXF_mid": 0.45, "XFX": 0.30}


def point_position(scene: str, s: float) -> np.ndarray:
    """Undeformed body-frame position of arc length s on a scene's polyline."""
    from flexfmu.ffr.scene import load_scene
    pts = np.asarray(load_scene(scene).points, float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    acc = np.concatenate([[0.0], np.cumsum(seg)])
    i = min(int(np.searchsorted(acc, s, side="right")) - 1, len(seg) - 1)
    return pts[i] + (s - acc[i]) / seg[i] * (pts[i + 1] - pts[i])


def harvester_values(boundary: str, scene: str = "spatial_double_L") -> dict:
    """Start values that put the harvester point (FFRBeam load_s = sensor_s, PTO attach) where a
    boundary leaves it free to move: {instance model: {variable: value}}."""
    require(boundary in HARVESTER_POINT_S, "boundary", f"got {boundary!r}", " | ".join(HARVESTER_POINT_S))
    s = HARVESTER_POINT_S[boundary]
    r = point_position(scene, s)
    return {"FFRBeam": {"boundary": boundary, "load_s": s, "sensor_s": s},
            "PTO": {"attach_x": float(r[0]), "attach_y": float(r[1]), "attach_z": float(r[2])}}


class HarvesterRole(Role):
    """The rod on the platform: kinetic, strain and modal-damping energy; the harvester point's motion."""

    kind = "harvester"

    @staticmethod
    def carrier(m):
        """The instance whose motion is the rod's base (it feeds base_a), or None."""
        src = m.roster.source(m.name, "base_a_x")
        return None if src is None else src[0]

    def recorder(self, m):
        from flexfmu.ffr.dynamics import _cross_integral
        platform = self.carrier(m)
        if platform is None:
            return None

        def record(slaves):
            beam = slaves[m.name].sim
            plat = slaves[platform]
            dyn = beam.dynamics
            ed = beam.state.eta_dot
            v_m = np.array(plat.get(["mount_v_x", "mount_v_y", "mount_v_z"]))
            w = np.array(plat.get(["omega_x", "omega_y", "omega_z"]))
            s_v = dyn.S_bar_hat @ ed                                        # int rho S q_dot
            Pqd = np.einsum("abk,k->ab", dyn.P_hat, ed)                     # int rho (S q_dot)_a u0_b
            ke_el = 0.5 * float(ed @ ed) + float(v_m @ s_v) + float(w @ _cross_integral(Pqd.T))
            return {"elastic_kinetic": ke_el, "damping_power": float(ed @ (dyn.damping * ed))}
        return record

    def energy(self, m, r):
        from flexfmu.ffr.simulator import FFRBeamSimulator
        terms = []
        platform = self.carrier(m)
        if platform is not None:
            ints = FFRBeamSimulator(m.config).dynamics.integrals
            v_m, w = r.vec(platform, "mount_v_{}"), r.vec(platform, "omega_{}")
            ke_rigid = (0.5 * ints.mass * np.einsum("ij,ij->i", v_m, v_m)
                        + np.einsum("ij,ij->i", v_m, np.cross(w, ints.first_moment))
                        + 0.5 * np.einsum("ij,jk,ik->i", w, ints.J0, w))
            terms.append(Term(KINETIC, "kinetic: harvester rigid-body" + m.suffix, change(ke_rigid)))
        elastic, damping = r.extra(m.name, "elastic_kinetic"), r.extra(m.name, "damping_power")
        if elastic is not None:
            terms.append(Term(KINETIC, "kinetic: harvester elastic (library)" + m.suffix, change(elastic)))
        terms.append(Term(POTENTIAL, "potential: harvester strain" + m.suffix, change(r.col(m.name, "elastic_energy"))))
        if damping is not None:
            terms.append(Term(DISSIPATED, "dissipated: harvester modal damping (library)" + m.suffix,
                              integral(damping, r.t)))
        return terms

    def summary(self, m, r, sel):
        amp = lambda v: amplitude(r.col(m.name, v), sel)   # noqa: E731
        return [summary_line(f"harvester point{m.suffix}, relative",
                             f"{max(amp(f'sensor_u_{a}') for a in 'xyz'):.4g} m, "
                             f"{max(amp(f'sensor_v_{a}') for a in 'xyz'):.4g} m/s (largest component)")]

    def panels(self, m, r):
        return [Panel("harvester" + m.suffix, "harvester point: elastic displacement relative to the platform "
                      f"(body frame){m.suffix}", "um",
                      [(1e6 * r.col(m.name, f"sensor_u_{a}"), {"lw": 0.8, "label": f"u_{a}"}) for a in "xyz"])]


#: what FFRBeam is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = HarvesterRole()
