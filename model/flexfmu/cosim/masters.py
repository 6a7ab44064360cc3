# Over 500 lines on purpose: the three masters (fmpy, libcosim, ecos) and the coupling-stability analysis share
# one System object (flexfmu.cosim.system) and its connection handling.
"""Co-simulation masters for a system of FMUs described by one OSP system structure file
(``OspSystemStructure.xml``, the format libcosim reads with ``CosimExecution.from_osp_config_file``).

Four ways to run the same description, all with a fixed communication step h:

- ``run(system, ..., backend="fmu")``: our own master over fmpy's ``FMU2Slave``, Jacobi (every
  slave steps from t_n with the inputs of t_n, then all outputs are passed on: what libcosim's
  fixed-step algorithm does) or Gauss-Seidel (slaves step one after the other in the file's order,
  each with the newest outputs of those before it).
- ``run(system, ..., backend="library")``: the same loop over the flexfmu façades that the FMUs
  wrap (no FMI, and the components' internal state is at hand, e.g. for the energy audit).
- ``run_libcosim(system, ...)``: DNV's libcosim through libcosimpy on the same file (Jacobi).
- ``run_ecos(system, ...)``: the ecos engine (ecospy) on the system written as SSP (Jacobi).

A system file is an OSP file or an SSP (``.ssp``; flexfmu.cosim.ssp): :func:`load_system` reads either.
The description itself (SimulatorSpec, System, the OSP file) is flexfmu.cosim.system's; its names are
importable from here too.

Also here: the linear coupling-stability analysis of the discrete co-simulation
(``step_limit``), the wave-energy converter's energy audit (``energy_balance``) and the
sea-state x boundary sweep (``sweep``; serial or on Dask).
"""
from __future__ import annotations

import csv
import ctypes
import importlib
import math
import sys
import tempfile
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Callable

import numpy as np

from flexfmu.core.progress import progress_bar
from flexfmu.cosim.ssp import PARAMETER_SET, load_ssp, write_ssp
# SimulatorSpec, System and write_osp live in flexfmu.cosim.system; callers (flexfmu.wec.system, the studies,
# examples/) import them from here too: kept importable on purpose
from flexfmu.cosim.system import SimulatorSpec, System, is_ssp_path, load_osp, write_osp
from flexfmu.fmi.registry import FMUS
from flexfmu.errors import CosimulationError, ParameterError, require

COUPLING_SCHEMES = ("jacobi", "gauss-seidel")   # how the master orders the FMUs in a step
BACKENDS = ("fmu", "library")
#: FMU model name -> the flexfmu module it wraps (config class, simulator class, names)
LIBRARY_MODULES = {spec.name: (spec.module, spec.config, spec.simulator) for spec in FMUS}


# ====================================================================== start values
_PYTHON_TYPES = {bool: "Boolean", int: "Integer", float: "Real", str: "String"}


def settable_variables(spec: SimulatorSpec) -> dict:
    """{variable: FMI type name} of the start values an instance takes: its FMU's parameters and
    inputs (modelDescription.xml), or, when the FMU file is not there, its library model's parameters."""
    if Path(spec.source).is_file():
        from fmpy import read_model_description
        md = read_model_description(str(spec.source))
        return {v.name: ("Integer" if v.type == "Enumeration" else v.type) for v in md.modelVariables
                if v.causality in ("parameter", "input") and v.variability != "constant"}
    require(spec.model in LIBRARY_MODULES, "source", f"{spec.name}: FMU {str(spec.source)!r} not found",
            "an FMU file (build them with: flexfmu build, or pass --fmu-dir)")
    module_name, config_name, _ = LIBRARY_MODULES[spec.model]
    config = getattr(importlib.import_module(module_name), config_name)
    return {f.name: _PYTHON_TYPES.get(type(f.default), "Real") for f in fields(config)}


