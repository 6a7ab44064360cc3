"""What an FMU of one user's flexible body (flexfmu.body.FlexBody) is, whichever runtime builds it: its spec for
flexfmu.fmi.plumbing, the checks of its name, its default experiment and its documentation page.  Both builders
import it: the Python runtime's (flexfmu.fmi.export, also the entry point that hands ``runtime="native"`` on) and
the native one's (flexfmu.fmi.native), which so imports nothing of flexfmu.fmi.export: the imports go one way.
"""
from __future__ import annotations

import html
import keyword
import re
from dataclasses import dataclass, field
from pathlib import Path

from flexfmu.errors import ParameterError

__all__ = ["BODY_FILE", "SHAPE_FILE", "ExportedSpec", "exported_spec", "check_model_identifier", "check_target",
           "default_experiment", "documentation_html", "shape_html", "shape_resource"]

#: the model's file name inside the FMU's resources/ (a Python FMU's; a native one carries its own model file)
BODY_FILE = "flexfmu_body.npz"
#: the shape file's name inside the FMU's resources/ (the nodes, cells, shapes Psi and nodal stress shapes S: what
#: flexfmu animate draws the deformed body from, with the outputs q_1 .. q_n); either runtime's FMU of a solid
SHAPE_FILE = "shape.npz"            # flexfmu.body.shape_file.FMU_SHAPE_MEMBER: resources/shape.npz


@dataclass(frozen=True)
class ExportedSpec:
    """An FMU of one FlexBody (a flexfmu.fmi.slave.FmuModel, as flexfmu.fmi.registry.FmuSpec)."""

    name: str
    description: str
    body: object                      # flexfmu.body.FlexBody
    experiment: dict = field(default_factory=dict)

    @property
    def _simulator_module(self):
        from flexfmu.body import simulator
        return simulator

    @property
    def config_class(self):
        return self._simulator_module.config_class(self.body)

    @property
    def input_names(self) -> tuple:
        return tuple(self._simulator_module.input_names(self.body))

    @property
    def output_names(self) -> tuple:
        return tuple(self._simulator_module.output_names(self.body))

    @property
    def variable_info(self) -> dict:
        return self._simulator_module.variable_info(self.body)

    @property
    def deferred_outputs(self) -> tuple:
        return tuple(self._simulator_module.deferred_outputs(self.body))

    def make_simulator(self, config):
        return self._simulator_module.FlexBodySimulator(self.body, config)

    def slave_source(self) -> tuple[str, str]:
        """The slave finds its body in the FMU's resources folder."""
        return ("from flexfmu.fmi.body_fmu import exported_spec",
                f"exported_spec(resources, {self.name!r}, {self.description!r})")


def exported_spec(resources: str, name: str, description: str) -> ExportedSpec:
    """The spec of an exported FMU whose resources folder is ``resources``."""
    from flexfmu.body.model import FlexBody

    return ExportedSpec(name, description, FlexBody.load(Path(resources) / BODY_FILE))


def check_model_identifier(name: str) -> str:
    """``name`` if it can be an FMU's modelIdentifier (a C and Python identifier), else ParameterError."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,63}", name or "") or keyword.iskeyword(name):
        raise ParameterError("output", f"model name {name!r} (the .fmu file's stem)",
                             "a letter, then letters, digits or _ (at most 64), e.g. Bracket.fmu")
    return name


def check_target(target) -> str:
    """The model identifier of the FMU file ``target`` (``NAME.fmu``), or ParameterError."""
    target = Path(target)
    if target.suffix != ".fmu":
        raise ParameterError("output", f"{str(target)!r}", "a file name ending in .fmu, e.g. Bracket.fmu")
    return check_model_identifier(target.stem)


def default_experiment(body) -> dict:
    """Start 0, stop 1 s, and a communication step of 1/20 of the first natural period (at most 1 ms), rounded
    down to 1, 2 or 5 x 10^k s.  The simulator splits a step internally as its modes need, so the step only
    has to sample the motion a master wants to see."""
    import math

    f_1 = float(body.natural_frequencies_hz[0]) if len(body.natural_frequencies_hz) else 0.0
    step = 1e-3 if not f_1 > 0 else min(1e-3, 0.05 / f_1)
    exponent = math.floor(math.log10(step))
    mantissa = max(m for m in (1, 2, 5) if m * 10.0**exponent <= step * (1 + 1e-12))
    return {"startTime": "0", "stopTime": "1", "stepSize": f"{mantissa}e{exponent}"}


def documentation_html(name: str, body) -> str:
    """documentation/index.html: the model, its source, its reduction, the variables."""
    from flexfmu.body import simulator

    info = simulator.variable_info(body)
    rows = "\n".join(f"<tr><td><code>{html.escape(v)}</code></td><td>{html.escape(info[v][0])}</td>"
                     f"<td>{html.escape(info[v][1])}</td></tr>" for v in info)
    summary = "\n".join(f"<li>{html.escape(line)}</li>" for line in body.describe())
    shape = shape_html(body)
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(name)}</title></head>
<body>
<h1>{html.escape(name)}</h1>
<p>A flexible body exported by flexfmu (FMI 2.0 co-simulation). The reduced model is
<code>resources/{BODY_FILE}</code>; the FMU needs no other file.</p>{shape}
<h2>Model, source and reduction</h2>
<ul>
{summary}
</ul>
<h2>Variables</h2>
<table border="1" cellspacing="0" cellpadding="3">
<tr><th>name</th><th>unit</th><th>description</th></tr>
{rows}
</table>
</body></html>
"""


def shape_html(body) -> str:
    """The documentation's paragraph on ``resources/shape.npz`` for a body that carries one (its shape data), else
    ""; both runtimes' pages say it."""
    if not getattr(body, "shape_data", None):
        return ""
    return (f"\n<p><code>resources/{SHAPE_FILE}</code> holds the undeformed nodes (m, body frame), the cells, the "
            "shapes Psi and the averaged nodal stress shapes S of the coordinates q_1 ... q_n (outputs): the "
            "displacement of every node is u = Psi q and its stress sigma = S q (<code>flexfmu animate</code> draws "
            "them).</p>")


def shape_resource(body, folder: Path) -> tuple[Path, ...]:
    """(the shape file written in ``folder``,) for a body built with its shape data (build_body(with_shapes=True)
    on a solid with cells), else (): the one writer of both runtimes' shape files (flexfmu.fmi.export,
    flexfmu.fmi.native put it into resources/)."""
    data = getattr(body, "shape_data", None)
    if not data:
        return ()
    from flexfmu.body.shape_file import write_shape_file
    path = Path(folder) / SHAPE_FILE
    write_shape_file(path, data["nodes"], data["cells"], data["Psi"], data["S"], data["names"],
                     header={"body": data["name"]})
    return (path,)
