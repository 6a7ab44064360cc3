"""Hydrodynamic database of a floating hull from the boundary-element solver Capytaine: frequency-dependent
added mass A(w) and radiation damping B(w), infinite-frequency added mass A_inf, the excitation force
X(w, beta) (Froude-Krylov + diffraction), the hydrostatic stiffness C and the rigid-body inertia.

Conventions (all SI).  Axes as flexfmu.wec.wave: x forward, y to port, z up, z = 0 the mean free surface.
The six rigid-body DOFs (surge, sway, heave, roll, pitch, yaw) are those of the Platform model
(flexfmu.wec.platform): small displacements of, and small rotations about, the reference point O at the
origin of the mesh coordinates on the free surface, for the box its waterplane centre.  Forces and
moments are about O.  Time dependence is Capytaine's, Re(Z e^{-i w t}): the motion xi(t) = Re(xi_hat
e^{-i w t}) under the excitation Re(X a e^{-i w t}) of a wave of amplitude a whose crest passes O at
t = 0, heading beta (rad) the direction of travel from x.  Infinite depth.

    radiation force        F_rad = w^2 A(w) xi_hat + i w B(w) xi_hat                       (BEM.1)
    motion (frequency)     [-w^2 (M + A(w)) - i w B(w) + C] xi_hat = X(w, beta) a          (BEM.2)

The dataset is Capytaine's (``capytaine.BEMSolver.fill_dataset``) with the finite frequencies along
``omega``, plus ``added_mass_inf`` (the w = inf problem), ``hydrostatic_stiffness`` computed exactly
from the panels (:func:`mesh_hydrostatics`, eq. BEM.3; Capytaine's own one-point-per-panel estimate is
kept as ``hydrostatic_stiffness_capytaine``), and provenance attributes.  It is stored as NetCDF: this
environment has neither netCDF4 nor h5netcdf, so xarray's scipy backend writes NETCDF3_64BIT (complex
arrays split into a ``complex`` = re, im dimension, Capytaine's own convention for NetCDF).  Databases
are cached on disk through flexfmu.core.cache, keyed by the geometry, the frequencies, headings, the
panel size, rho, g, the centre of gravity, Capytaine's version and this module's source.
"""
from __future__ import annotations

import io
import math
import os
from dataclasses import dataclass, fields
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError, require
from flexfmu.wec.wave import DOF_NAMES, BoxParameters

#: Capytaine's names of the rigid-body DOFs, in the order of DOF_NAMES.
CAPYTAINE_DOFS = ("Surge", "Sway", "Heave", "Roll", "Pitch", "Yaw")
#: the panel radius must stay below this fraction of the wavelength (Capytaine's own warning threshold)
PANELS_PER_WAVELENGTH = 8
DEFAULT_PANEL_SIZE = 0.05          # m: 560 hull panels on the example box
DEFAULT_HEADINGS_DEG = (0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0)
_KIND = "bem"
#: the cylinder's lid nearer the surface than Capytaine's lowest_lid_position (whose rule is a rectangular
#: waterline's): on the point absorber's cylinder (radius 5 m, draft 3 m, 0.43 m panels, omega_max 5 rad/s) its lid at
#: z = -0.357 m left a spurious heave resonance at 4.75 rad/s (B33 11 kN s/m, 14 % of its peak), one at -0.6 m spikes
#: in B11 and B33 from 4.6 rad/s, one at 0.7 x (-0.25 m) none from 4.5 to 5.5 rad/s
CYLINDER_LID_FACTOR = 0.7


def default_frequencies(n: int = 80, omega_min: float = 0.2, omega_max: float = 15.0) -> np.ndarray:
    """Evenly spaced angular frequencies (rad/s): periods 0.42 .. 31 s by default, the wave band 0.8 .. 3 s
    and the decay of B(w) the radiation fit needs (flexfmu.wec.radiation: a uniform grid also serves the
    cosine transform of eq. RAD.1)."""
    require(isinstance(n, (int, np.integer)) and 4 <= n <= 2000, "n", f"got {n!r}", "4 .. 2000")
    require(0 < omega_min < omega_max < math.inf, "omega_min, omega_max", f"got {omega_min!r}, {omega_max!r}",
            "0 < omega_min < omega_max < inf")
    return np.linspace(omega_min, omega_max, int(n))


