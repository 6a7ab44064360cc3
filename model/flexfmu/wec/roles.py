"""What each component is in the wave-energy-converter system: its role, and the roster of a system file.

A component's registry row (flexfmu.fmi.registry, ``FmuSpec.role``) names the module whose ``SYSTEM_ROLE`` (a
:class:`Role`) says what the component contributes to the system studies of flexfmu.wec.system: energy terms of
the audit (the work it does on the platform, energy it stores, dissipates or harvests), harvested power,
diagnostics, summary lines, chart panels, and per-step values that only the library state holds.  The roles
compute these from the recorded outputs of their own instance and of the instances the system file connects to
it (:class:`Recorded`), so a role names no other instance.  flexfmu.wec.system iterates over the instances the
file holds (:func:`roster`) and keeps what is system-level: the balance, the sums, the tables.

A new component of the system is its simulator module (with its ``SYSTEM_ROLE``) and its registry row.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from flexfmu.errors import ParameterError, require
from flexfmu.fmi.registry import BY_NAME

#: the categories of energy terms: WORK_IN is energy brought into the system (the balance's left-hand side);
#: the balance subtracts the others in this order (then in the file's order of the instances)
WORK_IN = "work in"
KINETIC, POTENTIAL, DISSIPATED, HARVESTED = "kinetic", "potential", "dissipated", "harvested"
CATEGORIES = (KINETIC, POTENTIAL, DISSIPATED, HARVESTED)
#: the kinds of role a wave-energy-converter system cannot do without: something drives it, something floats
REQUIRED_KINDS = ("wave", "platform")


@dataclass(frozen=True)
class Term:
    """One energy term (J) over the run: its category (WORK_IN or one of CATEGORIES) and its label in the table."""

    category: str
    label: str
    value: float


@dataclass
class Panel:
    """One panel of the run's chart.  ``curves``: (y, keyword arguments) drawn against time (``ax.plot``), or a
    float y drawn as a horizontal line (``ax.axhline``).  Panels with the same ``key`` share one axes (the wave's
    elevation is drawn over the platform's translation), titled by the first."""

    key: str
    title: str
    ylabel: str
    curves: list = field(default_factory=list)


class Role:
    """A component's part in the wave-energy-converter system; every contribution defaults to nothing.

    ``kind`` names the part (e.g. "wave", "platform", "harvester", "pto"): the system's own studies look up the
    one instance of a kind (Roster.one).  Every method gets the instance (:class:`Member`) and, after a run,
    the recorded outputs (:class:`Recorded`)."""

    kind = ""

    def energy(self, m: "Member", r: "Recorded") -> list:
        """Energy terms (:class:`Term`) of this instance over the run."""
        return []

    def diagnostics(self, m: "Member", r: "Recorded") -> dict:
        """Named numbers that explain the balance (not part of it)."""
        return {}

    def power(self, m: "Member", r: "Recorded"):
        """Harvested power (W) at the communication points, or None for a component that harvests nothing."""
        return None

    def input_work(self, m: "Member", r: "Recorded", input_name: str):
        """The work (J, at the communication points) done on this instance by the loads at ``input_name``'s
        group of inputs, or None when this component does not account for it."""
        return None

    def recorder(self, m: "Member"):
        """A function of the library slaves ({instance: LibrarySlave}) returning this instance's per-step values
        ({key: float}, recorded as ``instance.key`` in CosimResult.extra), or None."""
        return None

    def summary(self, m: "Member", r: "Recorded", sel) -> list:
        """Lines of the run's summary over the samples ``sel``."""
        return []

    def panels(self, m: "Member", r: "Recorded") -> list:
        """Panels (:class:`Panel`) of the run's chart."""
        return []


def change(y) -> float:
    """The change of a stored energy over the run."""
    return float(y[-1] - y[0])


def integral(y, t) -> float:
    """The integral of a power over the run (trapezoidal rule over the communication points)."""
    return float(np.trapezoid(y, t))


def amplitude(y, sel) -> float:
    """Half the peak-to-peak over the samples ``sel``."""
    return 0.5 * float(np.ptp(y[sel]))


def mean_power(p, t, t_from: float) -> float:
    """The mean of a power from t_from to the end (its integral over the duration)."""
    sel = t >= t_from
    return integral(p[sel], t[sel]) / (t[sel][-1] - t[sel][0])


def summary_line(label: str, text: str) -> str:
    """One line of the run's summary, the labels in one column."""
    return f"  {label:29s} {text}"


# ---------------------------------------------------------------- the roster of a system file
@dataclass
class Member:
    """One instance of the system file: its name, model, role and the roster it belongs to."""

    name: str
    model: str
    role: Role
    roster: "Roster"
    spec: object                       # the system file's SimulatorSpec

    @property
    def suffix(self) -> str:
        """What tells this instance's labels from those of another instance of its model: " [name]", or ""."""
        return f" [{self.name}]" if len(self.roster.system.by_model(self.model)) > 1 else ""

    @cached_property
    def config(self):
        """The instance's parameters: its library model's config with the file's start values."""
        # imported here: the components' simulator modules import this module for Role, and an FMU running one
        # of them has no use for the masters
        from flexfmu.cosim.masters import LibrarySlave
        return LibrarySlave(self.spec).config


class Roster:
    """The instances of a system file with their roles (in the file's order) and where each input comes from."""

    def __init__(self, system, members_of: dict):
        self.system = system
        self.members = [Member(s.name, s.model, members_of[s.model], self, s) for s in system.simulators]
        self._by_name = {m.name: m for m in self.members}
        self._sources = {}
        for (a, va), (b, vb) in system.connections:
            if vb in self._io(b)[0] and va in self._io(a)[1]:
                self._sources[(b, vb)] = (a, va)
            elif va in self._io(a)[0] and vb in self._io(b)[1]:
                self._sources[(a, va)] = (b, vb)

    def _io(self, name: str) -> tuple:
        spec = BY_NAME[self._by_name[name].model]
        return spec.input_names, spec.output_names

    def member(self, name: str) -> Member:
        return self._by_name[name]

    def of_kind(self, kind: str) -> list:
        return [m for m in self.members if m.role.kind == kind]

    def one(self, kind: str) -> Member:
        """The one instance of a kind (ParameterError if the file holds none or several)."""
        found = self.of_kind(kind)
        require(len(found) == 1, "SYSTEM_FILE", f"{len(found)} instances of the {kind} role "
                f"({', '.join(m.name for m in found) or 'none'})", f"exactly one {kind} for this study")
        return found[0]

    def source(self, name: str, input_name: str):
        """(instance, output) that feeds an instance's input, or None when the file leaves it unconnected."""
        return self._sources.get((name, input_name))

    def targets(self, name: str, output: str) -> list:
        """[(instance, input)] that an instance's output feeds."""
        return [tgt for tgt, src in self._sources.items() if src == (name, output)]


def roster(system) -> Roster:
    """The system file's instances with their roles.  Every instance's model must be a registered component with
    a role (else ParameterError naming the simulator and the known models), and the file must hold each of
    REQUIRED_KINDS; any other component may be missing or appear more than once."""
    known = {name: spec for name, spec in BY_NAME.items() if getattr(spec, "role", "")}
    for s in system.simulators:
        if s.model not in known:
            raise ParameterError("simulator", f"{s.name}: {s.model} is not a component of the wave-energy "
                                 "converter system", "the models " + ", ".join(known))
    out = Roster(system, {s.model: _role(known[s.model]) for s in system.simulators})
    for kind in REQUIRED_KINDS:
        models = [name for name, spec in known.items() if _role(spec).kind == kind]
        require(out.of_kind(kind), "SYSTEM_FILE", f"no {kind} among {', '.join(s.name for s in system.simulators)}",
                f"a wave-energy converter system: at least one {' or '.join(models)}")
    return out


def _role(spec) -> Role:
    # named as text in the registry row: the registry (fmi) lies below the wave converter (wec)
    return importlib.import_module(spec.role).SYSTEM_ROLE


class Recorded:
    """A run's recorded outputs (CosimResult) seen through the roster: columns by instance and variable, vectors
    over x, y, z, the outputs that feed an instance's inputs, and the library backend's per-step values."""

    def __init__(self, result, roster: Roster):
        self.result, self.roster = result, roster
        self.t = result.t
        self._memo = {}

    def col(self, name: str, variable: str) -> np.ndarray:
        return self.result.columns[f"{name}.{variable}"]

    def vec(self, name: str, fmt: str) -> np.ndarray:
        """(n, 3) of the variables fmt.format(a), a = x, y, z."""
        return np.column_stack([self.result.columns[f"{name}.{fmt.format(a)}"] for a in "xyz"])

    def input_vec(self, name: str, fmt: str) -> np.ndarray:
        """(n, 3) of the inputs fmt.format(a), a = x, y, z: the recorded outputs that feed them (an unconnected
        input stays at its start value 0)."""
        zero = np.zeros_like(self.t, dtype=float)
        sources = [self.roster.source(name, fmt.format(a)) for a in "xyz"]
        return np.column_stack([zero if s is None else self.result.columns[f"{s[0]}.{s[1]}"] for s in sources])

    def extra(self, name: str, key: str):
        """An instance's per-step value of the library backend's record (Role.recorder), or None."""
        return self.result.extra.get(f"{name}.{key}")

    def work_on_target(self, name: str, output: str):
        """(target member, its input, the work (J) done on the target through that input's group) for the input
        ``output`` feeds, or None when it feeds no component that accounts for the work of its inputs."""
        for tgt, inp in self.roster.targets(name, output):
            m = self.roster.member(tgt)
            work = m.role.input_work(m, self, inp)
            if work is not None:
                return m, inp, work
        return None

    def memo(self, key, compute):
        """compute() once per run (terms and diagnostics share what a role derives from the columns)."""
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]