def _typed(text: str, kind: str, where: str):
    """A --set value as the variable's type."""
    try:
        if kind == "Real":
            value = float(text)
            require(math.isfinite(value), where, f"{text!r} is not finite", "a finite number")
            return value
        if kind == "Integer":
            return int(text)
        if kind == "Boolean":
            low = text.strip().lower()
            require(low in ("true", "false", "1", "0"), where, f"{text!r} is not a Boolean", "true | false | 1 | 0")
            return low in ("true", "1")
        return text
    except ValueError:
        raise ParameterError(where, f"{text!r} is not {'an' if kind == 'Integer' else 'a'} {kind}",
                             f"{'an' if kind == 'Integer' else 'a'} {kind} value") from None


def with_assignments(system: System, assignments) -> System:
    """The system with start values changed by "INSTANCE.VARIABLE=VALUE" texts (``flexfmu cosim --set``),
    each value converted to the variable's type.  An unknown instance or variable is a ParameterError
    that lists the allowed ones."""
    values: dict = {}
    instances = [s.name for s in system.simulators]
    for text in assignments:
        key, sep, raw = str(text).partition("=")
        inst, dot, var = key.strip().partition(".")
        require(bool(sep) and bool(dot) and bool(inst) and bool(var), "set",
                f"{text!r} is not INSTANCE.VARIABLE=VALUE", "e.g. wave.wave_height=0.1")
        require(inst in instances, "set", f"{text!r}: unknown instance {inst!r}", ", ".join(instances))
        allowed = settable_variables(system.simulator(inst))
        require(var in allowed, "set", f"{text!r}: {inst} has no parameter or input {var!r}",
                ", ".join(f"{inst}.{v}" for v in allowed))
        values.setdefault(inst, {})[var] = _typed(raw.strip(), allowed[var], f"{inst}.{var}")
    return system.with_values(values)


def load_system(path, fmu_dir=None) -> System:
    """Read a system file: an OspSystemStructure.xml (flexfmu.cosim.system.load_osp) or an SSP (``.ssp``
    archive, ``.ssd`` file or a folder with SystemStructure.ssd: flexfmu.cosim.ssp.load_ssp).  FMU sources
    are relative to the file; fmu_dir overrides their folder."""
    return load_ssp(path, fmu_dir=fmu_dir) if is_ssp_path(path) else load_osp(path, fmu_dir=fmu_dir)


# ====================================================================== slaves
class LibrarySlave:
    """A flexfmu façade behaving like the FMU that wraps it (the FlexfmuPlumbing semantics)."""

    def __init__(self, spec: SimulatorSpec):
        require(spec.model in LIBRARY_MODULES, "source", f"{spec.source.name}: no library model",
                ", ".join(f"{m}.fmu" for m in LIBRARY_MODULES))
        module_name, config_name, sim_name = LIBRARY_MODULES[spec.model]
        self.module = importlib.import_module(module_name)
        self.config_class = getattr(self.module, config_name)
        self.sim_class = getattr(self.module, sim_name)
        self.name = spec.name
        self.input_names = tuple(self.module.INPUT_NAMES)
        self.output_names = tuple(self.module.OUTPUT_NAMES)
        defaults = {f.name: f.default for f in fields(self.config_class)}
        params = dict(defaults)
        for key, value in spec.initial_values.items():
            require(key in defaults, f"{spec.name}.{key}", "not a parameter", ", ".join(defaults))
            kind = type(defaults[key])
            params[key] = kind(value) if kind is not bool else bool(value)
        self.config = self.config_class(**params)
        self.values = dict.fromkeys(self.input_names + self.output_names, 0.0)
        self.sim = None

    def initialize(self, start_time: float = 0.0):
        require(start_time == 0.0, "StartTime", f"got {start_time!r}", "0 for the library backend")
        self.sim = self.sim_class(self.config)
        self.sim.set_inputs(**{n: self.values[n] for n in self.input_names})
        self.values.update(self.sim.outputs())

    def set(self, names, values):
        for n, v in zip(names, values):
            self.values[n] = float(v)

    def get(self, names):
        return [self.values[n] for n in names]

    def do_step(self, t: float, h: float):
        self.sim.set_inputs(**{n: self.values[n] for n in self.input_names})
        self.sim.step(h)
        self.values.update(self.sim.outputs())

    def free(self):
        pass