def max_frequency(panel_radius: float, g: float = 9.81) -> float:
    """Highest angular frequency (rad/s) a mesh of panels of radius r resolves: wavelength 2 pi g / w^2 >=
    PANELS_PER_WAVELENGTH r (deep water)."""
    return math.sqrt(2 * math.pi * g / (PANELS_PER_WAVELENGTH * panel_radius))


# ------------------------------------------------------------------ geometry
@dataclass(frozen=True)
class HullGeometry:
    """A hull for the BEM: a box (length, beam, draft; mesh generated), a vertical circular cylinder (radius,
    draft; mesh generated, O on its axis) or a mesh file (any format Capytaine or meshio reads; coordinates
    in m, z = 0 the free surface, the reference point O at the origin; only the part below z = 0 is used).
    centre of gravity (x_G, y_G, z_G) from O; the hull floats freely (mass = rho * displaced volume)."""

    length: float = 0.0
    beam: float = 0.0
    draft: float = 0.0
    mesh_file: str = ""
    x_G: float = 0.0
    y_G: float = 0.0
    z_G: float = -0.10
    radius: float = 0.0            # > 0: the vertical cylinder (length and beam then 0)

    @classmethod
    def box(cls, params: BoxParameters) -> "HullGeometry":
        return cls(length=params.length, beam=params.beam, draft=params.draft, z_G=params.z_G)

    @classmethod
    def cylinder(cls, radius: float, draft: float, z_G: float) -> "HullGeometry":
        return cls(draft=draft, z_G=z_G, radius=radius)

    @property
    def is_cylinder(self) -> bool:
        return not self.mesh_file and self.radius != 0.0

    @property
    def is_box(self) -> bool:
        return not self.mesh_file and self.radius == 0.0

    def smallest_dimension(self) -> float:
        """The generated mesh's smallest dimension (m): the largest panel size it takes."""
        return min(self.radius, self.draft) if self.is_cylinder else min(self.length, self.beam, self.draft)

    def check(self) -> "HullGeometry":
        if self.is_cylinder:
            for name in ("radius", "draft"):
                v = getattr(self, name)
                require(isinstance(v, (int, float)) and math.isfinite(v) and v > 0, name, f"got {v!r}",
                        "> 0 m for the cylinder")
            for name in ("length", "beam"):
                require(getattr(self, name) == 0.0, name, f"got {getattr(self, name)!r} with radius {self.radius!r}",
                        "0 for the cylinder (a box has radius 0)")
        elif self.is_box:
            for name in ("length", "beam", "draft"):
                v = getattr(self, name)
                require(isinstance(v, (int, float)) and math.isfinite(v) and v > 0, name, f"got {v!r}",
                        "> 0 m (or a mesh_file)")
        else:
            require(Path(self.mesh_file).is_file(), "mesh_file", f"{self.mesh_file!r} is not a file",
                    "a mesh file Capytaine or meshio reads")
        for name in ("x_G", "y_G", "z_G"):
            v = getattr(self, name)
            require(isinstance(v, (int, float)) and math.isfinite(v), name, f"got {v!r}", "a finite coordinate (m)")
        return self

    def key(self) -> dict:
        """What the database depends on (a mesh file by its content)."""
        from flexfmu.core.cache import file_digest
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        if d["radius"] == 0.0:                   # boxes and mesh files keep the keys they had before the cylinder
            del d["radius"]
        if self.mesh_file:
            d["mesh_file"] = file_digest(str(Path(self.mesh_file).resolve()))
        return d


def _capytaine():
    try:
        import capytaine
    except ImportError as exc:                       # an optional dependency: say how to get it
        raise ImportError("the BEM database needs Capytaine: pip install 'flexfmu[bem]'") from exc
    return capytaine


