"""Mooring: three slack catenary lines of a floating body, simulated by MoorDyn (what Mooring.fmu wraps; variable
names are the FMU's).

MoorDyn (pip ``moordyn``, MoorDyn-C 2.x: the lumped-mass mooring model of WEC-Sim and OpenFAST) carries the lines:
each is ``segments`` straight elastic segments with the line's mass, weight, buoyancy, Morison drag and added mass
lumped at the nodes, a penalty sea floor, and critical internal damping of each segment's axial mode.  The lines run
from anchors on the sea floor at ``anchor_radius`` from the body's axis to fairleads fixed to the body at
``fairlead_radius`` and height ``fairlead_z``, at headings 0, 120 and 240 deg from the x axis.  The fairleads are
MoorDyn's coupled points: their positions and velocities follow from the body's motion at the inputs,

    p_i = pos + R r_i,   v_i = vel + omega x (R r_i),   R = exp([rot]x) (the rotation vector rot),

and the outputs are the lines' forces on the body, summed at the reference point O (the still-water line on the body's
axis; earth frame, z up): F = sum f_i, M = sum (p_i - pos) x f_i, and each line's tension at its fairlead |f_i|.
To first order R r_i = r_i + rot x r_i, the linear seakeeping model's small rotation (flexfmu.wec.platform), whose
outputs pos_*, rot_*, vel_*, omega_* are this component's inputs by name.

Each communication step is one MoorDyn Step over the step with the inputs of its start (MoorDyn moves each fairlead
at its held velocity and takes its own internal steps of ``internal_time_step``); the outputs are the forces at the
step's end (about O moved on at ``vel``), so they depend on the state only, not directly on the inputs.  MoorDyn's
initial condition is its own static solution for the fairleads where the inputs hold them when the outputs or a step
are first needed.  The FMU state (get_state) holds MoorDyn's serialised state (MoorDyn's Serialize; restored with
Deserialize), so a restored state continues bit for bit.  ``enabled = false`` makes no MoorDyn instance: the
outputs are zero.

MoorDyn reads its input file: it is written from the parameters into a temporary folder of the instance (deleted
with it).  MoorDyn prints its set-up to the process's standard output, which is silenced while it does.

In the wave-energy converter system (SYSTEM_ROLE, flexfmu.wec.roles) the mooring accounts for the energy it takes
from the body it holds (stored in the lines and dissipated by them), its fairlead tensions, and their chart.
"""
from __future__ import annotations

import base64
import contextlib
import ctypes
import hashlib
import math
import os
import sys
import tempfile
import weakref
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from flexfmu.core.checks import DEFAULT_MAX_INTERNAL_STEPS, shown
from flexfmu.errors import DivergenceError, NonFiniteError, ParameterError, StepRejected, require
from flexfmu.wec.components import AXES, check_config, check_inputs, check_state_config, check_step, vector_info
from flexfmu.wec.roles import POTENTIAL, Panel, Role, Term, integral, summary_line

N_LINES = 3
#: the lines' headings from the x axis, deg: line i runs from anchor i to fairlead i, both on this heading
LINE_HEADINGS_DEG = (0.0, 120.0, 240.0)
INPUT_NAMES = (tuple(f"pos_{a}" for a in AXES) + tuple(f"rot_{a}" for a in AXES)
               + tuple(f"vel_{a}" for a in AXES) + tuple(f"omega_{a}" for a in AXES))
OUTPUT_NAMES = (tuple(f"F_{a}" for a in AXES) + tuple(f"M_{a}" for a in AXES)
                + tuple(f"tension_{i + 1}" for i in range(N_LINES)))
