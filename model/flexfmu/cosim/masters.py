"""Co-simulation masters for a system of FMUs described by one OSP system structure file
(``OspSystemStructure.xml``, the format libcosim reads with ``CosimExecution.from_osp_config_file``) or an SSP.

Four ways to run the same description, all with a fixed communication step h:

- ``run(system, ..., backend="fmu")``: our own master over fmpy's ``FMU2Slave``, Jacobi (every
  slave steps from t_n with the inputs of t_n, then all outputs are passed on: what libcosim's
  fixed-step algorithm does), Gauss-Seidel (slaves step one after the other in the file's order,
  each with the newest outputs of those before it) or interface-Jacobian (every slave steps, then the
  coupling equations are solved with the outputs linearised in the inputs: flexfmu.cosim.coupling).
- ``run(system, ..., backend="library")``: the same loop over the flexfmu façades that the FMUs
  wrap (no FMI, and the components' internal state is at hand, e.g. for the energy audit).
- ``run_libcosim(system, ...)``: DNV's libcosim through libcosimpy on the same file (Jacobi).
- ``run_ecos(system, ...)``: the ecos engine (ecospy) on the system written as SSP (Jacobi).

This module is the masters' one entry: it holds our master (:class:`Master`, :func:`run`), the start values
changed by name (:func:`with_assignments`) and the linear coupling-stability analysis of the discrete
co-simulation (:func:`step_map`, :func:`step_limit`, :func:`stability_check`), and names what the cosim modules
beside it hold, for callers (flexfmu.wec.system, the studies, examples/) to import from here:

- flexfmu.cosim.system: SimulatorSpec, System, the OSP file (load_osp, write_osp); flexfmu.cosim.ssp: the SSP;
  :func:`load_system` reads either;
- flexfmu.cosim.slaves: FmuSlave, LibrarySlave, LIBRARY_MODULES, the instances' interfaces;
- flexfmu.cosim.checks: what is checked before a run (the system against its FMUs or models, the run's length and
  memory, MAX_RESULT_BYTES);
- flexfmu.cosim.results: CosimResult; flexfmu.cosim.engines: run_libcosim, run_ecos.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import numpy as np

from flexfmu.core.progress import progress_bar
from flexfmu.cosim.checks import (MAX_RESULT_BYTES, CheckedSystem, check_result_memory, check_system, n_steps,
                                  resolve_connections)
from flexfmu.cosim.coupling import (COUPLING_SCHEMES, INTERFACE_JACOBIAN, STEP_JACOBIAN, InterfaceCoupling,
                                    check_interface_jacobians)
from flexfmu.cosim.engines import run_ecos, run_libcosim
from flexfmu.cosim.results import CosimResult
from flexfmu.cosim.slaves import LIBRARY_MODULES, FmuSlave, Interface, LibrarySlave, interface
from flexfmu.cosim.ssp import load_ssp
# the names of the modules beside this one that callers have always imported from here: kept importable on purpose
from flexfmu.cosim.system import SimulatorSpec, System, is_ssp_path, load_osp, write_osp
from flexfmu.errors import ParameterError, require

__all__ = ["BACKENDS", "COUPLING_SCHEMES", "LIBRARY_MODULES", "MAX_RESULT_BYTES", "STABILITY_TOLERANCE",
           "CheckedSystem", "CosimResult", "FmuSlave", "Interface", "LibrarySlave", "Master", "SimulatorSpec",
           "System", "check_result_memory", "check_system", "interface", "is_ssp_path", "load_osp", "load_system",
           "n_steps", "resolve_connections", "run", "run_ecos", "run_libcosim", "settable_variables",
           "spectral_radius", "stability_check", "step_limit", "step_map", "with_assignments", "write_osp"]

BACKENDS = ("fmu", "library")


# ====================================================================== start values
def settable_variables(spec: SimulatorSpec) -> dict:
    """{variable: FMI type name} of the start values an instance takes: its FMU's parameters and
    inputs (modelDescription.xml), or, when the FMU file is not there, its library model's parameters."""
    library = not Path(spec.source).is_file() and spec.model in LIBRARY_MODULES
    return interface(spec, "library" if library else "fmu").settable     # "fmu": a missing FMU is named


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