def box_mesh(length: float, beam: float, draft: float, panel_size: float = DEFAULT_PANEL_SIZE):
    """Capytaine mesh of the wetted box (z in [-draft, 0], O at the waterplane centre), panels of at most
    panel_size per side, with the two vertical symmetry planes (Capytaine solves on a quarter)."""
    cpt = _capytaine()
    _check_panel_size(panel_size, min(length, beam, draft))
    # an even number of panels across each symmetry plane; the box is meshed to 2 * draft and clipped at
    # z = 0, so the clipped height keeps whole panels
    res = (2 * max(1, math.ceil(length / (2 * panel_size))), 2 * max(1, math.ceil(beam / (2 * panel_size))),
           2 * max(1, math.ceil(draft / panel_size)))
    mesh = cpt.mesh_parallelepiped(size=(length, beam, 2 * draft), center=(0.0, 0.0, 0.0), resolution=res,
                                   reflection_symmetry=True, name="box")
    return mesh.immersed_part()


def cylinder_mesh(radius: float, draft: float, panel_size: float = DEFAULT_PANEL_SIZE):
    """Capytaine mesh of the wetted vertical cylinder (z in [-draft, 0], O on the axis at z = 0), panels of at
    most panel_size per side (ring, sector and slice), with the x-z symmetry plane (Capytaine solves on a half;
    its axial symmetry would be faster, but its lid generation returns no panels for it)."""
    cpt = _capytaine()
    _check_panel_size(panel_size, min(radius, draft))
    # an even number of sectors (the symmetry plane); meshed to 2 * draft and clipped at z = 0 as the box
    res = (max(1, math.ceil(radius / panel_size)), 2 * max(2, math.ceil(math.pi * radius / panel_size)),
           2 * max(1, math.ceil(draft / panel_size)))
    mesh = cpt.mesh_vertical_cylinder(length=2 * draft, radius=radius, center=(0.0, 0.0, 0.0), resolution=res,
                                      reflection_symmetry=True, name="cylinder")
    return mesh.immersed_part()


def _check_panel_size(panel_size: float, size: float) -> None:
    require(isinstance(panel_size, (int, float)) and math.isfinite(panel_size) and 0 < panel_size <= size,
            "panel_size", f"got {panel_size!r}", f"0 < panel_size <= {size:.4g} m (the smallest hull dimension)")


def floating_body(geometry: HullGeometry, panel_size: float = DEFAULT_PANEL_SIZE, omega_max: float = 15.0):
    """The Capytaine FloatingBody: wetted hull, an interior lid below the free surface (removes the irregular
    frequencies of the boundary integral equation: without it B11 of the example box dips by 30 % near
    11.5 rad/s), the six rigid DOFs about O.  The lid sits at Capytaine's lowest_lid_position(omega_max):
    a lid nearer the surface left spikes of -5 % of max B33 near 10.5 rad/s, a deeper one spurious
    resonances (measured on the example box)."""
    cpt = _capytaine()
    geometry.check()
    if geometry.is_box:
        mesh = box_mesh(geometry.length, geometry.beam, geometry.draft, panel_size)
    elif geometry.is_cylinder:
        mesh = cylinder_mesh(geometry.radius, geometry.draft, panel_size)
    else:
        try:
            mesh = cpt.load_mesh(geometry.mesh_file)
        except Exception as exc:                     # any reader error: the file is what is wrong
            raise ParameterError("mesh_file", f"{geometry.mesh_file!r} cannot be read ({exc})",
                                 "a mesh file Capytaine or meshio reads") from exc
        mesh = mesh.immersed_part()
        require(mesh.nb_faces > 0 and mesh.volume > 0, "mesh_file", f"{geometry.mesh_file!r} has no wetted part",
                "a hull that pierces z = 0 with its origin at the reference point")
    draft = -float(np.min(mesh.vertices[:, 2]))
    with np.errstate(invalid="ignore"):
        z_lid = float(mesh.lowest_lid_position(omega_max=omega_max))
    if not math.isfinite(z_lid):                 # Capytaine's bound is NaN when no depth limits omega_max
        z_lid = -0.5 * draft
    elif geometry.is_cylinder:
        z_lid *= CYLINDER_LID_FACTOR
    lid = mesh.generate_lid(z=min(max(z_lid, -0.5 * draft), -1e-3 * draft))
    return cpt.FloatingBody(mesh=mesh, lid_mesh=lid, center_of_mass=(geometry.x_G, geometry.y_G, geometry.z_G),
                            dofs=cpt.rigid_body_dofs(rotation_center=(0.0, 0.0, 0.0)), name="hull")