#: hydrodynamic coefficients of studless chain (MoorPy's line-property table, moorpy.helpers.getLineProps "chain"):
#: normal and axial drag, normal and axial added mass, on the volume-equivalent diameter
CHAIN_COEFFICIENTS = {"Cd": 1.333, "Ca": 1.0, "CdAx": 0.639, "CaAx": 0.5}
#: MoorDyn's BA/-zeta column: -1 = each segment's axial mode critically damped (MoorDyn's usual choice for chain)
AXIAL_DAMPING = -1.0
#: the largest internal_time_step allowed, as a fraction of the period of one segment's axial mode
#: 2 pi (L / N) sqrt(m / EA) (MoorDyn's CFL number); MoorDyn's RK2 with critical axial damping went unstable from
#: 0.13 in runs of 10, 20 and 40 segments (stable at 0.105), so half of that
MAX_CFL = 0.06
#: sea-floor penalty stiffness (Pa/m) and damping (Pa s/m), MoorDyn's defaults: a chain of 0.09 m sinks ~1.6 mm
SEABED = (3.0e6, 3.0e5)


@dataclass(frozen=True)
class MooringConfig:
    """Parameters, named and defaulted as in the FMU.  Defaults: the point absorber of docs/wave_converter.md
    "Mooring (MoorDyn)", 100 m of water, 50 mm studless chain (MoorPy's getLineProps(50, "chain"): 50 kg/m, EA
    2.14e8 N, volume-equivalent diameter 0.09 m), fairleads at the keel edge of a cylinder of radius 5 m and
    draft 3 m."""

    enabled: bool = True
    depth: float = 100.0
    fairlead_radius: float = 5.0
    fairlead_z: float = -3.0
    anchor_radius: float = 200.0
    line_length: float = 250.0
    line_mass: float = 50.0
    line_diameter: float = 0.09
    line_EA: float = 213995087.5
    segments: int = 20
    internal_time_step: float = 1e-3
    rho: float = 1025.0
    g: float = 9.81

    @property
    def wet_weight(self) -> float:
        """Weight in water per unit length (N/m)."""
        return (self.line_mass - self.rho * math.pi / 4 * self.line_diameter * self.line_diameter) * self.g

    def spans(self) -> tuple[float, float]:
        """(horizontal, vertical) distance from an anchor to its fairlead at rest (m)."""
        return self.anchor_radius - self.fairlead_radius, self.depth + self.fairlead_z

    def axial_period(self) -> float:
        """Period of one segment's axial mode, 2 pi (L / N) sqrt(m / EA) (s): what internal_time_step resolves."""
        return 2 * math.pi * self.line_length / self.segments * math.sqrt(self.line_mass / self.line_EA)


def check(cfg: MooringConfig) -> None:
    """Every parameter in its range (ParameterError naming it and the range)."""
    check_config(cfg)
    for name in ("depth", "line_length", "line_mass", "line_diameter", "line_EA", "internal_time_step", "rho", "g"):
        require(getattr(cfg, name) > 0, name, f"got {getattr(cfg, name)!r}", "> 0")
    require(cfg.fairlead_radius >= 0, "fairlead_radius", f"got {cfg.fairlead_radius!r} m", ">= 0 m")
    require(-cfg.depth < cfg.fairlead_z <= 0, "fairlead_z", f"got {cfg.fairlead_z!r} m",
            f"-depth < fairlead_z <= 0 m: between the sea floor ({-cfg.depth:g} m) and the still-water line")
    require(cfg.anchor_radius > cfg.fairlead_radius, "anchor_radius", f"got {cfg.anchor_radius!r} m",
            f"> fairlead_radius = {cfg.fairlead_radius:g} m")
    require(2 <= cfg.segments <= 1000, "segments", f"got {cfg.segments!r}", "an integer 2 .. 1000")
    with np.errstate(all="ignore"):
        w = cfg.wet_weight
        horizontal, vertical = cfg.spans()
        straight, slack = math.hypot(horizontal, vertical), horizontal + vertical
        period = cfg.axial_period()
    floating = cfg.rho * math.pi / 4 * cfg.line_diameter * cfg.line_diameter
    require(w > 0 and math.isfinite(w), "line_mass", f"{cfg.line_mass!r} kg/m with line_diameter "
            f"{cfg.line_diameter!r} m floats (wet weight {w:.4g} N/m)",
            f"> rho pi d^2 / 4 = {floating:.4g} kg/m: a catenary line sinks")
    require(straight < cfg.line_length < slack, "line_length", f"got {cfg.line_length!r} m",
            f"{straight:.6g} .. {slack:.6g} m for a slack catenary: longer than the straight fairlead-anchor distance "
            "(a taut line) and shorter than the horizontal plus the vertical span (a line hanging straight down)")
    require(math.isfinite(period) and period > 0, "line_EA", f"{cfg.line_EA!r} N with line_mass {cfg.line_mass!r} "
            "kg/m makes the axial period not finite", "values whose ratio stays within the floating-point range")
    limit = MAX_CFL * period
    require(cfg.internal_time_step <= limit, "internal_time_step", f"got {cfg.internal_time_step!r} s",
            f"<= {limit:.4g} s: {MAX_CFL} of the axial period 2 pi (line_length / segments) sqrt(line_mass / "
            f"line_EA) = {period:.4g} s (MoorDyn's explicit integration goes unstable above ~0.1 of it)")


