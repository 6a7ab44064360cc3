"""The point absorber's hull data: a freely floating vertical circular cylinder, radius 5 m, draft 3 m, deep water.

Frames and DOFs as flexfmu.wec.bem: O the waterplane centre on the axis at z = 0 (the mean free surface), x forward
(the wave's direction of travel, heading 0), y to port, z up, global (earth) axes, linear seakeeping;
xi = (surge, sway, heave [m], roll, pitch, yaw [rad]) of O, loads about O.

    mass         m = rho V,  V the BEM mesh's displaced volume; G = (0, 0, -1.5) m
    inertia      a uniform solid filling the displaced cylinder: about G I_xx = I_yy = m (3 r^2 + d^2) / 12,
                 I_zz = m r^2 / 2
    M_rb         [[m I, -m S(r_G)], [m S(r_G), I_G - m S(r_G)^2]]  about O (S = skew)
    M_total      M_rb + A_inf
    radiation    the Cummins memory (flexfmu.wec.radiation.fit_radiation, passivity enforced, RAD.4 tolerance
                 RADIATION_TOLERANCE = 3 %) over all six DOFs:
                 a DOF whose K(j w) is zero (yaw: the cylinder is axisymmetric) gets zero columns of B_r and rows
                 of C_r instead of a fit of the solver's rounding

The BEM database: Capytaine over 100 frequencies 0.05 .. 5 rad/s (step 0.05 rad/s), heading 0, panels of side
PANEL_SIZE = 0.43 m (1406 hull panels, largest panel radius 0.302 m: flexfmu.wec.bem.max_frequency 5.05 rad/s, the
database's top frequency resolved; 0.5 m panels resolve 4.7 rad/s only), the lid at flexfmu.wec.bem's
CYLINDER_LID_FACTOR.  Against 0.30 m panels (2862, resolving 6.0 rad/s) at 0.25 .. 2 rad/s: A33 within 0.14 %, B33
within 0.3 % to 1.25 rad/s, 1.0 % at 1.5, 4 % at 2 rad/s (1 % of its peak), |X3| within 0.2 % to 1.25 rad/s, 0.9 %
at 1.5 and 2 rad/s; A_inf33 0.12 %, the displaced volume 0.06 %.  ~2 minutes on one core, kept by
hydro_database's disk cache; the assembled AbsorberHull (with its radiation fit) is cached in memory and on disk
(flexfmu.core.cache, keyed by the database's parameters and this module's and the radiation fit's sources).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexfmu.wec.radiation import RadiationModel

RHO = 1025.0                   # kg/m^3
G = 9.81                       # m/s^2
RADIUS = 5.0                   # m
DRAFT = 3.0                    # m
Z_G = -1.5                     # m: centre of gravity below the waterline, on the axis
PANEL_SIZE = 0.43              # m: the mesh resolves the database's top frequency (module docstring)
OMEGA = np.linspace(0.05, 5.0, 100)        # rad/s
HEADINGS_DEG = (0.0,)
#: RAD.4 tolerance of the radiation fit: at 0.02 no passive fit of pitch exists up to order 20 (the enforcement takes its
#: error from 0.5 % to 3.5 %); at 0.03: 53 states, errors surge 2.6 %, heave 1.2 %, pitch 2.4 %
RADIATION_TOLERANCE = 0.03
_ZERO_DOF_TOLERANCE = 1e-6     # ||K_ii|| below this x the largest of its kind (translation, rotation): no radiation
_KIND = "absorber_hull"


@dataclass(frozen=True, eq=False)
class AbsorberHull:
    """The hull's data (SI; about O, global axes; DOF order surge, sway, heave, roll, pitch, yaw).

    X: complex excitation per unit wave amplitude at heading 0, (n_w, 6) (N/m, N m/m), Capytaine's convention
    Re(X a e^{-i w t}) with the crest at O at t = 0.  A, B: (n_w, 6, 6) added mass and radiation damping."""

    rho: float
    g: float
    radius: float
    draft: float
    mass: float
    M_rb: np.ndarray
    A_inf: np.ndarray
    C: np.ndarray
    radiation: RadiationModel
    omega: np.ndarray
    X: np.ndarray
    A: np.ndarray
    B: np.ndarray
    displaced_volume: float
    panel_size: float

    @property
    def M_total(self) -> np.ndarray:
        return self.M_rb + self.A_inf


def rigid_mass_matrix(mass: float, radius: float, draft: float, z_G: float) -> np.ndarray:
    """M_rb (6x6) about O of a uniform solid cylinder of the given mass with its centre of gravity at (0, 0, z_G)."""
    from flexfmu.core.vec3 import skew
    r_G = np.array([0.0, 0.0, z_G])
    S = skew(r_G)
    I_G = np.diag([mass * (3 * radius**2 + draft**2) / 12] * 2 + [mass * radius**2 / 2])
    M = np.zeros((6, 6))
    M[:3, :3] = mass * np.eye(3)
    M[:3, 3:] = -mass * S
    M[3:, :3] = mass * S
    M[3:, 3:] = I_G - mass * S @ S
    return M


def database(use_cache: bool = True):
    """The hull's BEM database (flexfmu.wec.bem.hydro_database; on-disk cached)."""
    from flexfmu.wec import bem
    return bem.hydro_database(bem.HullGeometry.cylinder(RADIUS, DRAFT, Z_G), omega=OMEGA, headings_deg=HEADINGS_DEG,
                              panel_size=PANEL_SIZE, rho=RHO, g=G, use_cache=use_cache)


