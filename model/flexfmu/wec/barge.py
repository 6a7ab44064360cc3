"""The flexible barge: the wave converter's platform as a free flexible body (flexfmu.body, the reframe
kernels) instead of Platform's rigid 6-DOF box, carrying the harvester.

Structure: the box's hull as a solid slab (length x beam x thickness, centred at the rigid platform's centre
of gravity z_G) of quadratic hexahedra, its density set so that it weighs the displaced water, so that the
rigid motion has the rigid Platform's mass; a user's own hull (any mesh flexfmu.load_structure reads) goes
the same way.  Interfaces (RBE3-like patches, flexfmu.body.interfaces):

* ``wave`` and ``hydro`` at the waterplane centre O, patch: the bottom face.  The BEM database is a
  rigid-body one (no generalised modes), so its loads are resultants about O; spreading them over the
  wetted bottom by the patch's weights is what the database supports, no finer;
* ``mount`` and ``stator`` at the harvester's mount point, patch: the deck around it.

Infinite-frequency added mass.  It must stay inside the body (a delayed added-mass force is unstable
when it is comparable to the mass: here A_inf,33 = 0.94 m).  The reframe kernels carry one translational
mass, so the body takes the isotropic part a point mass can carry (:func:`split_added_mass`: A_33 at O,
the heave value, and the rotational block) through the hydro patch (build_body's added_mass), and
Hydrostatics applies the rest, -(A_inf - A_body) a, from the body's acceleration of the previous step
(parameter added_mass = "point").  That rest is small against the mass it acts on: |A_11 - A_33| /
(m + A_33) = 0.40 for the example box, which keeps the lagged part stable (measured in the tests).

Model size ("no more than the scene needs"): the modes up to f_max (examples/flexible_barge uses 1.5x the
harvester's first clamped frequency: the barge's vibration that can reach the harvester) plus the interfaces' static correction
(flexfmu.sizing.interfaces); the waves themselves (0.3 - 1.3 Hz) excite the rigid motion and the
quasi-static bending that the static correction carries exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.wec.wave import BoxParameters

#: hull material of the example: HDPE-like (E, nu); the density follows from the mass
HULL = {"E": 1.0e9, "nu": 0.42}


@dataclass(frozen=True)
class BargeParameters:
    """The slab: the box's length and beam (BoxParameters), ``thickness`` (m), centre height ``z_center`` (m,
    the rigid platform's z_G), elements along x, y, z, the mount point's x, y (m; on the deck, z = the slab's
    top) and the half-size of the deck patch around it (m)."""

    box: BoxParameters = BoxParameters()
    thickness: float = 0.05
    z_center: float = -0.1
    elements: tuple = (10, 6, 1)
    mount: tuple = (0.0, 0.0)
    deck_patch: float = 0.1
    E: float = HULL["E"]
    nu: float = HULL["nu"]

    def check(self) -> "BargeParameters":
        """Self, or ParameterError naming the field and its range."""
        from flexfmu.core.checks import finite
        for name in ("thickness", "deck_patch", "E"):
            value = getattr(self, name)
            if not (finite(value) and value > 0):
                raise ParameterError(name, f"got {value!r}", "> 0")
        if not (finite(self.nu) and 0.0 <= self.nu < 0.5):
            raise ParameterError("nu", f"got {self.nu!r}", "0 <= nu < 0.5")
        if not (len(self.elements) == 3 and all(isinstance(n, int) and n >= 1 for n in self.elements)):
            raise ParameterError("elements", f"got {self.elements!r}", "three integers >= 1 (x, y, z)")
        if not (finite(self.z_center) and len(self.mount) == 2 and all(finite(v) for v in self.mount)):
            raise ParameterError("mount", f"got {self.mount!r}, z_center {self.z_center!r}", "finite numbers")
        return self

    @property
    def mount_point(self) -> tuple:
        return (float(self.mount[0]), float(self.mount[1]), self.z_center + self.thickness / 2)

    @property
    def displaced_mass(self) -> float:
        b = self.box
        return b.rho * b.length * b.beam * b.draft

    @property
    def density(self) -> float:
        b = self.box
        return self.displaced_mass / (b.length * b.beam * self.thickness)


def slab_mesh(p: BargeParameters):
    """A meshio Mesh of 20-node hexahedra (Abaqus C3D20 order) with point sets bottom, top and deck (the top
    nodes within deck_patch of the mount point in x and y)."""
    import meshio

    nx, ny, nz = p.check().elements
    L, B, t = p.box.length, p.box.beam, p.thickness
    # a (2n+1)^3 lattice of which the hexahedra's corner and mid-edge nodes are kept
    xs = np.linspace(-L / 2, L / 2, 2 * nx + 1)
    ys = np.linspace(-B / 2, B / 2, 2 * ny + 1)
    zs = np.linspace(p.z_center - t / 2, p.z_center + t / 2, 2 * nz + 1)
    index = -np.ones((xs.size, ys.size, zs.size), dtype=np.int64)
    corners = [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2)]
    mids = [(1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2), (0, 1, 2),
            (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1)]
    points, cells = [], []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                cell = []
                for (a, b, c) in corners + mids:
                    key = (2 * i + a, 2 * j + b, 2 * k + c)
                    if index[key] < 0:
                        index[key] = len(points)
                        points.append((xs[key[0]], ys[key[1]], zs[key[2]]))
                    cell.append(index[key])
                cells.append(cell)
    points = np.array(points)
    z = points[:, 2]
    bottom = np.flatnonzero(np.isclose(z, zs[0]))
    top = np.flatnonzero(np.isclose(z, zs[-1]))
    near = (np.abs(points[top, 0] - p.mount[0]) <= p.deck_patch + 1e-12) & (
        np.abs(points[top, 1] - p.mount[1]) <= p.deck_patch + 1e-12)
    return meshio.Mesh(points, [("hexahedron20", np.array(cells))],
                       point_sets={"bottom": bottom, "top": top, "deck": top[near]})


def split_added_mass(A_inf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A_body, A_lagged) with A_inf = A_body + A_lagged (6x6 about O, [translation; rotation], global axes):
    A_body = diag(A_33 I, rotational block) is what a point mass at O can carry (one translational mass, the
    heave value, which dominates a barge's), A_lagged the rest (surge and sway differences, the coupling)."""
    A = np.asarray(A_inf, dtype=float)
    if A.shape != (6, 6) or not np.all(np.isfinite(A)):
        raise ParameterError("A_inf", f"shape {A.shape}", "a finite 6x6 added-mass matrix")
    A = 0.5 * (A + A.T)
    body = np.zeros((6, 6))
    body[:3, :3] = A[2, 2] * np.eye(3)
    body[3:, 3:] = A[3:, 3:]
    return body, A - body