def _headings() -> np.ndarray:
    h = np.radians(LINE_HEADINGS_DEG)
    return np.column_stack([np.cos(h), np.sin(h)])


def fairleads(cfg: MooringConfig) -> np.ndarray:
    """(3, 3) fairlead positions in the body frame, from O (m)."""
    return np.column_stack([cfg.fairlead_radius * _headings(), np.full(N_LINES, cfg.fairlead_z)])


def anchors(cfg: MooringConfig) -> np.ndarray:
    """(3, 3) anchor positions, earth frame (m)."""
    return np.column_stack([cfg.anchor_radius * _headings(), np.full(N_LINES, -cfg.depth)])


def rotation(rot) -> np.ndarray:
    """The rotation matrix of the rotation vector ``rot`` (rad), exp([rot]x) by Rodrigues' formula."""
    rot = np.asarray(rot, float)
    angle = float(np.linalg.norm(rot))
    k = np.array([[0.0, -rot[2], rot[1]], [rot[2], 0.0, -rot[0]], [-rot[1], rot[0], 0.0]])
    if angle < 1e-8:                      # the series: 1 - angle^2 / 6 and 1/2 - angle^2 / 24 are exact here
        return np.eye(3) + k + 0.5 * k @ k
    return np.eye(3) + math.sin(angle) / angle * k + (1 - math.cos(angle)) / angle ** 2 * k @ k


def _number(x) -> str:
    """A number as MoorDyn reads it back exactly (repr of a Python float: the shortest round trip)."""
    return repr(float(x))


def moordyn_input(cfg: MooringConfig, drag_scale: float = 1.0) -> str:
    """The MoorDyn input file of the lines (``drag_scale`` multiplies the drag coefficients: a settling run's
    damping, which changes no static force)."""
    c = CHAIN_COEFFICIENTS
    points, lines = [], []
    for i, (a, f) in enumerate(zip(anchors(cfg), fairleads(cfg))):
        points.append(f"{2 * i + 1} Fixed {' '.join(map(_number, a))} 0 0 0 0")
        points.append(f"{2 * i + 2} Coupled {' '.join(map(_number, f))} 0 0 0 0")
        lines.append(f"{i + 1} chain {2 * i + 1} {2 * i + 2} {_number(cfg.line_length)} {int(cfg.segments)} -")
    options = {"writeLog": 0, "disableOutput": 1, "disableOutTime": 1, "dtM": _number(cfg.internal_time_step),
               "WtrDpth": _number(cfg.depth), "rho": _number(cfg.rho), "g": _number(cfg.g),
               "kBot": _number(SEABED[0]), "cBot": _number(SEABED[1]),
               # the initial condition: MoorDyn's stationary solver (its defaults)
               "ICgenDynamic": 0, "dtIC": 1.0, "TmaxIC": 120.0, "threshIC": 0.001}
    return "\n".join([
        "MoorDyn input file written by flexfmu.wec.mooring from the Mooring FMU's parameters",
        "---------------------- LINE TYPES -----------------------------------",
        "TypeName Diam Mass/m EA BA/-zeta EI Cd Ca CdAx CaAx",
        "(name) (m) (kg/m) (N) (N-s/-) (N-m^2) (-) (-) (-) (-)",
        " ".join(["chain", _number(cfg.line_diameter), _number(cfg.line_mass), _number(cfg.line_EA),
                  _number(AXIAL_DAMPING), "0", _number(c["Cd"] * drag_scale), _number(c["Ca"]),
                  _number(c["CdAx"] * drag_scale), _number(c["CaAx"])]),
        "---------------------- POINTS ---------------------------------------",
        "ID Attachment X Y Z Mass Volume CdA Ca",
        "(#) (word) (m) (m) (m) (kg) (m^3) (m^2) (-)",
        *points,
        "---------------------- LINES ----------------------------------------",
        "ID LineType AttachA AttachB UnstrLen NumSegs LineOutputs",
        "(#) (name) (ID) (ID) (m) (-) (-)",
        *lines,
        "---------------------- OPTIONS -----------------------------------------",
        *(f"{value} {name}" for name, value in options.items()),
        "------------------------- need this line -------------------------------------", ""])


