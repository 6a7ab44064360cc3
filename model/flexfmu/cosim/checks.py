"""What is checked before a co-simulation starts, once for every master: the system against its FMUs or library
models (:func:`check_system`: each instance's interface, its start values, every connection an output into an input
and no input fed twice) and the run's length (:func:`n_steps`, :func:`check_result_memory`: the number of
communication steps and the memory the recorded results take, against ``MAX_RESULT_BYTES``).

Every refusal is a ParameterError naming where the system file declares the offending element (or the option:
t-end, step, max-memory) and what is allowed, so ``flexfmu cosim`` and ``flexfmu wec power-matrix`` stop with one
line before any step.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from flexfmu.cosim.slaves import Interface, interface, start_value, value_where
from flexfmu.cosim.system import System
from flexfmu.errors import ParameterError, require

#: The default limit on the results a run records in memory: every output of every instance at every communication
#: point, 8 bytes each, and the time.  ``flexfmu cosim --max-memory GIB`` and ``max_result_bytes`` raise it.
MAX_RESULT_BYTES = 4 * 2**30
_GIB = 2**30


def _finite_real(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def n_steps(t_end: float, start: float, h: float) -> int:
    """The number of communication steps h from ``start`` to ``t_end``: both finite, t_end > start, h > 0 and
    dividing the run (within 1e-9 of the run)."""
    require(_finite_real(t_end), "t-end", f"{t_end!r} is not finite", f"a finite end time > start time {start!r} s")
    require(t_end > start, "t-end", f"got {t_end!r}", f"> start time {start!r} s")
    require(_finite_real(h) and h > 0, "step", f"got {h!r}", "a finite step > 0 s")
    ratio = (t_end - start) / h
    require(math.isfinite(ratio), "t-end, step", f"(t-end - start) / step = ({t_end!r} - {start!r}) / {h!r} "
            "communication steps is not finite", "a run of finitely many steps: a shorter --t-end or a larger --step")
    n = int(round(ratio))
    require(n >= 1 and abs(n * h - (t_end - start)) <= 1e-9 * max(1.0, t_end), "step",
            f"{h!r} s does not divide the run {t_end - start!r} s", "a step that divides t-end - start")
    return n


def check_result_memory(n: int, n_outputs: int, h: float, max_result_bytes: float = MAX_RESULT_BYTES) -> None:
    """Refuse a run of n steps whose recorded results (n + 1 rows of n_outputs outputs and the time, 8 bytes each)
    exceed ``max_result_bytes``, before anything is allocated."""
    require(_finite_real(max_result_bytes) and max_result_bytes > 0, "max-memory", f"got {max_result_bytes!r} bytes",
            "a finite limit > 0")
    row = 8 * (n_outputs + 1)
    need = (n + 1) * row
    if need > max_result_bytes:
        most = max(int(max_result_bytes // row) - 1, 0)
        raise ParameterError("t-end, step", f"{n:.4g} communication steps of {h!r} s, recording {n_outputs} outputs "
                             f"each, would need {need / _GIB:.3g} GiB of memory",
                             f"at most {max_result_bytes / _GIB:.4g} GiB of recorded results, here {most:.4g} steps: "
                             "a shorter --t-end, a larger --step, or a larger --max-memory")


def check_output_path(path, option: str) -> None:
    """Refuse, before a run, an output file that could not be written after it: an existing folder, or a path
    whose nearest existing parent is a file or a folder this process may not write in."""
    if path is None:
        return
    path = Path(path)
    require(not path.is_dir(), option, f"{str(path)!r} is a folder", "a file path")
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    require(parent.is_dir(), option, f"{str(path)!r}: {str(parent)!r} is a file", "a path inside folders")
    require(os.access(parent, os.W_OK), option, f"{str(path)!r}: {str(parent)!r} is not writable",
            "a path in a folder you may write in")


def _connection_text(sa, va, sb, vb) -> str:
    return f"{sa}.{va} -> {sb}.{vb}"


def resolve_connections(system: System, interfaces: dict) -> list:
    """[(source instance, output, target instance, input)] of the system's connections, each turned output ->
    input (a connection given input first is swapped), with ``interfaces`` {instance: object with input_names and
    output_names}.  A variable the instance does not have, a connection of two outputs or two inputs, and a second
    connection into an input are ParameterErrors naming where the file declares the connection."""
    out, fed_by = [], {}
    for connection in system.connections:
        (sa, va), (sb, vb) = connection
        at = system.connection_origin(connection) or "VariableConnection"
        for inst in (sa, sb):
            require(inst in interfaces, at, f"unknown simulator {inst!r}", ", ".join(interfaces))
        A, B = interfaces[sa], interfaces[sb]
        for inst, var, I in ((sa, va, A), (sb, vb, B)):
            require(var in I.input_names or var in I.output_names, at, f"{inst} has no input or output {var!r}",
                    ", ".join(I.output_names + I.input_names))
        if va in A.output_names and vb in B.input_names:
            link = (sa, va, sb, vb)
        elif vb in B.output_names and va in A.input_names:
            link = (sb, vb, sa, va)
        else:
            raise ParameterError(at, f"{sa}.{va} <-> {sb}.{vb} joins no output to an input",
                                 "one output and one input")
        target = link[2:]
        if target in fed_by:
            first, first_at = fed_by[target]
            raise ParameterError(at, f"{_connection_text(*link)} is a second connection into the input "
                                 f"{target[0]}.{target[1]}, fed already by {_connection_text(*first)} "
                                 f"({first_at or 'made by the caller'})", "one connection into each input")
        fed_by[target] = (link, system.connection_origin(connection))
        out.append(link)
    return out


@dataclass(frozen=True)
class _Names:
    input_names: tuple
    output_names: tuple


@dataclass(frozen=True)
class CheckedSystem:
    """What :func:`check_system` found: each instance's interface and the connections, output -> input."""

    interfaces: dict
    connections: list

    @property
    def n_outputs(self) -> int:
        """The number of outputs a run records at each communication point."""
        return sum(len(i.outputs) for i in self.interfaces.values())


def check_system(system: System, backend: str = "fmu") -> CheckedSystem:
    """Check the system against its FMUs (backend "fmu": their modelDescription.xml) or the library models they
    wrap ("library") without instantiating anything: every FMU there and an FMU, every start value a parameter or
    input of its instance and of its type, every connection an output into an input of the instances, no input
    fed twice."""
    interfaces: dict[str, Interface] = {}
    for spec in system.simulators:
        found = interfaces[spec.name] = interface(spec, backend)
        for variable in spec.initial_values:
            require(variable in found.settable, value_where(spec, variable),
                    f"{spec.name} has no parameter {variable!r}", ", ".join(found.settable) or "none")
            start_value(spec, variable, found.settable[variable], found.settable)
    names = {k: _Names(i.inputs, i.outputs) for k, i in interfaces.items()}
    return CheckedSystem(interfaces, resolve_connections(system, names))