def six_dof_radiation(ds) -> RadiationModel:
    """The radiation memory over all six DOFs: fit_radiation over the DOFs with radiation, embedded in six."""
    from dataclasses import replace

    from flexfmu.wec import bem, radiation
    from flexfmu.wec.wave import DOF_NAMES
    c = bem.coefficients(ds, DOF_NAMES)
    K = radiation.frequency_response(c.omega, c.A, c.B, c.A_inf)
    norms = np.array([np.linalg.norm(K[:, i, i]) for i in range(6)])
    radiating = [i for i in range(6)
                 if norms[i] > _ZERO_DOF_TOLERANCE * norms[[0, 1, 2] if i < 3 else [3, 4, 5]].max()]
    model = radiation.fit_radiation(ds, dofs=tuple(DOF_NAMES[i] for i in radiating), omega_max=float(c.omega[-1]),
                                    tolerance=RADIATION_TOLERANCE)
    n = model.order
    B_r, C_r = np.zeros((n, 6)), np.zeros((6, n))
    B_r[:, radiating], C_r[radiating, :] = model.B_r, model.C_r
    pairs = tuple(replace(p, i=radiating[p.i], j=radiating[p.j]) for p in model.pairs)
    return RadiationModel(DOF_NAMES, model.A_r, B_r, C_r, _symmetric(c.A_inf), pairs, model.tolerance,
                          model.passivity)


def _symmetric(A: np.ndarray) -> np.ndarray:
    # the BEM's A_inf is symmetric to its discretisation error; a mass matrix must be
    return 0.5 * (A + A.T)


def _build(ds) -> AbsorberHull:
    from flexfmu.wec import bem
    c = bem.coefficients(ds)
    volume = float(ds.attrs["displaced_volume"])
    mass = RHO * volume
    rad = six_dof_radiation(ds)
    return AbsorberHull(rho=RHO, g=G, radius=RADIUS, draft=DRAFT, mass=mass,
                        M_rb=rigid_mass_matrix(mass, RADIUS, DRAFT, Z_G), A_inf=rad.A_inf, C=np.array(c.C, float),
                        radiation=rad, omega=c.omega.copy(), X=c.X[:, 0, :].copy(), A=c.A.copy(), B=c.B.copy(),
                        displaced_volume=volume, panel_size=PANEL_SIZE)


_ARRAYS = ("M_rb", "A_inf", "C", "omega", "X", "A", "B")
_SCALARS = ("rho", "g", "radius", "draft", "mass", "displaced_volume", "panel_size")


def _to_arrays(hull: AbsorberHull) -> dict:
    out = {k: np.asarray(getattr(hull, k)) for k in _ARRAYS + _SCALARS}
    r = hull.radiation
    out.update(A_r=r.A_r, B_r=r.B_r, C_r=r.C_r, tolerance=np.asarray(r.tolerance))
    return out


def _from_arrays(a: dict) -> AbsorberHull:
    # a model read back carries no per-pair fit details (pairs, passivity report): the arrays are the model
    from flexfmu.wec.wave import DOF_NAMES
    rad = RadiationModel(DOF_NAMES, a["A_r"], a["B_r"], a["C_r"], a["A_inf"], (), float(a["tolerance"]), None)
    return AbsorberHull(**{k: float(a[k]) for k in _SCALARS}, **{k: np.array(a[k]) for k in _ARRAYS}, radiation=rad)


_MEMORY: dict = {}


def absorber_hull(use_cache: bool = True) -> AbsorberHull:
    """The point absorber's hull data, computed once per machine (Capytaine, ~3 min, and the radiation fit) and
    loaded once per process."""
    if use_cache and "hull" in _MEMORY:
        return _MEMORY["hull"]
    from flexfmu.core import cache
    from flexfmu.wec import bem, radiation, radiation_fit, radiation_passivity
    import capytaine
    key = cache.make_key(_KIND, radius=RADIUS, draft=DRAFT, z_G=Z_G, omega=OMEGA, headings=HEADINGS_DEG,
                         panel_size=PANEL_SIZE, rho=RHO, g=G, capytaine=capytaine.__version__,
                         sources=[cache.file_digest(m.__file__) for m in (bem, radiation, radiation_fit,
                                                                           radiation_passivity)]
                         + [cache.file_digest(__file__)])
    hull = None
    if use_cache:
        hit = cache.load(_KIND, key)
        if hit is not None:
            try:
                hull = _from_arrays(hit)
            except (KeyError, TypeError, ValueError):      # an entry of another layout is a miss
                hull = None
    if hull is None:
        hull = _build(database(use_cache))
        if use_cache:
            cache.store(_KIND, key, _to_arrays(hull))
    if use_cache:
        _MEMORY["hull"] = hull
    return hull