# ---------------------------------------------------------------- MoorDyn, wrapped
def _moordyn():
    try:
        import moordyn
    except ImportError:
        raise ParameterError("enabled", "the Mooring needs MoorDyn, which is not installed",
                             "pip install moordyn (flexfmu's dev extra has it), or enabled = false") from None
    return moordyn


@contextlib.contextmanager
def _quiet():
    """Standard output silenced at the file-descriptor level: MoorDyn's C++ prints its banner and set-up there."""
    sys.stdout.flush()
    try:
        saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    except OSError:                                           # no standard output to silence
        yield
        return
    os.dup2(devnull, 1)
    try:
        yield
    finally:
        with contextlib.suppress(Exception):                   # C stdio's buffer, before the descriptor returns
            ctypes.CDLL(None).fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)


def _deserialize(moordyn, system, data: bytes) -> None:
    """moordyn.Deserialize, keeping None alive: its wrapper (cmoordyn 2.7) returns Py_None without a new reference,
    so every call takes one from None's count; on Python 3.11 a few thousand restores would free None and crash."""
    before = sys.getrefcount(None)
    moordyn.Deserialize(system, data)
    for _ in range(before - sys.getrefcount(None)):           # 0 where None is immortal (3.12+) or the bug fixed
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(None))


def _release(moordyn, system, folder) -> None:
    moordyn.Close(system)
    folder.cleanup()


class _Lines:
    """One MoorDyn instance of the lines, with its input file in a temporary folder (both freed with it)."""

    def __init__(self, cfg: MooringConfig, drag_scale: float, x: list, v: list, restore: bytes | None = None):
        moordyn = self.moordyn = _moordyn()
        folder = tempfile.TemporaryDirectory(prefix="flexfmu_mooring_", ignore_cleanup_errors=True)
        path = Path(folder.name) / "lines.txt"
        path.write_text(moordyn_input(cfg, drag_scale), encoding="utf-8")
        with _quiet():
            self.system = moordyn.Create(str(path))
            self._finalizer = weakref.finalize(self, _release, moordyn, self.system, folder)
            # a restored instance skips the static solution: Deserialize sets every line node
            status = (moordyn.Init_NoIC if restore is not None else moordyn.Init)(self.system, x, v)
        if status != 0:
            self.close()
            raise ParameterError("MoorDyn", f"could not set the lines up (its error code {status})",
                                 "parameters within their ranges (VARIABLE_INFO)")
        if restore is not None:
            _deserialize(moordyn, self.system, restore)

    def forces(self, x: list, v: list, t: float, h: float) -> np.ndarray:
        """The lines' forces on the fairleads (3, 3) after a MoorDyn Step of h (0: at the current state)."""
        return np.array(self.moordyn.Step(self.system, x, v, t, h)).reshape(N_LINES, 3)

    def serialize(self) -> bytes:
        return self.moordyn.Serialize(self.system)

    def deserialize(self, data: bytes) -> None:
        _deserialize(self.moordyn, self.system, data)

    def close(self) -> None:
        self._finalizer()


