"""The reduced model of a flexible body (:class:`FlexBody`): everything its simulator needs and nothing that needs
the original model file, saved as one ``.npz``.

File (``FlexBody.save``; np.savez_compressed, read with allow_pickle=False):

    header                 JSON text: format "flexfmu-body", version, kind, name, dofs_per_node, n_modes,
                           damping_ratio, mass, the interfaces (name, point, moments, how the patch was chosen),
                           the provenance (source, format, reader, units, material, notes, reduction) and messages
    eigenvalues            (m,) omega^2 of the retained elastic coordinates (modes, then residual vectors), rad^2/s^2
    natural_frequencies_hz (<= 6,) the lowest natural frequencies (free: elastic; clamped: of the clamped structure)
    center_of_mass (3,), inertia (3, 3) about it (kg m^2, body axes), clamped_dofs (k,)
    if<i>.nodes, if<i>.dofs, if<i>.D (6, n_fit), if<i>.shapes (n_fit, m)   interface i: patch, Eq. (I3) of
                           flexfmu.body.interfaces, the patch DOFs' rows of the retained coordinates
    inv.<name>             the kind's reduced arrays (free: flexfmu.body.free.free_invariants; clamped:
                           flexfmu.body.clamped.clamped_invariants)

Size: a free body keeps the translational mode rows of every node (for max_elastic_displacement), 3 N m
numbers; a clamped body only O(m^2) numbers per coordinate pair.
"""
from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError

FORMAT = "flexfmu-body"
FORMAT_VERSION = 1
KINDS = ("free", "clamped")


def _shapes(kind: str, m: int) -> dict:
    """Expected shapes of the kind's reduced arrays (None: any length on that axis)."""
    if kind == "free":
        return {"mass": (), "J0": (3, 3), "Aj": (m, 3, 3), "Bsym": (m, 3, 3), "Cjk": (m, m, 3, 3), "Dj": (m, 3, m),
                "A6": (6, 6), "center_of_mass": (3,), "inertia": (3, 3), "nodes": (None, 3),
                "translations": (None, 3, m)}
    return {"mass": (), "first_moment": (3,), "J0": (3, 3), "Sa": (m, 3), "Sw": (m, 3), "B": (3, m, m),
            "N": (3, 3, m, m), "R": (3, 3, m), "Vp": (2, 3, m), "Va": (2, 3, 3, m), "Vq": (2, 3, 3, 3, m),
            "Vr": (2, 3, 3, m), "arm": (15, 3, m)}


@dataclass
class InterfaceData:
    """An interface as the body keeps it: point (3,) m body frame, patch nodes and fitted DOFs, D (6, n_fit)
    (flexfmu.body.interfaces Eq. (I3)), shapes (n_fit, m) the patch DOFs' rows of the retained coordinates,
    whether M is an input, and how the patch was chosen."""

    name: str
    point: np.ndarray
    nodes: np.ndarray
    dofs: np.ndarray
    D: np.ndarray
    shapes: np.ndarray
    moments: bool
    rule: str = ""

    @property
    def rows(self) -> np.ndarray:
        """(6, m): the point's translation and rotation per retained coordinate, D Phi_patch."""
        return self.D @ self.shapes