def barge_structure(p: BargeParameters, folder: Path):
    """The slab as a flexfmu Structure (written to ``folder``/barge.inp with its barge.json, then read back by
    flexfmu.load_structure, the path a user's own hull file takes)."""
    import json

    import meshio

    from flexfmu.importers import load_structure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    meshio.write(folder / "barge.inp", slab_mesh(p), file_format="abaqus")
    (folder / "barge.json").write_text(json.dumps({
        "mesh": "barge.inp", "length_unit": "m", "name": "barge",
        "material": {"E": p.E, "nu": p.nu, "rho": p.density}}, indent=2) + "\n")
    return load_structure(folder / "barge.json")


def barge_interfaces(p: BargeParameters) -> list[dict]:
    mount = list(p.mount_point)
    return [{"name": "wave", "point": [0.0, 0.0, 0.0], "node_set": "bottom", "moments": True},
            {"name": "hydro", "point": [0.0, 0.0, 0.0], "node_set": "bottom", "moments": True},
            {"name": "mount", "point": mount, "node_set": "deck", "moments": True},
            {"name": "stator", "point": mount, "node_set": "deck", "moments": True}]


def build_barge(p: BargeParameters, folder: Path, *, A_inf: np.ndarray, f_max: float, tolerance: float = 1e-3,
                damping_ratio: float = 0.02, gauges=()):
    """The barge's FlexBody: the slab with the body's share of A_inf at O (:func:`split_added_mass`), the
    modes up to f_max and the interfaces' static correction; ``gauges``: stress gauges as flexfmu.body.build_body
    takes them (``NAME=SET`` or ``NAME=X,Y,Z`` in the slab's coordinates, m; :func:`deck_gauge`)."""
    from flexfmu.body.build import build_body

    structure = barge_structure(p, folder)
    A_body, _ = split_added_mass(A_inf)
    return build_body(structure, interfaces=barge_interfaces(p), f_max=f_max, tolerance=tolerance,
                      damping_ratio=damping_ratio, name="barge", added_mass={"hydro": A_body}, gauges=gauges)