# ---------------------------------------------------------------- the simulator
class MooringSimulator:
    """State (MoorDyn's lines, t, the last loads) and step of one Mooring instance.  ``drag_scale`` multiplies the
    lines' drag (quasi-static studies settle faster; no FMU parameter)."""

    def __init__(self, config: MooringConfig = MooringConfig(), *, drag_scale: float = 1.0):
        check(config)
        require(math.isfinite(drag_scale) and drag_scale > 0, "drag_scale", f"got {drag_scale!r}", "> 0")
        self.config = config
        self.drag_scale = float(drag_scale)
        self.r_body = fairleads(config)
        self.anchors = anchors(config)
        self.t = 0.0
        self.inputs = dict.fromkeys(INPUT_NAMES, 0.0)
        self.loads = np.zeros(6)                    # F, M about O (earth frame)
        self.tensions = np.zeros(N_LINES)
        self.lines: _Lines | None = None            # made when first needed, at the inputs of that moment
        self.failure = ""                           # why MoorDyn's state was lost (a failed step), else ""

    @property
    def time(self) -> float:
        return self.t

    def set_inputs(self, **inputs: float) -> None:
        check_inputs(inputs, INPUT_NAMES)
        self.inputs.update({k: float(v) for k, v in inputs.items()})

    def _motion(self) -> tuple[np.ndarray, ...]:
        v = self.inputs
        pos, rot, vel, omega = (np.array([v[f"{k}_{a}"] for a in AXES]) for k in ("pos", "rot", "vel", "omega"))
        arms = self.r_body @ rotation(rot).T                      # R r_i, earth frame
        return pos, vel, arms, vel + np.cross(omega, arms)

    def _check_reach(self, motion: tuple, h: float) -> None:
        """Every fairlead above the sea floor and within its line's length of its anchor at the step's start (h = 0)
        or end, else ParameterError naming the input that moves it farthest that way: beyond, the slack catenary
        the lines are would be torn taut (or the fairlead would be under the sea floor)."""
        pos, vel, arms, velocities = motion
        points = pos + arms + h * velocities
        span = np.linalg.norm(points - self.anchors, axis=1)
        if np.all(span <= self.config.line_length) and np.all(points[:, 2] > -self.config.depth):
            return
        if np.any(points[:, 2] <= -self.config.depth):
            i = int(np.argmin(points[:, 2]))
            direction, what = np.array([0.0, 0.0, -1.0]), f"under the sea floor (z = {points[i, 2]:.6g} m)"
        else:
            i = int(np.argmax(span))
            direction, what = (points[i] - self.anchors[i]) / span[i], f"{span[i]:.6g} m from its anchor"
        # each input's share of the fairlead's motion that way (rotations to first order)
        turn = [direction @ np.cross(e, arms[i]) for e in np.eye(3)]
        share = {}
        for k, a in enumerate(AXES):
            share.update({f"pos_{a}": direction[k] * pos[k], f"rot_{a}": turn[k] * self.inputs[f"rot_{a}"],
                          f"vel_{a}": h * direction[k] * vel[k], f"omega_{a}": h * turn[k] * self.inputs[f"omega_{a}"]})
        name = max(share, key=share.get)
        raise ParameterError(name, f"{shown(self.inputs[name])} puts fairlead {i + 1} {what} at the "
                                   f"{'end' if h else 'start'} of the step from t = {self.t!r} s",
                             f"motions that keep every fairlead above the sea floor and within line_length = "
                             f"{self.config.line_length:g} m of its anchor")

    def _ensure_lines(self) -> None:
        if self.failure:
            raise DivergenceError("state", self.failure, "restore an FMU state saved before, or a new instance")
        if self.lines is None and self.config.enabled:
            motion = self._motion()
            self._check_reach(motion, 0.0)
            pos, _, arms, _ = motion
            # the lines' static shape with the fairleads where the inputs hold them, at rest
            x, v = (pos + arms).ravel().tolist(), [0.0] * (3 * N_LINES)
            self.lines = _Lines(self.config, self.drag_scale, x, v)
            self._set_loads(self.lines.forces(x, v, self.t, 0.0), arms)

    def _set_loads(self, f: np.ndarray, arms: np.ndarray) -> None:
        if not np.all(np.isfinite(f)):
            raise NonFiniteError("state", f"MoorDyn's line forces are not finite at t = {self.t!r} s")
        self.loads = np.concatenate([f.sum(axis=0), np.cross(arms, f).sum(axis=0)])
        self.tensions = np.linalg.norm(f, axis=1)

    def step(self, step_size: float) -> None:
        """One MoorDyn Step over the communication step (the fairleads moving at the held velocities)."""
        check_step(step_size)
        h = step_size
        if not math.isfinite(self.t + h):
            raise NonFiniteError("step_size", f"the time {self.t!r} s + {h!r} s overflows")
        if self.config.enabled:
            n = math.ceil(h / self.config.internal_time_step)
            if n > DEFAULT_MAX_INTERNAL_STEPS:
                raise StepRejected("step_size", f"{h!r} s needs {n} internal steps of internal_time_step = "
                                                f"{self.config.internal_time_step:g} s, more than "
                                                f"{DEFAULT_MAX_INTERNAL_STEPS}: take smaller communication steps")
            motion = self._motion()
            self._check_reach(motion, 0.0)
            self._check_reach(motion, h)
            self._ensure_lines()
            pos, vel, arms, velocities = motion
            x, v = (pos + arms).ravel().tolist(), velocities.ravel().tolist()
            try:
                f = self.lines.forces(x, v, self.t, h)
            except RuntimeError as exc:                     # NaN in MoorDyn's nodes: its state is lost
                self.lines.close()
                self.lines = None
                self.failure = (f"MoorDyn's integration failed in the step from t = {self.t!r} s ({exc}): the lines "
                                f"diverged (internal_time_step = {self.config.internal_time_step:g} s, the motion at "
                                "the inputs)")
                raise DivergenceError("state", self.failure,
                                      "a smaller internal_time_step or gentler motions") from None
            self._set_loads(f, arms + h * (velocities - vel))    # arms at the step's end
        self.t += h

    def outputs(self) -> dict[str, float]:
        self._ensure_lines()
        return dict(zip(OUTPUT_NAMES, self.loads.tolist() + self.tensions.tolist()))

    def get_state(self) -> dict:
        lines = None
        if self.lines is not None:
            data = self.lines.serialize()
            lines = {"data": base64.b64encode(data).decode("ascii"), "sha256": hashlib.sha256(data).hexdigest()}
        return {"t": self.t, "inputs": dict(self.inputs), "config": asdict(self.config), "drag_scale": self.drag_scale,
                "loads": self.loads.tolist(), "tensions": self.tensions.tolist(), "failure": self.failure,
                "moordyn": lines}

    def set_state(self, data: dict) -> None:
        check_state_config(data, self.config)
        require(data.get("drag_scale") == self.drag_scale, "FMUstate", "was taken with another drag_scale",
                "a state of this instance's configuration")
        lines = data["moordyn"]
        restore = None
        if lines is not None:
            restore = base64.b64decode(lines["data"], validate=True)
            require(hashlib.sha256(restore).hexdigest() == lines["sha256"], "FMUstate",
                    "MoorDyn's part is damaged (its checksum differs)", "a state this FMU saved")
        self.t = float(data["t"])
        self.inputs = {k: float(data["inputs"][k]) for k in INPUT_NAMES}
        self.loads = np.array(data["loads"], float)
        self.tensions = np.array(data["tensions"], float)
        self.failure = str(data.get("failure", ""))
        if restore is None:
            if self.lines is not None:
                self.lines.close()
            self.lines = None
        elif self.lines is None:
            pos, _, arms, _ = self._motion()
            x, v = (pos + arms).ravel().tolist(), [0.0] * (3 * N_LINES)
            self.lines = _Lines(self.config, self.drag_scale, x, v, restore=restore)
        else:
            self.lines.deserialize(restore)