# ------------------------------------------------------------------ exact hydrostatics
def _triangles(mesh) -> np.ndarray:
    """The hull's panels as triangles (n, 3, 3) (quads split by a fan; degenerate repeats dropped)."""
    full = mesh.merged() if hasattr(mesh, "merged") else mesh
    V = np.asarray(full.vertices, float)
    tris = []
    for face in full.faces:
        idx = list(dict.fromkeys(int(i) for i in face))        # drops a repeated last vertex of a triangle
        for a, b in zip(idx[1:-1], idx[2:]):
            tris.append((idx[0], a, b))
    return V[np.array(tris)]


def mesh_hydrostatics(mesh, rho: float, g: float, center_of_mass) -> dict:
    """Volume, centre of buoyancy, waterplane moments and the 6x6 hydrostatic stiffness about O (on z = 0)
    of a wetted hull mesh, exact for planar panels:

        int_wp f dA = -iint_hull f n_z dS   (f independent of z),   V = iint z n_z dS,
        V r_B = iint (x z, y z, z^2 / 2) n_z dS                      (divergence theorem on hull + waterplane)
        C33 = rho g A_wp,  C34 = rho g S_y,  C35 = -rho g S_x,  C45 = -rho g I_xy,
        C44 = rho g (I_yy + V z_B) - m g z_G,  C55 = rho g (I_xx + V z_B) - m g z_G,
        C46 = -rho g V x_B + m g x_G,  C56 = -rho g V y_B + m g y_G       (m = rho V)          (BEM.3)

    with S_x = int x dA, I_xx = int x^2 dA, I_yy = int y^2 dA, I_xy = int x y dA over the waterplane.
    The integrands are quadratic: the edge-midpoint rule per triangle integrates them exactly (Capytaine's
    one point per panel misses the panels' own second moments, O(h^2))."""
    tri = _triangles(mesh)
    area_vec = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])   # outward: Capytaine's normals
    mids = 0.5 * (tri + np.roll(tri, -1, axis=1))                               # (n, 3 midpoints, xyz)
    x, y, z = mids[..., 0], mids[..., 1], mids[..., 2]
    nz = area_vec[:, 2]

    def flux(f):                          # iint f n_z dS, f evaluated at the 3 midpoints
        return float(np.sum(nz * f.mean(axis=1)))

    one = np.ones_like(x)
    A_wp, S_x, S_y = -flux(one), -flux(x), -flux(y)
    I_xx, I_yy, I_xy = -flux(x * x), -flux(y * y), -flux(x * y)
    V = flux(z)
    r_B = np.array([flux(x * z), flux(y * z), flux(0.5 * z * z)]) / V
    xG, yG, zG = np.asarray(center_of_mass, float)
    m = rho * V
    C = np.zeros((6, 6))
    C[2, 2] = rho * g * A_wp
    C[2, 3] = C[3, 2] = rho * g * S_y
    C[2, 4] = C[4, 2] = -rho * g * S_x
    C[3, 4] = C[4, 3] = -rho * g * I_xy
    C[3, 3] = rho * g * (I_yy + V * r_B[2]) - m * g * zG
    C[4, 4] = rho * g * (I_xx + V * r_B[2]) - m * g * zG
    C[3, 5] = -rho * g * V * r_B[0] + m * g * xG
    C[4, 5] = -rho * g * V * r_B[1] + m * g * yG
    return {"volume": V, "center_of_buoyancy": r_B, "waterplane_area": A_wp, "waterplane_first_moments": (S_x, S_y),
            "waterplane_second_moments": (I_xx, I_yy, I_xy), "mass": m, "hydrostatic_stiffness": C}


