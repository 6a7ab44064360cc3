"""The other engines on the same system description, both Jacobi (their fixed-step algorithm): DNV's libcosim
(libcosimpy; :func:`run_libcosim`) and the ecos engine (ecospy; :func:`run_ecos`).  Each gets the system written
into a temporary folder, as an OSP file or an SSP archive; their results are CosimResults like our master's, and
their run length is checked the same way first (flexfmu.cosim.checks).
"""
from __future__ import annotations

import contextlib
import ctypes
import sys
import tempfile
from pathlib import Path

import numpy as np

from flexfmu.core.progress import progress_bar
from flexfmu.cosim.checks import MAX_RESULT_BYTES, check_result_memory, check_system, n_steps
from flexfmu.cosim.results import CosimResult
from flexfmu.cosim.slaves import model_description
from flexfmu.cosim.ssp import PARAMETER_SET, write_ssp
from flexfmu.cosim.system import System, write_osp
from flexfmu.errors import CosimulationError, ParameterError, require


def _is_ssp(system: System) -> bool:
    return system.path is not None and (Path(system.path).suffix.lower() in (".ssp", ".ssd")
                                        or Path(system.path).is_dir())


def _chunks(n: int, every: int) -> list[int]:
    """The steps between recorded points: ``every`` steps each, the last chunk what is left of n."""
    require(isinstance(every, int) and every >= 1, "every", f"got {every!r}", "an integer >= 1")
    return [every] * (n // every) + ([n % every] if n % every else [])


def run_libcosim(system: System, t_end: float, step: float | None = None, progress: bool = False,
                 label: str = "flexfmu cosim (libcosim)", description: str | None = None,
                 max_result_bytes: float = MAX_RESULT_BYTES, every: int = 1) -> CosimResult:
    """DNV's libcosim (libcosimpy) on the same description (its fixed-step algorithm: Jacobi).
    The system (with any changed start values) is written into a temporary folder first, as an OSP
    file with absolute FMU paths (``description="osp"``, libcosim's from_osp_config_file) or as an
    SSP archive (``"ssp"``, from_ssp_file); default: the format the system was read from.  ``every``: record the
    outputs at every ``every``-th communication point (and the last): libcosim takes the steps between in one call,
    without Python in its loop (a long run's speed is then libcosim's and the FMUs')."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    h = float(system.base_step if step is None else step)
    n = n_steps(t_end, system.start_time, h)
    require(abs(round(h * 1e9) - h * 1e9) <= 1e-6 * h * 1e9, "step", f"{h!r} s is not a whole number of ns",
            "a multiple of 1 ns (libcosim's time unit)")
    check_result_memory(n, check_system(system, "fmu").n_outputs, h, max_result_bytes)
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
        md = model_description(spec)
        index[spec.name] = execution.slave_index_from_instance_name(spec.name)
        outs = [(v.name, v.valueReference) for v in md.modelVariables if v.causality == "output"]
        outputs[spec.name] = outs
    order = [s.name for s in system.simulators]
    rows = []

    def sample():
        rows.append(np.concatenate([observer.last_real_values(index[nm], [vr for _, vr in outputs[nm]])
                                    for nm in order]))

    chunks = _chunks(n, every)
    done = []                         # the step count after each recorded point
    with progress_bar(n, label, enabled=progress, t_end=t_end) as bar:
        ok = execution.step(1)        # libcosim initialises on the first step
        require(ok, "libcosim", "the first step failed", "see the FMUs' log")
        sample()                      # libcosim's observer has no values before the first step: t0 is not recorded
        done.append(1)
        bar.update_to(1, system.start_time + h)
        # after the first step, chunks of `every` (the first chunk one shorter: the points stay at multiples)
        chunks[0] -= 1
        for count in chunks:
            if count == 0:
                continue
            k = done[-1]
            ok = execution.step(count)
            require(ok, "libcosim", f"a step in {k + 1} .. {k + count} (t = {system.start_time + k * h:.9g} .. "
                    f"{system.start_time + (k + count) * h:.9g} s) failed", "a step inside the coupling-stability limit")
            sample()
            done.append(k + count)
            bar.update_to(k + count, system.start_time + (k + count) * h)
    del execution
    data = np.array(rows)
    columns = {}
    j = 0
    for nm in order:
        for var, _ in outputs[nm]:
            columns[f"{nm}.{var}"] = data[:, j]
            j += 1
    t = system.start_time + h * np.array(done, float)
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


def _initialise_each(system: System) -> None:
    """Each FMU instantiated and initialised once with its start values (through fmpy), freed again: ecos goes on
    after an FMU refuses its initialisation (its init still returns true) and records the zeros of a model that
    never ran, so a refusal is raised here first, with the FMU's message."""
    from flexfmu.cosim.slaves import FmuSlave
    for spec in system.simulators:
        slave = FmuSlave(spec)
        try:
            slave.initialize(system.start_time)
        finally:
            with contextlib.suppress(Exception):        # an instance whose initialisation failed cannot terminate
                slave.free()


def _ecos_error() -> str:
    from ecospy.lib import EcosLib
    return EcosLib.get_last_error() or "no message (the FMUs' own log says why)"


def run_ecos(system: System, t_end: float, step: float | None = None, progress: bool = False,
             label: str = "flexfmu cosim (ecos)", max_result_bytes: float = MAX_RESULT_BYTES,
             every: int = 1) -> CosimResult:
    """The ecos engine (ecospy's C library, the FMUs in this process) on the system written as an SSP
    archive into a temporary folder (its fixed-step algorithm: Jacobi; the outputs after
    initialisation are passed to the inputs before the first step; time accumulated, t += h).
    Start values are the SSP's parameter set "start".  ecos goes on after an FMU call fails (its init and step
    still succeed): each FMU is initialised once beforehand, so that a refused start value is raised; a step an
    FMU refuses during the run cannot be seen from here (run the fmpy master to see it).  ``every``: record the
    outputs at t0 and every ``every``-th communication point (and the last), ecos taking the steps between in one
    call."""
    h = float(system.base_step if step is None else step)
    n = n_steps(t_end, system.start_time, h)
    require(system.start_time == 0.0, "StartTime", f"got {system.start_time!r}", "0 for ecos")
    check_result_memory(n, check_system(system, "fmu").n_outputs, h, max_result_bytes)
    EcosSimulation = _load_ecospy()
    _initialise_each(system)
    order = [s.name for s in system.simulators]
    outputs = {s.name: [v.name for v in model_description(s).modelVariables
                        if v.causality == "output"] for s in system.simulators}
    ids = [f"{nm}::{var}" for nm in order for var in outputs[nm]]
    chunks = _chunks(n, every)
    rows = np.empty((len(chunks) + 1, len(ids)))
    with tempfile.TemporaryDirectory() as tmp:
        ssp = write_ssp(system, Path(tmp) / "system.ssp", h)
        sim = EcosSimulation(ssp_path=str(ssp), step_size=h)
        try:
            # ecos reports a failed FMU call only by its return value (and its last error): a failure must stop
            # the run here, or the outputs read after it are the zeros of models that never ran
            if not sim.init(parameter_set=PARAMETER_SET):
                raise CosimulationError(f"ecos: initialisation failed: {_ecos_error()}")
            get = sim.get_real
            rows[0] = [get(i) for i in ids]
            k = 0
            with progress_bar(n, label, enabled=progress, t_end=t_end) as bar:
                for j, count in enumerate(chunks):
                    t = sim.step(count)
                    if not t > system.start_time + (k + count - 0.5) * h:      # a step did not happen
                        raise CosimulationError(f"ecos: a step in {k + 1} .. {k + count} (from t = "
                                                f"{system.start_time + k * h:.6g} s) failed: {_ecos_error()}")
                    k += count
                    rows[j + 1] = [get(i) for i in ids]
                    bar.update_to(k, system.start_time + k * h)
            sim.terminate()
        finally:
            sim.free()
    require(bool(np.all(np.isfinite(rows))), "ecos", "non-finite outputs", "a step inside the coupling-stability limit")
    columns = dict(zip([f"{nm}.{var}" for nm in order for var in outputs[nm]], rows.T))
    points = np.concatenate([[0], np.cumsum(chunks)])
    return CosimResult(system.start_time + h * points, columns, h, "jacobi", "ecos (jacobi)")