#: name -> (unit, description) of every FMU variable.
VARIABLE_INFO: dict[str, tuple[str, str]] = {
    "enabled": ("", "true: MoorDyn's lines; false: no lines, the outputs are zero"),
    "depth": ("m", "water depth (flat sea floor), > 0"),
    "fairlead_radius": ("m", "horizontal distance of the fairleads from the body's axis, >= 0"),
    "fairlead_z": ("m", "height of the fairleads from the still-water line, -depth .. 0 (default: the keel)"),
    "anchor_radius": ("m", "horizontal distance of the anchors from the body's axis, > fairlead_radius"),
    "line_length": ("m", "unstretched length of each line: between the straight fairlead-anchor distance and the "
                         "horizontal plus vertical span (a slack catenary)"),
    "line_mass": ("", "mass per unit length in air, kg/m; the line must sink (> rho pi line_diameter^2 / 4)"),
    "line_diameter": ("m", "volume-equivalent diameter (buoyancy, drag, added mass), > 0"),
    "line_EA": ("N", "axial stiffness, > 0"),
    "segments": ("", "MoorDyn segments per line, 2 .. 1000"),
    "internal_time_step": ("s", "MoorDyn's internal time step dtM, > 0 and <= 0.06 of a segment's axial period "
                                "2 pi (line_length / segments) sqrt(line_mass / line_EA)"),
    "rho": ("", "water density, kg/m3, > 0"),
    "g": ("m/s2", "gravity, > 0"),
    **vector_info("pos", "m", "displacement of the body's reference point O", "earth"),
    **{f"rot_{a}": ("", f"rotation vector of the body, earth {a}, rad (the Platform's small rotation)") for a in AXES},
    **vector_info("vel", "m/s", "velocity of O", "earth"),
    **vector_info("omega", "rad/s", "angular velocity", "earth"),
    **vector_info("F", "N", "the lines' force on the body", "earth"),
    **vector_info("M", "N.m", "the lines' moment on the body about O", "earth"),
    **{f"tension_{i + 1}": ("N", f"tension of line {i + 1} at its fairlead (heading {LINE_HEADINGS_DEG[i]:g} deg)")
       for i in range(N_LINES)},
}


