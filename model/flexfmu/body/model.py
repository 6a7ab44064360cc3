"""The reduced model of a flexible body: everything its simulator needs and nothing that needs the original model
file, saved as one ``.npz``.  :class:`FlexBody` holds what every body has; its two kinds are classes, each owning
what differs: :class:`FreeBody` (the reframe kernels on reduced invariants) and :class:`ClampedBody` (a body clamped
to a moving base): the names and shapes of their reduced arrays, their wording, their FMU's parameters, inputs and
outputs, their engine (flexfmu.body.engines) and their native FMU's model kind.

File (``FlexBody.save``; np.savez_compressed, read with allow_pickle=False; ``FlexBody.load`` returns the class its
header's kind names):

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
    gauge<g>.strain, gauge<g>.stress  (6, m) gauge g's strain (1) and stress (Pa) per retained coordinate (VOIGT,
                           body frame; flexfmu.body.stress), its name and place in the header's "gauges"
                           (optional: a file without gauges has neither)

Size: a free body keeps the translational mode rows of every node (for max_elastic_displacement), 3 N m
numbers; a clamped body only O(m^2) numbers per coordinate pair.
"""
from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import ClassVar

import numpy as np

from flexfmu.body.engines import ClampedEngine, FreeEngine
from flexfmu.body.stress import GaugeData
from flexfmu.core.stress import VOIGT, DerivedStress
from flexfmu.body.variables import AXES, ClampedBodyConfig, FlexBodyConfig, axes_info, parameter_info
from flexfmu.errors import ParameterError

FORMAT = "flexfmu-body"
FORMAT_VERSION = 1

# the variables a kind adds to its interfaces' (FreeBody, ClampedBody; their values: flexfmu.body.engines)
#: a free body's outputs after the interfaces': its frame's motion, its centre of mass, the elastic displacement
FREE_BODY_OUTPUTS = (tuple(f"pos_{a}" for a in AXES) + tuple(f"vel_{a}" for a in AXES) + ("q_w", "q_x", "q_y", "q_z")
                     + tuple(f"omega_{i}" for i in (1, 2, 3)) + tuple(f"alpha_{i}" for i in (1, 2, 3))
                     + tuple(f"com_pos_{a}" for a in AXES) + tuple(f"com_vel_{a}" for a in AXES)
                     + ("max_elastic_displacement",))