# ------------------------------------------------------------------ the database
def hydro_database(geometry: HullGeometry | BoxParameters = BoxParameters(), omega=None,
                   headings_deg=DEFAULT_HEADINGS_DEG, panel_size: float = DEFAULT_PANEL_SIZE,
                   rho: float | None = None, g: float | None = None, use_cache: bool = True):
    """The BEM database (an xarray Dataset; see the module docstring) of a hull, cached on disk.

    geometry: a HullGeometry, or BoxParameters (its length, beam, draft, z_G; rho and g default to its own).
    omega: finite angular frequencies (rad/s), default :func:`default_frequencies`; headings in degrees.
    panel_size: the box's or cylinder's panel side (m; a mesh file is used as it is, panel_size only enters the key)."""
    if isinstance(geometry, BoxParameters):
        rho = geometry.rho if rho is None else rho
        g = geometry.g if g is None else g
        geometry = HullGeometry.box(geometry)
    require(isinstance(geometry, HullGeometry), "geometry", f"got {type(geometry).__name__}",
            "HullGeometry or BoxParameters")
    geometry.check()
    rho = 1025.0 if rho is None else rho
    g = 9.81 if g is None else g
    for name, v in (("rho", rho), ("g", g)):
        require(isinstance(v, (int, float)) and math.isfinite(v) and v > 0, name, f"got {v!r}", "> 0")
    omega = default_frequencies() if omega is None else np.asarray(omega, float).ravel()
    require(omega.size >= 1 and np.all(np.isfinite(omega)) and np.all(omega > 0) and np.all(np.diff(omega) > 0),
            "omega", "must be finite, > 0 and increasing", "0 < omega_1 < omega_2 < ... rad/s")
    headings = np.asarray(headings_deg, float).ravel()
    require(headings.size >= 1 and np.all(np.isfinite(headings)), "headings_deg", f"got {headings_deg!r}",
            "finite angles in degrees")
    if not geometry.mesh_file:
        _check_panel_size(panel_size, geometry.smallest_dimension())
    cpt = _capytaine()
    from flexfmu.core import cache
    key = cache.make_key(_KIND, geometry=geometry.key(), omega=omega, headings_deg=headings,
                         panel_size=float(panel_size), rho=float(rho), g=float(g), capytaine=cpt.__version__,
                         source=cache.file_digest(__file__))
    if use_cache:
        hit = cache.load(_KIND, key)
        if hit is not None and "netcdf" in hit:
            try:
                return from_netcdf_bytes(hit["netcdf"].tobytes())
            except Exception:                        # an unreadable entry is a miss
                pass
    ds = _compute(geometry, omega, np.radians(headings), panel_size, rho, g)
    if use_cache:
        cache.store(_KIND, key, {"netcdf": np.frombuffer(to_netcdf_bytes(ds), dtype=np.uint8)})
    return ds