def deck_gauge(p: BargeParameters, name: str = "deck") -> str:
    """A gauge on the slab's midship section, a quarter beam off the centreline (clear of the mount's deck patch
    there) and an eighth of the thickness under the deck: where the slab's hogging and sagging stress is largest
    outside the patch, as ``NAME=X,Y,Z`` text."""
    z = p.z_center + 0.5 * p.thickness - 0.125 * p.thickness
    return f"{name}={p.mount[0]:.9g},{p.mount[1] + 0.25 * p.box.beam:.9g},{z:.9g}"


#: the barge's interfaces that replace Platform's inputs, and the outputs that replace its motion outputs
_PLATFORM_INPUTS = {"wave": "wave", "hydro": "hydro", "payload": "mount", "pto": "stator"}
_PLATFORM_OUTPUTS = {**{f"pos_{a}": f"hydro.pos_{a}" for a in "xyz"}, **{f"vel_{a}": f"hydro.vel_{a}" for a in "xyz"},
                     **{f"acc_{a}": f"hydro.acc_{a}" for a in "xyz"}, **{f"rot_{a}": f"rot_{a}" for a in "xyz"},
                     **{f"omega_{a}": f"omega_{a}" for a in "xyz"}, **{f"alpha_{a}": f"alpha_{a}" for a in "xyz"},
                     **{f"mount_a_{a}": f"mount.acc_{a}" for a in "xyz"},
                     **{f"mount_v_{a}": f"mount.vel_{a}" for a in "xyz"}}


def barge_system(system, barge_fmu: Path, name: str = "barge", hydrodynamics: str = "bem"):
    """The wave-converter ``system`` (flexfmu.cosim.masters.System with one Platform) with the platform replaced by
    the exported barge FMU: Platform's load inputs become the barge's interface inputs, its motion outputs the
    barge's (O's rigid fit and the frame's rotation, global), and Hydrostatics gets the barge's acceleration for
    the lagged part of the added mass (added_mass = point).  WaveExcitation and Hydrostatics get
    ``hydrodynamics`` (the barge must carry the same model's added mass: build_barge's A_inf)."""
    from dataclasses import replace as _replace

    from flexfmu.cosim.masters import SimulatorSpec

    platforms = system.by_model("Platform")
    if len(platforms) != 1:
        raise ParameterError("SYSTEM_FILE", f"{len(platforms)} Platform instances", "exactly one Platform")
    old = platforms[0].name
    hydro = [s.name for s in system.by_model("Hydrostatics")]
    sims = []
    for s in system.simulators:
        if s.name == old:
            sims.append(SimulatorSpec(name, Path(barge_fmu), {}))
        elif s.name in hydro:
            sims.append(_replace(s, initial_values={**s.initial_values, "added_mass": "point",
                                                    "hydrodynamics": hydrodynamics}))
        elif s.model == "WaveExcitation":
            sims.append(_replace(s, initial_values={**s.initial_values, "hydrodynamics": hydrodynamics}))
        else:
            sims.append(s)
    connections = []
    for (sa, va), (sb, vb) in system.connections:
        if sb == old:                                     # a load on the platform: group_F_x -> interface.F_x
            group, rest = vb.split("_", 1)
            connections.append(((sa, va), (name, f"{_PLATFORM_INPUTS[group]}.{rest}")))
        elif sa == old:
            connections.append(((name, _PLATFORM_OUTPUTS[va]), (sb, vb)))
        else:
            connections.append(((sa, va), (sb, vb)))
    for h in hydro:
        connections += [((name, _PLATFORM_OUTPUTS[f"{q}_{a}"]), (h, f"{q}_{a}")) for q in ("acc", "alpha")
                        for a in "xyz"]
    return _replace(system, simulators=sims, connections=connections)