#: the body frame's rotation in global components (what a seakeeping or a clamped component downstream reads):
#: rotation vector, angular velocity and acceleration; computed from q and omega_k, alpha_k (body)
FRAME_GLOBAL_OUTPUTS = (tuple(f"rot_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES)
                        + tuple(f"alpha_{a}" for a in AXES))
#: a clamped body's outputs after the interfaces': what it exerts on its clamps
REACTION_OUTPUTS = tuple(f"reaction_F_{a}" for a in AXES) + tuple(f"reaction_M_{a}" for a in AXES)
#: a clamped body's inputs after the interfaces': its base's motion, body frame
BASE_INPUTS = (tuple(f"base_a_{a}" for a in AXES) + tuple(f"base_w_{a}" for a in AXES)
               + tuple(f"base_dw_{a}" for a in AXES))


def gauge_output_names(name: str) -> tuple[str, ...]:
    """A gauge's outputs, in order: NAME.sigma_xx .. NAME.sigma_xz, NAME.von_mises, NAME.eps_xx .. NAME.eps_xz."""
    return (tuple(f"{name}.sigma_{c}" for c in VOIGT) + (f"{name}.von_mises",)
            + tuple(f"{name}.eps_{c}" for c in VOIGT))


class _ClassConstant:
    """A class attribute that instances cannot rebind (a body's kind is its class)."""

    def __init__(self, value):
        self.value = value

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        return self.value

    def __set__(self, obj, value):
        raise AttributeError(f"{type(obj).__name__}.{self.name} is its class's ({self.value!r}): read-only")


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
    """A reduced flexible body (module docstring): a :class:`FreeBody` or a :class:`ClampedBody`.  eigenvalues:
    omega^2 of the m retained elastic coordinates, the first n_modes eigenmodes, the rest residual-flexibility
    vectors; natural_frequencies_hz: f_1 ... (at most six); mass (kg), center_of_mass (3,) m and inertia (3, 3)
    kg m^2 about it, body frame; arrays: the kind's reduced arrays (``array_shapes``); provenance: JSON-able text
    about the source and the reduction; messages: what the reduction chose and why.

    What a kind decides is its class's (class attributes, and the methods below that read them): ``kind`` (the
    file header's word), ``what`` (the summary's), ``config_class`` (the FMU's parameters), ``engine_class``
    (flexfmu.body.engines), ``native_kind`` (the native FMU's model kind: flexfmu.fmi.native), ``body_inputs`` and
    ``body_outputs`` (after the interfaces'), ``deferred_outputs``, the wording of the variables (``frame``,
    ``interface_notes``, ``frequency_text``, ``_body_variable_info``), ``array_shapes``, ``check_initial_motion``
    and ``lti_probe``."""

    kind: ClassVar[str]
    what: ClassVar[str]
    config_class: ClassVar[type]
    engine_class: ClassVar[type]
    native_kind: ClassVar[str]
    body_inputs: ClassVar[tuple] = ()
    body_outputs: ClassVar[tuple] = ()
    #: outputs whose cost grows with the mesh (computed only when read, flexfmu.fmi.plumbing)
    deferred_outputs: ClassVar[tuple] = ()
    #: the frame of the interfaces' loads and motion, and what each of pos, vel, acc adds to its description
    frame: ClassVar[str]
    interface_notes: ClassVar[dict]
    frequency_text: ClassVar[str]
    shape_outputs: ClassVar[bool] = False      #: the retained coordinates are outputs (q_1 .. q_m), gauges possible

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
    #: the stress and strain gauges (flexfmu.body.stress.GaugeData): outputs linear in the coordinates
    gauges: tuple = ()
    #: build_body(with_shapes=True): the shape file's content (flexfmu.body.build.shape_data); not saved
    shape_data: dict | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        if not isinstance(getattr(type(self), "kind", None), str):
            raise TypeError(f"{type(self).__name__} has no kind: a body is a FreeBody or a ClampedBody")

    @classmethod
    def array_shapes(cls, m: int) -> dict:
        """Expected shapes of the kind's reduced arrays for m retained coordinates (None: any length on that
        axis)."""
        raise NotImplementedError

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
        return (f"{self.name or 'body'}: {self.what}, {self.mass:.6g} kg, {self.n_modes} mode(s)"
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

    # ------------------------------------------------------------------ the FMU's variables
    def input_names(self) -> tuple[str, ...]:
        """The inputs in the order of FlexBodySimulator.set_input_vector (flexfmu.body.simulator's docstring): each
        interface's force (and moment, where its patch carries one), then the kind's own."""
        out = []
        for i in self.interfaces:
            out += [f"{i.name}.F_{a}" for a in AXES]
            if i.moments:
                out += [f"{i.name}.M_{a}" for a in AXES]
        return tuple(out) + self.body_inputs

    def frequency_names(self) -> tuple[str, ...]:
        """f_1 .. f_k: the natural_frequencies_hz outputs."""
        return tuple(f"f_{k}" for k in range(1, len(self.natural_frequencies_hz) + 1))

    def shape_names(self) -> tuple[str, ...]:
        """q_1 .. q_m: the retained elastic coordinates as outputs (eigenmodes', then static-correction vectors'), so
        that the elastic displacement of every node is Psi q (the shape file; a free body's: in its body frame)."""
        return tuple(f"q_{k}" for k in range(1, self.n_coordinates + 1)) if self.shape_outputs else ()

    def gauge_names(self) -> tuple[str, ...]:
        """Per gauge G: G.sigma_xx .. G.sigma_xz (Pa), G.von_mises (Pa, derived), G.eps_xx .. G.eps_xz (1)."""
        return tuple(name for g in self.gauges for name in gauge_output_names(g.name))

    def derived_outputs(self) -> tuple:
        """The outputs computed from other outputs (flexfmu.core.stress.DerivedStress): each gauge's von Mises."""
        return tuple(DerivedStress(f"{g.name}.von_mises", "tensor_von_mises",
                                   tuple(f"{g.name}.sigma_{c}" for c in VOIGT)) for g in self.gauges)

    def output_names(self) -> tuple[str, ...]:
        """The outputs in the order of FlexBodySimulator.output_vector: each interface's pos, vel, acc, then the
        kind's own, then the natural frequencies, the shape coordinates and the gauges."""
        per = tuple(f"{i.name}.{q}_{a}" for i in self.interfaces for q in ("pos", "vel", "acc") for a in AXES)
        return per + self.body_outputs + self.frequency_names() + self.shape_names() + self.gauge_names()

    def variable_info(self) -> dict[str, tuple[str, str]]:
        """name -> (unit, description) of every parameter (those of config_class), input and output."""
        parameters = parameter_info(self.damping_ratio)
        info = {f.name: parameters[f.name] for f in fields(self.config_class)}
        frame, notes = self.frame, self.interface_notes
        for i in self.interfaces:
            info.update(axes_info(f"{i.name}.F", "N", f"force at interface {i.name}, {frame}"))
            if i.moments:
                info.update(axes_info(f"{i.name}.M", "N.m", f"moment at interface {i.name}, {frame}"))
            info.update(axes_info(f"{i.name}.pos", "m", f"position of interface {i.name} (rigid fit of its patch), "
                                  f"{frame}" + notes["pos"]))
            info.update(axes_info(f"{i.name}.vel", "m/s", f"velocity of interface {i.name}, {frame}" + notes["vel"]))
            info.update(axes_info(f"{i.name}.acc", "m/s2", f"acceleration of interface {i.name}, {frame}"
                                  + notes["acc"]))
        info.update(self._body_variable_info())
        info.update({n: ("Hz", f"{self.frequency_text} {k}") for k, n in enumerate(self.frequency_names(), start=1)})
        for k, n in enumerate(self.shape_names(), start=1):
            kind = (f"eigenmode {k} ({self.coordinate_frequencies_hz[k - 1]:.6g} Hz)" if k <= self.n_modes else
                    f"static-correction (residual-flexibility) vector {k - self.n_modes}")
            info[n] = ("", f"coordinate {k} of the displacement u = Psi q, {kind}; Psi mass-normalised "
                           "(Psi^T M Psi = I), so q in m kg^0.5")
        for g in self.gauges:
            for c in VOIGT:
                info[f"{g.name}.sigma_{c}"] = ("Pa", f"stress sigma_{c}, body frame, at gauge {g.name}: {g.where}")
            info[f"{g.name}.von_mises"] = ("Pa", f"von Mises stress of {g.name}.sigma_*")
            for c in VOIGT:
                info[f"{g.name}.eps_{c}"] = ("", f"strain eps_{c} (tensor component, 1), body frame, at gauge "
                                                 f"{g.name}: {g.where}")
        return info

    def _body_variable_info(self) -> dict[str, tuple[str, str]]:
        """The kind's own variables (body_inputs, body_outputs): name -> (unit, description)."""
        raise NotImplementedError

    def check_initial_motion(self, name: str, value: float) -> None:
        """ParameterError if the body cannot start with ``value`` of the initial motion ``name`` (v0_*, omega0_*
        of FlexBodyConfig; flexfmu.body.variables.check_config)."""

    def lti_probe(self, sim):
        """The maps of ``sim`` (this body's FlexBodySimulator) as flexfmu.native.lti's Probe, for
        LtiModel.from_clamped_body; ParameterError naming ``body`` for a kind without that form."""
        raise ParameterError("body", f"a {self.kind} body", "a clamped body (flexfmu.body: build_body(clamp=...))")

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
        if self.gauges:
            header["gauges"] = [{"name": g.name, "where": g.where} for g in self.gauges]
        data = {"header": np.array(json.dumps(header, allow_nan=False)),
                "eigenvalues": self.eigenvalues, "natural_frequencies_hz": self.natural_frequencies_hz,
                "center_of_mass": self.center_of_mass, "inertia": self.inertia,
                "clamped_dofs": np.asarray(self.clamped_dofs, np.int64)}
        for k, i in enumerate(self.interfaces):
            data.update({f"if{k}.nodes": np.asarray(i.nodes, np.int64), f"if{k}.dofs": np.asarray(i.dofs, np.int64),
                         f"if{k}.D": i.D, f"if{k}.shapes": i.shapes})
        data.update({f"inv.{k}": v for k, v in self.arrays.items()})
        for k, g in enumerate(self.gauges):
            data.update({f"gauge{k}.strain": g.strain, f"gauge{k}.stress": g.stress})
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **data)
        return path

    @classmethod
    def load(cls, path) -> "FlexBody":
        """Read a body written by :meth:`save`, as the class its header's kind names (FreeBody.load and
        ClampedBody.load refuse the other kind); ParameterError naming the file for a missing, corrupt or
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
        body_class = BODY_CLASSES.get(header.get("kind"))
        if body_class is not None and not issubclass(body_class, cls):
            bad(f"a {body_class.kind} body", f"a {cls.kind} body: {cls.__name__}.load, or FlexBody.load for either")
        try:
            return _from_parts(header, files)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            bad(f"inconsistent content ({type(exc).__name__}: {exc})")


class FreeBody(FlexBody):
    """A free body: the reframe kernels on reduced invariants (flexfmu.body.free), inputs and outputs global."""

    kind = _ClassConstant("free")
    what = "free flexible body"
    config_class = FlexBodyConfig
    engine_class = FreeEngine
    native_kind = "reframe"
    body_outputs = FREE_BODY_OUTPUTS + FRAME_GLOBAL_OUTPUTS
    deferred_outputs = ("max_elastic_displacement",)
    frame = "global"
    shape_outputs = True
    interface_notes = {"pos": "", "vel": "", "acc": ""}
    frequency_text = "elastic natural frequency"

    def variable_info(self) -> dict[str, tuple[str, str]]:
        """FlexBody.variable_info; q and the gauges: the elastic deformation's, relative to the floating frame."""
        info = super().variable_info()
        caveat = ("no static-correction vectors (n_modes given, or not needed for the interfaces' tolerance): the "
                  "quasi-static stress carries the modes' truncation error" if self.n_coordinates == self.n_modes
                  else "static-correction vectors included")
        notes = {n: "; elastic displacement relative to the body frame (the floating frame: origin at the centre of "
                 "mass, rotation q_w .. q_z), body-frame components" for n in self.shape_names()}
        notes.update({n: f"; of the elastic deformation S q (inertia relief included); {caveat}"
                      for n in self.gauge_names() if not n.endswith(".von_mises")})
        return {**info, **{n: (info[n][0], info[n][1] + text) for n, text in notes.items()}}

    @classmethod
    def array_shapes(cls, m: int) -> dict:
        return {"mass": (), "J0": (3, 3), "Aj": (m, 3, 3), "Bsym": (m, 3, 3), "Cjk": (m, m, 3, 3), "Dj": (m, 3, m),
                "A6": (6, 6), "center_of_mass": (3,), "inertia": (3, 3), "nodes": (None, 3),
                "translations": (None, 3, m)}

    def _body_variable_info(self) -> dict[str, tuple[str, str]]:
        info = axes_info("pos", "m", "position of the body frame's origin, global")
        info.update(axes_info("vel", "m/s", "velocity of the body frame's origin, global"))
        info.update({f"q_{c}": ("", f"orientation quaternion body -> global, scalar first, {c}") for c in "wxyz"})
        info.update({f"omega_{k}": ("rad/s", f"angular velocity, body frame, {k}") for k in (1, 2, 3)})
        info.update({f"alpha_{k}": ("rad/s2", f"angular acceleration, body frame, {k}") for k in (1, 2, 3)})
        info.update(axes_info("com_pos", "m", "centre of mass (of the deformed body too), global"))
        info.update(axes_info("com_vel", "m/s", "velocity of the centre of mass, global"))
        info["max_elastic_displacement"] = ("m", "largest elastic nodal displacement, body frame norm")
        info.update({f"rot_{a}": ("", f"rotation vector of the body frame (body -> global), global {a}, rad")
                     for a in AXES})
        info.update(axes_info("omega", "rad/s", "angular velocity of the body frame, global"))
        info.update(axes_info("alpha", "rad/s2", "angular acceleration of the body frame, global"))
        return info


class ClampedBody(FlexBody):
    """A body clamped to a moving base (flexfmu.body.clamped, Eqs. B0-B6): the base's motion are inputs, the
    reactions on the clamps outputs, everything in the body frame."""

    kind = _ClassConstant("clamped")
    what = "flexible body clamped to a moving base"
    config_class = ClampedBodyConfig
    engine_class = ClampedEngine
    native_kind = "lti"
    body_inputs = BASE_INPUTS
    body_outputs = REACTION_OUTPUTS
    frame = "body frame"
    shape_outputs = True
    interface_notes = {"pos": ", from the body origin", "vel": ", elastic, relative to the base",
                       "acc": ", absolute (accelerometer)"}
    frequency_text = "natural frequency of the clamped structure"

    @classmethod
    def array_shapes(cls, m: int) -> dict:
        return {"mass": (), "first_moment": (3,), "J0": (3, 3), "Sa": (m, 3), "Sw": (m, 3), "B": (3, m, m),
                "N": (3, 3, m, m), "R": (3, 3, m), "Vp": (2, 3, m), "Va": (2, 3, 3, m), "Vq": (2, 3, 3, 3, m),
                "Vr": (2, 3, 3, m), "arm": (15, 3, m)}

    def _body_variable_info(self) -> dict[str, tuple[str, str]]:
        info = axes_info("base_a", "m/s2", "acceleration of the base (body frame origin), body frame")
        info.update(axes_info("base_w", "rad/s", "angular velocity of the base, body frame"))
        info.update(axes_info("base_dw", "rad/s2", "angular acceleration of the base, body frame"))
        info.update(axes_info("reaction_F", "N", "force the body exerts on its clamps, body frame"))
        info.update(axes_info("reaction_M", "N.m", "moment the body exerts on its clamps about the body origin, "
                                                   "body frame"))
        return info

    def check_initial_motion(self, name: str, value: float) -> None:
        if value != 0.0:
            raise ParameterError(name, f"{value:g}: a clamped body moves with its base", "0 for a clamped body")

    def lti_probe(self, sim):
        from flexfmu.body.lti_probe import clamped_body_probe      # on use: importing the body loads no native.lti
        return clamped_body_probe(sim)


#: the body classes by the kind their file's header names
BODY_CLASSES = {cls.kind: cls for cls in (FreeBody, ClampedBody)}
#: the kinds a body file may name
KINDS = tuple(BODY_CLASSES)


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
    if kind not in BODY_CLASSES:
        raise ValueError(f"kind {kind!r}")
    body_class = BODY_CLASSES[kind]
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
    expected = body_class.array_shapes(m)
    if sorted(header["arrays"]) != sorted(expected):
        raise ValueError(f"reduced arrays {sorted(header['arrays'])}")
    arrays = {k: _array(files, f"inv.{k}", shape) for k, shape in expected.items()}
    damping = float(header["damping_ratio"])
    if not 0.0 <= damping < 1.0:
        raise ValueError(f"damping_ratio {damping}")
    mass = float(header["mass"])
    if not (math.isfinite(mass) and mass > 0):
        raise ValueError(f"mass {mass}")
    gauges = tuple(GaugeData(str(g["name"]), str(g["where"]), _array(files, f"gauge{k}.strain", (6, m)),
                             _array(files, f"gauge{k}.stress", (6, m))) for k, g in enumerate(header.get("gauges", ())))
    if gauges and not body_class.shape_outputs:
        raise ValueError("gauges on a free body")
    return body_class(name=str(header["name"]), dofs_per_node=dpn, interfaces=tuple(interfaces), gauges=gauges,
                      eigenvalues=eig, n_modes=n_modes,
                      natural_frequencies_hz=_array(files, "natural_frequencies_hz", (None,)), mass=mass,
                      center_of_mass=_array(files, "center_of_mass", (3,)), inertia=_array(files, "inertia", (3, 3)),
                      damping_ratio=damping, arrays=arrays, provenance=dict(header.get("provenance") or {}),
                      messages=tuple(str(s) for s in header.get("messages", ())),
                      clamped_dofs=_array(files, "clamped_dofs", (None,), integer=True))