def _compute(geometry: HullGeometry, omega, headings, panel_size, rho, g):
    import xarray as xr
    cpt = _capytaine()
    from flexfmu import __version__
    body = floating_body(geometry, panel_size, float(omega[-1]))
    dofs = list(body.dofs)
    problems = xr.Dataset(coords={"omega": np.concatenate([omega, [np.inf]]), "wave_direction": headings,
                                  "radiating_dof": dofs, "water_depth": [np.inf], "rho": [float(rho)],
                                  "g": [float(g)]})
    cpt.set_logging("ERROR")      # Capytaine logs each skipped w = inf diffraction problem as a warning
    # one thread: the solver's own threads oversubscribe a shared machine (measured 10x slower on 2 busy cores)
    ds = cpt.BEMSolver().fill_dataset(problems, body, n_threads=1, progress_bar=False, _check_wavelength=False)
    inf = ds.sel(omega=np.inf)
    ds = ds.sel(omega=omega)
    ds["added_mass_inf"] = inf["added_mass"].drop_vars([c for c in inf["added_mass"].coords
                                                        if c not in ("influenced_dof", "radiating_dof")])
    hs = mesh_hydrostatics(body.mesh, rho, g, body.center_of_mass)
    ds["hydrostatic_stiffness_capytaine"] = ds["hydrostatic_stiffness"]
    ds["hydrostatic_stiffness"] = (("influenced_dof", "radiating_dof"), hs["hydrostatic_stiffness"])
    radius = float(np.max(body.mesh.faces_radiuses))
    ds.attrs.update({
        "flexfmu_version": __version__,
        "capytaine_version": cpt.__version__,
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "geometry": repr(geometry),
        "reference_point": "O = (0, 0, 0): mesh origin on the free surface (the box's or cylinder's waterplane "
                           "centre); "
                           "DOFs surge sway heave (m) roll pitch yaw (rad) of O, loads about O",
        "time_convention": "Re(Z exp(-i omega t)); wave crest at O at t = 0",
        "water_depth": "infinite",
        "rho": float(rho), "g": float(g),
        "panel_size": float(panel_size),
        "hull_panels": int(body.mesh.nb_faces),
        "lid_panels": int(body.lid_mesh.nb_faces),
        "lid_z": float(np.min(body.lid_mesh.vertices[:, 2])),
        "max_panel_radius": radius,
        "omega_resolved_max": max_frequency(radius, g),
        "omega_min": float(omega[0]), "omega_max": float(omega[-1]), "n_omega": int(omega.size),
        "headings_deg": np.degrees(headings).tolist(),
        "hydrostatic_stiffness_method": "exact panel integration (flexfmu.wec.bem.mesh_hydrostatics, eq. BEM.3)",
        "displaced_volume": hs["volume"],
    })
    return ds


# ------------------------------------------------------------------ NetCDF
def _netcdf_ready(ds):
    from capytaine.io.xarray import separate_complex_values
    out = separate_complex_values(ds)
    for c in ("radiating_dof", "influenced_dof"):
        out[c] = out[c].astype(str)
    out.attrs = {k: (v if isinstance(v, (str, int, float, list)) else str(v)) for k, v in out.attrs.items()}
    return out


def to_netcdf_bytes(ds) -> bytes:
    """The dataset as NetCDF-3 bytes (xarray's scipy backend; complex values split as Capytaine does)."""
    return bytes(_netcdf_ready(ds).to_netcdf(engine="scipy"))


def from_netcdf_bytes(data: bytes):
    import xarray as xr
    from capytaine.io.xarray import merge_complex_values
    with xr.open_dataset(io.BytesIO(data), engine="scipy") as ds:
        return merge_complex_values(ds.load())


def save_database(ds, path) -> Path:
    """Write the database to a NetCDF file (NETCDF3_64BIT, atomic: a temporary file renamed)."""
    path = Path(path)
    require(path.suffix == ".nc", "path", f"got {str(path)!r}", "a file name ending in .nc")
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(to_netcdf_bytes(ds))
    os.replace(tmp, path)
    return path


def load_database(path):
    """Read a database written by :func:`save_database` (or Capytaine's ``export_dataset``, NetCDF-3)."""
    path = Path(path)
    require(path.is_file(), "path", f"{str(path)!r} is not a file", "a .nc file written by save_database")
    return from_netcdf_bytes(path.read_bytes())


# ------------------------------------------------------------------ coefficient access
def _mat(da, dofs) -> np.ndarray:
    names = [CAPYTAINE_DOFS[DOF_NAMES.index(d)] for d in dofs]
    return da.sel(influenced_dof=names, radiating_dof=names).transpose(..., "influenced_dof", "radiating_dof").values


def _dofs(dofs) -> tuple:
    dofs = tuple(dofs)
    for d in dofs:
        require(d in DOF_NAMES, "dofs", f"got {d!r}", " | ".join(DOF_NAMES))
    return dofs