def harvester_f1(system) -> float:
    """The first clamped natural frequency (Hz) of the system's FFRBeam harvester, with its start values."""
    from flexfmu.cosim.masters import LibrarySlave
    from flexfmu.ffr.simulator import FFRBeamSimulator

    found = system.by_model("FFRBeam")
    if len(found) != 1:
        raise ParameterError("SYSTEM_FILE", f"{len(found)} FFRBeam instances", "exactly one FFRBeam (the harvester)")
    return float(FFRBeamSimulator(LibrarySlave(found[0]).config).frequencies_hz[0])


def rigid_box(p: BargeParameters) -> BoxParameters:
    """The rigid box with the slab's rigid-body mass matrix (uniform L x B x t box at z_center, the displaced
    mass): what the barge is when its elastic modes are left out."""
    b, t = p.box, p.thickness
    return BoxParameters(length=b.length, beam=b.beam, draft=b.draft, z_G=p.z_center,
                         r_xx=float(np.sqrt((b.beam ** 2 + t ** 2) / 12)),
                         r_yy=float(np.sqrt((b.length ** 2 + t ** 2) / 12)),
                         r_zz=float(np.sqrt((b.length ** 2 + b.beam ** 2) / 12)), rho=b.rho, g=b.g)


def rigid_system(system, p: BargeParameters, hydrodynamics: str = "bem"):
    """The wave-converter ``system`` with its Platform given the barge's rigid-body mass matrix and mount point
    (and ``hydrodynamics`` on the wave components): the rigid counterpart of :func:`barge_system`."""
    from dataclasses import asdict

    box = asdict(rigid_box(p))
    mount = dict(zip(("mount_x", "mount_y", "mount_z"), p.mount_point))
    values = {}
    for s in system.simulators:
        if s.model == "Platform":
            values[s.name] = {**box, **mount, "hydrodynamics": hydrodynamics}
        elif s.model in ("WaveExcitation", "Hydrostatics"):
            values[s.name] = {"hydrodynamics": hydrodynamics}
    return system.with_values(values)


class BargeInLoop:
    """The barge's simulator in Platform's place of flexfmu.wec.rao.cosimulated_motion (library simulators coupled
    as the Gauss-Seidel master): wave and hydro loads at their interfaces, Hydrostatics' inputs from the hydro
    interface's rigid fit and the frame's global rotation; keeps the largest elastic displacement seen, read every
    ``every`` steps (its search grows with the mesh)."""

    def __init__(self, body, every: int = 50):
        from flexfmu.body.simulator import FlexBodySimulator
        self.sim = FlexBodySimulator(body)
        self.every, self.count, self.largest_elastic = every, 0, 0.0

    def hold_loads(self, wave: dict, hydro: dict) -> None:
        self.sim.set_inputs(**{f"{g}.{q}_{a}": o[f"{q}_{a}"] for g, o in (("wave", wave), ("hydro", hydro))
                               for q in "FM" for a in "xyz"})

    def step(self, h: float) -> None:
        self.sim.step(h)
        if self.count % self.every == 0:
            self.largest_elastic = max(self.largest_elastic, self.sim.outputs()["max_elastic_displacement"])
        self.count += 1

    def motion(self) -> dict:
        out = self.sim.outputs()
        return {name: out[barge_name] for name, barge_name in _PLATFORM_OUTPUTS.items()
                if not name.startswith("mount_")}