class MooringRole(Role):
    """The lines: the energy they took from the body (stored in them and dissipated), their fairlead tensions."""

    kind = "mooring"

    def power_on_body(self, m, r) -> np.ndarray:
        """The power (W) of the lines' loads on the body at the communication points: the outputs' force and moment
        with the velocities at the inputs."""
        return (np.einsum("ij,ij->i", r.vec(m.name, "F_{}"), r.input_vec(m.name, "vel_{}"))
                + np.einsum("ij,ij->i", r.vec(m.name, "M_{}"), r.input_vec(m.name, "omega_{}")))

    def energy(self, m, r):
        # what the lines took from the body is what they store (weight, stretch, motion) and dissipate (drag,
        # internal damping, the sea floor): one term, as the lines' own energies are not outputs
        return [Term(POTENTIAL, "mooring: taken from the body (stored, dissipated)" + m.suffix,
                     -integral(self.power_on_body(m, r), r.t))]

    def summary(self, m, r, sel):
        tensions = np.column_stack([r.col(m.name, f"tension_{i + 1}") for i in range(N_LINES)])[sel]
        return [summary_line(f"mooring{m.suffix} fairlead tension", f"mean {tensions.mean() / 1e3:.4g} kN, "
                                                                    f"max {tensions.max() / 1e3:.4g} kN")]

    def panels(self, m, r):
        return [Panel("mooring" + m.suffix, f"mooring line tensions at the fairleads{m.suffix}", "kN",
                      [(r.col(m.name, f"tension_{i + 1}") / 1e3, {"label": f"line {i + 1}"}) for i in range(N_LINES)])]


#: what the mooring is in the wave-energy converter system (its registry row names this module)
SYSTEM_ROLE = MooringRole()