class FmuSlave:
    """An FMU instance through fmpy's FMU2Slave; FMI errors raise CosimulationError with the FMU's log."""

    _extracted: dict = {}

    def __init__(self, spec: SimulatorSpec):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

        require(Path(spec.source).is_file(), "source", f"{spec.name}: FMU {str(spec.source)!r} not found",
                "an FMU file (build them with: flexfmu build, or pass --fmu-dir)")
        key = str(Path(spec.source).resolve())
        md = read_model_description(key)
        if key not in FmuSlave._extracted:
            FmuSlave._extracted[key] = extract(key)
        self.name = spec.name
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.types = {v.name: v.type for v in md.modelVariables}
        causality = {v.name: v.causality for v in md.modelVariables}
        self.input_names = tuple(n for n, c in causality.items() if c == "input")
        self.output_names = tuple(n for n, c in causality.items() if c == "output")
        self.log: list[str] = []

        def logger(component, instance_name, status, category, message):
            self.log.append((message or b"").decode())

        self._logger = fmi2CallbackLoggerTYPE(logger)
        callbacks = fmi2CallbackFunctions()
        callbacks.logger = self._logger
        callbacks.allocateMemory = ctypes.cast(None, type(callbacks.allocateMemory))
        callbacks.freeMemory = ctypes.cast(None, type(callbacks.freeMemory))
        self.fmu = FMU2Slave(guid=md.guid, unzipDirectory=FmuSlave._extracted[key],
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=spec.name)
        self._call("fmi2Instantiate", self.fmu.instantiate, callbacks=callbacks, loggingOn=True)
        self._spec = spec
        self._vr_cache: dict = {}

    def _call(self, what, fn, *args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except Exception as exc:
            message = self.log[-1] if self.log else str(exc)
            raise CosimulationError(f"{self.name}: {what} failed: {message}") from None

    def initialize(self, start_time: float = 0.0):
        self._call("setupExperiment", self.fmu.setupExperiment, startTime=start_time)
        self._call("enterInitializationMode", self.fmu.enterInitializationMode)
        for name, value in self._spec.initial_values.items():
            require(name in self.vr, f"{self.name}.{name}", "no such variable", "the FMU's variables")
            kind = self.types[name]
            setter = {"Real": (self.fmu.setReal, float), "Integer": (self.fmu.setInteger, int),
                      "Boolean": (self.fmu.setBoolean, bool), "String": (self.fmu.setString, str)}[kind]
            self._call(f"setting {name}", setter[0], [self.vr[name]], [setter[1](value)])
        self._call("exitInitializationMode", self.fmu.exitInitializationMode)

    def _vrs(self, names):
        key = tuple(names)
        hit = self._vr_cache.get(key)
        if hit is None:
            hit = self._vr_cache[key] = [self.vr[n] for n in names]
        return hit

    def set(self, names, values):
        if names:
            self.fmu.setReal(self._vrs(names), [float(v) for v in values])

    def get(self, names):
        return self.fmu.getReal(self._vrs(names)) if names else []

    def do_step(self, t: float, h: float):
        self._call(f"doStep at t = {t:.9g} s", self.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)

    def free(self):
        try:
            self.fmu.terminate()
        finally:
            self.fmu.freeInstance()


# ====================================================================== results
@dataclass
class CosimResult:
    """Time series at the communication points: t (n,), columns {"instance.variable": (n,)}."""

    t: np.ndarray
    columns: dict
    step: float
    scheme: str
    master: str
    slaves: dict = field(default_factory=dict)      # library backend: name -> LibrarySlave (final state)
    extra: dict = field(default_factory=dict)        # library backend: per-step extra records

    def __getitem__(self, key: str) -> np.ndarray:
        return self.columns[key]

    def write_csv(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        names = list(self.columns)
        table = np.column_stack([self.t] + [self.columns[n] for n in names])
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["time"] + names)
            for row in table:
                w.writerow([repr(float(x)) for x in row])
        return path


def _n_steps(t_end: float, start: float, h: float) -> int:
    require(np.isfinite(t_end) and t_end > start, "t-end", f"got {t_end!r}", f"> start time {start!r} s")
    require(np.isfinite(h) and h > 0, "step", f"got {h!r}", "> 0 s")
    n = int(round((t_end - start) / h))
    require(n >= 1 and abs(n * h - (t_end - start)) <= 1e-9 * max(1.0, t_end), "step",
            f"{h!r} s does not divide the run {t_end - start!r} s", "a step that divides t-end - start")
    return n


def _resolve_connections(system: System, slaves: dict):
    """[(source slave, output, target slave, input)] with the direction checked (swapped if given in reverse)."""
    out = []
    for (sa, va), (sb, vb) in system.connections:
        A, B = slaves[sa], slaves[sb]
        if va in A.output_names and vb in B.input_names:
            out.append((sa, va, sb, vb))
        elif vb in B.output_names and va in A.input_names:
            out.append((sb, vb, sa, va))
        else:
            raise ParameterError("VariableConnection", f"{sa}.{va} <-> {sb}.{vb} joins no output to an input",
                                 "one output and one input")
    return out


class Master:
    """The fixed-step master over one system's slaves (FMUs through fmpy, or library façades)."""

    def __init__(self, system: System, backend: str = "fmu"):
        require(backend in BACKENDS, "backend", f"got {backend!r}", " | ".join(BACKENDS))
        self.system, self.backend = system, backend
        make = FmuSlave if backend == "fmu" else LibrarySlave
        self.slaves = {}
        try:
            for spec in system.simulators:
                self.slaves[spec.name] = make(spec)
            conns = _resolve_connections(system, self.slaves)
        except BaseException:
            self.free()
            raise
        self.order = [s.name for s in system.simulators]
        plan = {name: {} for name in self.slaves}        # target -> source -> (outputs, inputs)
        for sa, va, sb, vb in conns:
            outs, ins = plan[sb].setdefault(sa, ([], []))
            outs.append(va)
            ins.append(vb)
        self.plan = {tgt: [(src, tuple(o), tuple(i)) for src, (o, i) in groups.items()]
                     for tgt, groups in plan.items()}
        self.output_names = {name: self.slaves[name].output_names for name in self.order}

    def initialize(self):
        for name in self.order:
            self.slaves[name].initialize(self.system.start_time)
        for name in self.order:                 # inputs at t0 from the outputs at t0
            self.transfer(name)

    def transfer(self, target: str):
        slaves = self.slaves
        for src, outs, ins in self.plan[target]:
            slaves[target].set(ins, slaves[src].get(outs))

    def step(self, t: float, h: float, scheme: str):
        if scheme == "jacobi":
            for name in self.order:
                self.slaves[name].do_step(t, h)
            for name in self.order:
                self.transfer(name)
        else:
            for name in self.order:
                self.transfer(name)
                self.slaves[name].do_step(t, h)

    def outputs(self) -> np.ndarray:
        return np.concatenate([self.slaves[name].get(self.output_names[name]) for name in self.order])

    def column_names(self) -> list:
        return [f"{name}.{var}" for name in self.order for var in self.output_names[name]]

    def free(self):
        if self.backend == "fmu":
            for s in self.slaves.values():
                try:
                    s.free()
                except Exception:
                    pass

    # ---- library backend: the whole co-simulation state as one vector (for the stability analysis)
    # Hydrostatics' "memory" (the radiation memory state of hydrodynamics = bem) is dynamic too: leaving
    # it out would freeze the memory in the linearised step and give the stability of another system.
    # A key absent from a component's state (memory with hydrodynamics = constant) is skipped.
    _DYNAMIC = {"FFRBeam": ("eta", "eta_dot"), "Platform": ("xi", "xi_dot"), "WaveExcitation": (),
                "Hydrostatics": ("memory",), "PTO": ()}

    def state_vector(self) -> np.ndarray:
        parts = []
        for name in self.order:
            sl = self.slaves[name]
            model = self.system.simulator(name).model
            require(model in self._DYNAMIC, "simulator", f"{name}: {model} has no linear state map",
                    ", ".join(self._DYNAMIC))
            st = sl.sim.get_state()
            parts += [np.asarray(st[k], float) for k in self._DYNAMIC[model] if k in st]
            parts.append(np.array([sl.values[n] for n in sl.input_names + sl.output_names], float))
        return np.concatenate(parts)

    def set_state_vector(self, x: np.ndarray, snapshot: dict):
        """Restore ``snapshot`` (from ``snapshot()``) with the numbers of x."""
        j = 0
        for name in self.order:
            sl = self.slaves[name]
            model = self.system.simulator(name).model
            st = dict(snapshot[name])
            for k in (k for k in self._DYNAMIC[model] if k in st):
                n = len(st[k])
                st[k] = x[j:j + n].tolist()
                j += n
            sl.sim.set_state(st)
            keys = sl.input_names + sl.output_names
            sl.values.update(zip(keys, x[j:j + len(keys)].tolist()))
            j += len(keys)

    def snapshot(self) -> dict:
        return {name: self.slaves[name].sim.get_state() for name in self.order}


def run(system: System, t_end: float, step: float | None = None, scheme: str = "jacobi", backend: str = "fmu",
        progress: bool = False, record: Callable | None = None, label: str = "flexfmu cosim") -> CosimResult:
    """Our master: fixed step, Jacobi or Gauss-Seidel, over FMUs (fmpy) or the library façades.
    Records every output of every slave at every communication point (t = start .. t_end).
    ``record(slaves)`` (library backend) may return a dict of extra per-step values."""
    require(scheme in COUPLING_SCHEMES, "scheme", f"got {scheme!r}", " | ".join(COUPLING_SCHEMES))
    h = float(system.base_step if step is None else step)
    n = _n_steps(t_end, system.start_time, h)
    master = Master(system, backend)
    extra = []
    try:
        master.initialize()
        t0 = system.start_time
        first = master.outputs()
        rows = np.empty((n + 1, first.size))
        rows[0] = first
        if record is not None:
            extra.append(record(master.slaves))
        with progress_bar(n, label, enabled=progress, t_end=t_end) as bar:
            for k in range(n):
                t = t0 + k * h
                master.step(t, h, scheme)
                rows[k + 1] = master.outputs()
                if record is not None:
                    extra.append(record(master.slaves))
                bar.update_to(k + 1, t + h)
    finally:
        master.free()
    columns = dict(zip(master.column_names(), rows.T))
    ex = {key: np.array([e[key] for e in extra]) for key in extra[0]} if extra and extra[0] else {}
    return CosimResult(system.start_time + h * np.arange(n + 1), columns, h, scheme,
                       f"{'fmpy' if backend == 'fmu' else backend} ({scheme})",
                       master.slaves if backend == "library" else {}, ex)


# ====================================================================== coupling stability
def step_map(system: System, h: float, scheme: str = "gauss-seidel", t: float = 0.0) -> np.ndarray:
    """The Jacobian of one co-simulation step (library façades) at rest at time t: the map of the
    whole discrete co-simulation state (components' states and the values held between them)."""
    master = Master(system, "library")
    master.initialize()
    snap = master.snapshot()
    x0 = master.state_vector()

    def advance(x):
        master.set_state_vector(x, snap)
        master.step(t, h, scheme)
        return master.state_vector()

    base = advance(x0)
    eps = 1e-7
    J = np.empty((x0.size, x0.size))
    for i in range(x0.size):
        x = x0.copy()
        x[i] += eps
        J[:, i] = (advance(x) - base) / eps
    return J


def spectral_radius(system: System, h: float, scheme: str = "gauss-seidel") -> float:
    return float(np.max(np.abs(np.linalg.eigvals(step_map(system, h, scheme)))))


#: growth per step above which the linearised co-simulation counts as unstable (neutral rigid-body
#: modes - surge, sway, yaw positions - have |lambda| = 1 exactly)
STABILITY_TOLERANCE = 1e-6


def step_limit(system: System, scheme: str = "gauss-seidel", h_min: float = 1e-4, h_max: float = 0.5,
               rtol: float = 0.01, scan_ratio: float = 1.05) -> float:
    """The largest communication step below which the linearised coupled step is stable at every step (spectral
    radius <= 1 + STABILITY_TOLERANCE): a geometric scan from h_min by scan_ratio up to the first unstable step,
    then bisection to rtol.  Stability can come in bands (the example system is unstable at 4.15-4.5 ms and
    6 ms, stable at 5-5.5 ms and 7-10 ms), so the scan is fine: a band narrower than scan_ratio can still be
    missed.  Returns inf if stable up to h_max."""
    require(isinstance(scan_ratio, (int, float)) and 1.0 < scan_ratio <= 2.0, "scan_ratio", f"got {scan_ratio!r}",
            "1 < scan_ratio <= 2")
    unstable = lambda h: spectral_radius(system, h, scheme) > 1 + STABILITY_TOLERANCE   # noqa: E731
    require(not unstable(h_min), "step", f"the coupled system is unstable even at {h_min:g} s",
            "a system whose coupling is stable for small steps")
    grid = np.geomspace(h_min, h_max, int(math.ceil(math.log(h_max / h_min) / math.log(scan_ratio))) + 1)
    lo = h_min
    for h in grid[1:]:
        if unstable(h):
            hi = h
            break
        lo = h
    else:
        return math.inf
    while hi - lo > rtol * lo:
        mid = math.sqrt(lo * hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    return lo


def _is_ssp(system: System) -> bool:
    return system.path is not None and (Path(system.path).suffix.lower() in (".ssp", ".ssd")
                                        or Path(system.path).is_dir())


def run_libcosim(system: System, t_end: float, step: float | None = None, progress: bool = False,
                 label: str = "flexfmu cosim (libcosim)", description: str | None = None) -> CosimResult:
    """DNV's libcosim (libcosimpy) on the same description (its fixed-step algorithm: Jacobi).
    The system (with any changed start values) is written into a temporary folder first, as an OSP
    file with absolute FMU paths (``description="osp"``, libcosim's from_osp_config_file) or as an
    SSP archive (``"ssp"``, from_ssp_file); default: the format the system was read from."""
    from fmpy import read_model_description
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    h = float(system.base_step if step is None else step)
    n = _n_steps(t_end, system.start_time, h)
    require(abs(round(h * 1e9) - h * 1e9) <= 1e-6 * h * 1e9, "step", f"{h!r} s is not a whole number of ns",
            "a multiple of 1 ns (libcosim's time unit)")
    for spec in system.simulators:
        require(Path(spec.source).is_file(), "source", f"{spec.name}: FMU {str(spec.source)!r} not found",
                "an FMU file (build them with: flexfmu build, or pass --fmu-dir)")
    description = description or ("ssp" if _is_ssp(system) else "osp")
    require(description in ("osp", "ssp"), "description", f"got {description!r}", "osp | ssp")
    log_output_level(CosimLogLevel.ERROR)
    with tempfile.TemporaryDirectory() as tmp:
        if description == "ssp":
            ssp = write_ssp(system, Path(tmp) / "system.ssp", h)
            execution = CosimExecution.from_ssp_file(str(ssp), int(round(h * 1e9)))
        else:
            osp = write_osp(system, Path(tmp) / "OspSystemStructure.xml", h)
            execution = CosimExecution.from_osp_config_file(str(osp))
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    index, outputs = {}, {}
    for spec in system.simulators:
        md = read_model_description(str(spec.source))
        index[spec.name] = execution.slave_index_from_instance_name(spec.name)
        outs = [(v.name, v.valueReference) for v in md.modelVariables if v.causality == "output"]
        outputs[spec.name] = outs
    order = [s.name for s in system.simulators]
    rows = []

    def sample():
        rows.append(np.concatenate([observer.last_real_values(index[nm], [vr for _, vr in outputs[nm]])
                                    for nm in order]))

    with progress_bar(n, label, enabled=progress, t_end=t_end) as bar:
        ok = execution.step(1)        # libcosim initialises on the first step
        require(ok, "libcosim", "the first step failed", "see the FMUs' log")
        sample()                      # libcosim's observer has no values before the first step: t0 is not recorded
        bar.update_to(1, system.start_time + h)
        for k in range(1, n):
            ok = execution.step(1)
            require(ok, "libcosim", f"step {k + 1} (t = {system.start_time + k * h:.9g} s) failed",
                    "a step inside the coupling-stability limit")
            sample()
            bar.update_to(k + 1, system.start_time + (k + 1) * h)
    del execution
    data = np.array(rows)
    columns = {}
    j = 0
    for nm in order:
        for var, _ in outputs[nm]:
            columns[f"{nm}.{var}"] = data[:, j]
            j += 1
    t = system.start_time + h * np.arange(1, n + 1)
    return CosimResult(t, columns, h, "jacobi", "libcosim (jacobi)")
def _load_ecospy():
    """ecospy's EcosSimulation; its library links libtbb.so.12, which the PyPI package tbb puts in the
    environment's lib/ (not on the loader's path): loaded globally first when it is there."""
    lib = Path(sys.prefix) / "lib" / "libtbb.so.12"
    if lib.exists():
        ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    try:
        from ecospy import EcosSimulation
    except (ImportError, OSError) as exc:
        raise ParameterError("master", f"ecos (ecospy) cannot be loaded: {exc}",
                             "fmpy | libcosim | library, or pip install ecospy tbb") from None
    return EcosSimulation


def run_ecos(system: System, t_end: float, step: float | None = None, progress: bool = False,
             label: str = "flexfmu cosim (ecos)") -> CosimResult:
    """The ecos engine (ecospy's C library, the FMUs in this process) on the system written as an SSP
    archive into a temporary folder (its fixed-step algorithm: Jacobi; the outputs after
    initialisation are passed to the inputs before the first step; time accumulated, t += h).
    Start values are the SSP's parameter set "start"."""
    from fmpy import read_model_description

    h = float(system.base_step if step is None else step)
    n = _n_steps(t_end, system.start_time, h)
    require(system.start_time == 0.0, "StartTime", f"got {system.start_time!r}", "0 for ecos")
    EcosSimulation = _load_ecospy()
    order = [s.name for s in system.simulators]
    outputs = {s.name: [v.name for v in read_model_description(str(s.source)).modelVariables
                        if v.causality == "output"] for s in system.simulators}
    ids = [f"{nm}::{var}" for nm in order for var in outputs[nm]]
    rows = np.empty((n + 1, len(ids)))
    with tempfile.TemporaryDirectory() as tmp:
        ssp = write_ssp(system, Path(tmp) / "system.ssp", h)
        sim = EcosSimulation(ssp_path=str(ssp), step_size=h)
        try:
            sim.init(parameter_set=PARAMETER_SET)
            get = sim.get_real
            rows[0] = [get(i) for i in ids]
            with progress_bar(n, label, enabled=progress, t_end=t_end) as bar:
                for k in range(n):
                    sim.step()
                    rows[k + 1] = [get(i) for i in ids]
                    bar.update_to(k + 1, system.start_time + (k + 1) * h)
            sim.terminate()
        finally:
            sim.free()
    require(bool(np.all(np.isfinite(rows))), "ecos", "non-finite outputs", "a step inside the coupling-stability limit")
    columns = dict(zip([f"{nm}.{var}" for nm in order for var in outputs[nm]], rows.T))
    return CosimResult(system.start_time + h * np.arange(n + 1), columns, h, "jacobi", "ecos (jacobi)")


def stability_check(system: System, h: float, scheme: str, n_grid: int = 12) -> dict:
    """Is the linearised coupled step stable at h and at n_grid evenly spaced steps below it?
    Returns {"stable": bool, "spectral_radius": rho(h), "first_unstable": smallest unstable step
    found on the grid (or None)}.  Unstable windows narrower than h / n_grid can be missed: the
    full scan is ``step_limit``."""
    rho = spectral_radius(system, h, scheme)
    first = None
    for hg in np.linspace(h / n_grid, h, n_grid):
        r = rho if hg == h else spectral_radius(system, float(hg), scheme)
        if r > 1 + STABILITY_TOLERANCE:
            first = float(hg)
            break
    return {"stable": first is None, "spectral_radius": rho, "first_unstable": first}