@dataclass
class FlexBody:
    """A reduced flexible body (module docstring).  kind: "free" | "clamped"; eigenvalues: omega^2 of the m
    retained elastic coordinates, the first n_modes eigenmodes, the rest residual-flexibility vectors;
    natural_frequencies_hz: f_1 ... (at most six); mass (kg), center_of_mass (3,) m and inertia (3, 3) kg m^2
    about it, body frame; arrays: the kind's reduced arrays; provenance: JSON-able text about the source and the
    reduction; messages: what the reduction chose and why."""

    kind: str
    name: str
    dofs_per_node: int
    interfaces: tuple
    eigenvalues: np.ndarray
    n_modes: int
    natural_frequencies_hz: np.ndarray
    mass: float
    center_of_mass: np.ndarray
    inertia: np.ndarray
    damping_ratio: float
    arrays: dict
    provenance: dict = field(default_factory=dict)
    messages: tuple = ()
    clamped_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def n_coordinates(self) -> int:
        """Retained elastic coordinates m (eigenmodes and residual vectors)."""
        return int(self.eigenvalues.size)

    @property
    def frequencies_hz(self) -> np.ndarray:
        """(n_modes,) natural frequencies of the retained eigenmodes, Hz (what a step must resolve: the residual
        vectors are stepped exactly or by the exponential scheme)."""
        return self.coordinate_frequencies_hz[:self.n_modes]

    @property
    def coordinate_frequencies_hz(self) -> np.ndarray:
        """(m,) frequencies of all retained coordinates, Hz (residual vectors: their Rayleigh frequencies)."""
        return np.sqrt(np.maximum(self.eigenvalues, 0.0)) / (2.0 * math.pi)

    def summary(self) -> str:
        what = "free flexible body" if self.kind == "free" else "flexible body clamped to a moving base"
        return (f"{self.name or 'body'}: {what}, {self.mass:.6g} kg, {self.n_modes} mode(s)"
                + (f" + {self.n_coordinates - self.n_modes} residual vector(s)" if self.n_coordinates > self.n_modes
                   else "") + f", interfaces {', '.join(i.name for i in self.interfaces)}")

    def describe(self) -> list[str]:
        """Lines for documentation and logs: the model, its source, its reduction, the interfaces."""
        p = self.provenance
        lines = [self.summary()]
        for key in ("source", "format", "reader", "units", "material"):
            if p.get(key):
                lines.append(f"{key}: {p[key]}")
        lines += [f"note: {n}" for n in p.get("notes", [])]
        red = p.get("reduction", {})
        if red:
            lines.append("reduction: " + "; ".join(f"{k} = {v}" for k, v in red.items()))
        lines += list(self.messages)
        f = ", ".join(f"{x:.6g}" for x in self.natural_frequencies_hz)
        lines.append(f"lowest natural frequencies: {f} Hz")
        lines.append(f"mass {self.mass:.6g} kg, centre of mass {np.round(self.center_of_mass, 9).tolist()} m")
        for i in self.interfaces:
            lines.append(f"interface {i.name}: point {np.round(i.point, 9).tolist()} m, {i.rule}"
                         + (", force and moment" if i.moments else ", force only"))
        return lines

    # ------------------------------------------------------------------ file
    def save(self, path) -> Path:
        """Write the body as one compressed .npz (module docstring); returns the path."""
        path = Path(path)
        header = {"format": FORMAT, "version": FORMAT_VERSION, "kind": self.kind, "name": self.name,
                  "dofs_per_node": int(self.dofs_per_node), "n_modes": int(self.n_modes),
                  "damping_ratio": float(self.damping_ratio), "mass": float(self.mass),
                  "interfaces": [{"name": i.name, "point": np.asarray(i.point, float).tolist(),
                                  "moments": bool(i.moments), "rule": i.rule} for i in self.interfaces],
                  "provenance": self.provenance, "messages": list(self.messages), "arrays": sorted(self.arrays)}
        data = {"header": np.array(json.dumps(header, allow_nan=False)),
                "eigenvalues": self.eigenvalues, "natural_frequencies_hz": self.natural_frequencies_hz,
                "center_of_mass": self.center_of_mass, "inertia": self.inertia,
                "clamped_dofs": np.asarray(self.clamped_dofs, np.int64)}
        for k, i in enumerate(self.interfaces):
            data.update({f"if{k}.nodes": np.asarray(i.nodes, np.int64), f"if{k}.dofs": np.asarray(i.dofs, np.int64),
                         f"if{k}.D": i.D, f"if{k}.shapes": i.shapes})
        data.update({f"inv.{k}": v for k, v in self.arrays.items()})
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **data)
        return path

    @classmethod
    def load(cls, path) -> "FlexBody":
        """Read a body written by :meth:`save`; ParameterError naming the file for a missing, corrupt or
        incompatible one."""
        name = str(path)

        def bad(why, allowed=f"a {FORMAT} file of version {FORMAT_VERSION} written by FlexBody.save"):
            raise ParameterError(name, why, allowed)

        try:
            with np.load(path, allow_pickle=False) as z:
                files = {k: z[k] for k in z.files}
        except FileNotFoundError:
            bad("no such file")
        except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
            bad(f"not a readable .npz ({type(exc).__name__}: {exc})")
        try:
            header = json.loads(str(files["header"]))
        except (KeyError, ValueError, TypeError):
            bad("no readable header")
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            bad("not a flexfmu body file")
        if header.get("version") != FORMAT_VERSION:
            bad(f"format version {header.get('version')!r}")
        try:
            return _from_parts(header, files)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            bad(f"inconsistent content ({type(exc).__name__}: {exc})")