@dataclass(frozen=True)
class Coefficients:
    """Plain arrays of a database over the DOFs ``dofs`` (names of flexfmu.wec.wave.DOF_NAMES): omega (n,),
    A, B (n, d, d), A_inf, C (d, d), X (n, n_beta, d) per unit wave amplitude, headings (rad)."""

    dofs: tuple
    omega: np.ndarray
    A: np.ndarray
    B: np.ndarray
    A_inf: np.ndarray
    C: np.ndarray
    X: np.ndarray
    headings: np.ndarray


def coefficients(ds, dofs=DOF_NAMES) -> Coefficients:
    dofs = _dofs(dofs)
    names = [CAPYTAINE_DOFS[DOF_NAMES.index(d)] for d in dofs]
    X = ds["excitation_force"].sel(influenced_dof=names).transpose("omega", "wave_direction", "influenced_dof").values
    return Coefficients(dofs, ds["omega"].values.astype(float), _mat(ds["added_mass"], dofs),
                        _mat(ds["radiation_damping"], dofs), _mat(ds["added_mass_inf"], dofs),
                        _mat(ds["hydrostatic_stiffness"], dofs), X, ds["wave_direction"].values.astype(float))


# ------------------------------------------------------------------ RAO
def response_amplitude_operator(ds, mass_matrix, heading_deg: float = 0.0, omega=None,
                                dofs=DOF_NAMES, extra_damping=None) -> tuple[np.ndarray, np.ndarray]:
    """Complex RAO xi_hat / a (m/m, rad/m) of the free floating hull from eq. BEM.2, (omega, RAO (n, d)).

    mass_matrix: the rigid-body 6x6 mass matrix about O (flexfmu.wec.wave.FloatingBox.rigid_mass_matrix:
    the Platform's M_rb); heading_deg must be one of the database's headings; omega defaults to the
    database's frequencies (others: A, B, X interpolated linearly, inside its range only); extra_damping:
    an optional 6x6 linear damping (viscous, PTO) added to B."""
    dofs = _dofs(dofs)
    M = np.asarray(mass_matrix, float)
    require(M.shape == (6, 6) and np.all(np.isfinite(M)), "mass_matrix", f"shape {M.shape}", "a finite 6x6 matrix")
    headings = np.degrees(ds["wave_direction"].values.astype(float))
    j = np.flatnonzero(np.isclose(headings, heading_deg, atol=1e-9))
    require(j.size == 1, "heading_deg", f"got {heading_deg!r}", f"one of the database's {headings.round(6).tolist()}")
    c = coefficients(ds, DOF_NAMES)
    w0 = c.omega
    w = w0 if omega is None else np.asarray(omega, float).ravel()
    require(np.all(w >= w0[0]) and np.all(w <= w0[-1]), "omega", f"{w.min():.4g} .. {w.max():.4g} rad/s",
            f"{w0[0]:.4g} .. {w0[-1]:.4g} rad/s (the database's range)")

    def interp(arr):                      # along the first axis
        flat = arr.reshape(arr.shape[0], -1)
        re = np.array([np.interp(w, w0, flat[:, k].real) for k in range(flat.shape[1])]).T
        im = np.array([np.interp(w, w0, flat[:, k].imag) for k in range(flat.shape[1])]).T if np.iscomplexobj(arr) else 0
        return (re + 1j * im).reshape((w.size,) + arr.shape[1:]) if np.iscomplexobj(arr) else re.reshape((w.size,) + arr.shape[1:])

    A, B, X = interp(c.A), interp(c.B), interp(c.X[:, j[0], :])
    B_extra = np.zeros((6, 6)) if extra_damping is None else np.asarray(extra_damping, float)
    idx = [DOF_NAMES.index(d) for d in dofs]
    # surge, sway and yaw have no restoring: the free-floating 6x6 system is regular at w > 0 only
    rao = np.empty((w.size, len(dofs)), complex)
    for n, wn in enumerate(w):
        H = -wn**2 * (M + A[n]) - 1j * wn * (B[n] + B_extra) + c.C
        rao[n] = np.linalg.solve(H, X[n])[idx]
    return w, rao