# ====================================================================== our master
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
            conns = resolve_connections(system, self.slaves)
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
        self.coupling = InterfaceCoupling(self.order, self.plan)
        self.coupled_outputs: dict = {}         # interface-Jacobian: the outputs for the solved inputs

    def initialize(self, scheme: str = "jacobi"):
        for name in self.order:
            self.slaves[name].initialize(self.system.start_time)
        if scheme == INTERFACE_JACOBIAN:         # the coupling equations solved at t0
            self.couple(self.system.start_time)
            return
        for name in self.order:                 # inputs at t0 from the outputs at t0
            self.transfer(name)

    def couple(self, t: float):
        """Interface-Jacobian: set every connected input to the solution of the linearised coupling equations at the
        slaves' current state (flexfmu.cosim.coupling) and keep the outputs that belong to them."""
        self.coupled_outputs = self.coupling.solve(self.slaves, t)
        for name in self.order:
            sl = self.slaves[name]
            if isinstance(sl, LibrarySlave):     # the façade's outputs as seen by record() and state_vector()
                sl.values.update(zip(sl.output_names, self.coupled_outputs[name].tolist()))

    def transfer(self, target: str):
        slaves = self.slaves
        for src, outs, ins in self.plan[target]:
            slaves[target].set(ins, slaves[src].get(outs))

    def step(self, t: float, h: float, scheme: str):
        if scheme == INTERFACE_JACOBIAN:
            for name in self.order:
                self.slaves[name].do_step(t, h)
            self.couple(t + h)
        elif scheme == STEP_JACOBIAN:       # implicit in the held inputs, which it leaves set for the next step
            self.coupling.step(self.slaves, t, h)
        elif scheme == "jacobi":
            for name in self.order:
                self.slaves[name].do_step(t, h)
            for name in self.order:
                self.transfer(name)
        else:
            for name in self.order:
                self.transfer(name)
                self.slaves[name].do_step(t, h)

    def outputs(self) -> np.ndarray:
        if self.coupled_outputs:
            return np.concatenate([self.coupled_outputs[name] for name in self.order])
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
        progress: bool = False, record: Callable | None = None, label: str = "flexfmu cosim",
        max_result_bytes: float = MAX_RESULT_BYTES) -> CosimResult:
    """Our master: fixed step, Jacobi, Gauss-Seidel or interface-Jacobian (flexfmu.cosim.coupling), over FMUs
    (fmpy) or the library façades.  Records every output of every slave at every communication point
    (t = start .. t_end).  ``record(slaves)`` (library backend) may return a dict of extra per-step values.
    Before anything is instantiated the system is checked against its FMUs or models (check_system), the
    recorded results against ``max_result_bytes`` (check_result_memory) and, for the interface-Jacobian scheme
    over FMUs, that every FMU with a connected input provides directional derivatives."""
    require(scheme in COUPLING_SCHEMES, "scheme", f"got {scheme!r}", " | ".join(COUPLING_SCHEMES))
    require(backend in BACKENDS, "backend", f"got {backend!r}", " | ".join(BACKENDS))
    h = float(system.base_step if step is None else step)
    n = n_steps(t_end, system.start_time, h)
    checked = check_system(system, backend)
    check_result_memory(n, checked.n_outputs, h, max_result_bytes)
    if scheme == INTERFACE_JACOBIAN:
        check_interface_jacobians(system, checked, backend)
    master = Master(system, backend)
    extra = []
    try:
        master.initialize(scheme)
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
    require(scheme in COUPLING_SCHEMES, "scheme", f"got {scheme!r}", " | ".join(COUPLING_SCHEMES))
    master = Master(system, "library")
    master.initialize(scheme)
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