def _array(files, key, shape, integer=False):
    a = np.asarray(files[key])
    if integer:
        if a.dtype.kind not in "iu":
            raise ValueError(f"{key}: not integers")
    elif a.dtype.kind != "f" or not np.all(np.isfinite(a)):
        raise ValueError(f"{key}: not finite floats")
    if shape is not None and (a.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, a.shape))):
        raise ValueError(f"{key}: shape {a.shape}, expected {shape}")
    return a


def _from_parts(header: dict, files: dict) -> FlexBody:
    kind = header["kind"]
    if kind not in KINDS:
        raise ValueError(f"kind {kind!r}")
    eig = _array(files, "eigenvalues", (None,))
    m = eig.size
    n_modes = int(header["n_modes"])
    if not 0 <= n_modes <= m:
        raise ValueError(f"n_modes {n_modes} for {m} coordinates")
    dpn = int(header["dofs_per_node"])
    if dpn not in (3, 6):
        raise ValueError(f"dofs_per_node {dpn}")
    interfaces = []
    for k, meta in enumerate(header["interfaces"]):
        dofs = _array(files, f"if{k}.dofs", (None,), integer=True)
        D = _array(files, f"if{k}.D", (6, dofs.size))
        shapes = _array(files, f"if{k}.shapes", (dofs.size, m))
        point = np.array(meta["point"], dtype=float)
        if point.shape != (3,) or not np.all(np.isfinite(point)):
            raise ValueError(f"interface {k} point")
        interfaces.append(InterfaceData(name=str(meta["name"]), point=point,
                                        nodes=_array(files, f"if{k}.nodes", (None,), integer=True), dofs=dofs, D=D,
                                        shapes=shapes, moments=bool(meta["moments"]), rule=str(meta.get("rule", ""))))
    names = [i.name for i in interfaces]
    if not names or len(set(names)) != len(names):
        raise ValueError("interface names missing or not unique")
    expected = _shapes(kind, m)
    if sorted(header["arrays"]) != sorted(expected):
        raise ValueError(f"reduced arrays {sorted(header['arrays'])}")
    arrays = {k: _array(files, f"inv.{k}", shape) for k, shape in expected.items()}
    damping = float(header["damping_ratio"])
    if not 0.0 <= damping < 1.0:
        raise ValueError(f"damping_ratio {damping}")
    mass = float(header["mass"])
    if not (math.isfinite(mass) and mass > 0):
        raise ValueError(f"mass {mass}")
    return FlexBody(kind=kind, name=str(header["name"]), dofs_per_node=dpn, interfaces=tuple(interfaces),
                    eigenvalues=eig, n_modes=n_modes,
                    natural_frequencies_hz=_array(files, "natural_frequencies_hz", (None,)), mass=mass,
                    center_of_mass=_array(files, "center_of_mass", (3,)), inertia=_array(files, "inertia", (3, 3)),
                    damping_ratio=damping, arrays=arrays, provenance=dict(header.get("provenance") or {}),
                    messages=tuple(str(s) for s in header.get("messages", ())),
                    clamped_dofs=_array(files, "clamped_dofs", (None,), integer=True))
