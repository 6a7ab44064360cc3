"""The two kinds of reduced body are classes (flexfmu.body.model: FreeBody, ClampedBody): FlexBody.load returns the
class a file's header names, files written before the kinds were classes load (the file format is unchanged), a
kind's load refuses the other kind's file, and the kind cannot be rebound.

The files in tests/reference/body_files/ were written by flexfmu at commit 0ed88ee, when the kind was a string field
(generate.py there)."""
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from flexfmu.body.model import ClampedBody, FlexBody, FreeBody
from flexfmu.body.simulator import FlexBodySimulator
from flexfmu.errors import ParameterError

FILES = Path(__file__).parent / "reference" / "body_files"
KINDS = {"free": FreeBody, "clamped": ClampedBody}


def _contents(path):
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


@pytest.mark.parametrize("kind", list(KINDS))
def test_a_file_written_before_the_classes_loads_as_its_class_and_saves_the_same_content(kind, tmp_path):
    path = FILES / f"{kind}_rod.npz"
    body = FlexBody.load(path)
    assert type(body) is KINDS[kind] and body.kind == kind
    assert type(KINDS[kind].load(path)) is KINDS[kind]
    before, after = _contents(path), _contents(body.save(tmp_path / "again.npz"))
    assert sorted(before) == sorted(after)
    assert json.loads(str(before.pop("header"))) == json.loads(str(after.pop("header")))
    for key, value in before.items():
        assert value.dtype == after[key].dtype and np.array_equal(value, after[key]), key


def test_each_kind_has_its_own_inputs_outputs_and_parameters():
    free, clamped = FlexBody.load(FILES / "free_rod.npz"), FlexBody.load(FILES / "clamped_rod.npz")
    assert free.input_names() == ("tip.F_x", "tip.F_y", "tip.F_z", "tip.M_x", "tip.M_y", "tip.M_z")
    assert clamped.input_names()[6:] == tuple(f"base_{q}_{a}" for q in ("a", "w", "dw") for a in "xyz")
    assert "max_elastic_displacement" in free.output_names() and free.deferred_outputs == ("max_elastic_displacement",)
    assert clamped.output_names()[9:15] == tuple(f"reaction_{q}_{a}" for q in "FM" for a in "xyz")
    assert clamped.deferred_outputs == ()
    assert "scheme" in free.variable_info() and "scheme" not in clamped.variable_info()
    for body in (free, clamped):
        sim = FlexBodySimulator(body)
        assert type(sim.config) is body.config_class and type(sim.engine) is body.engine_class
        sim.step(1e-3)
        assert np.all(np.isfinite(sim.output_vector()))
        assert list(sim.outputs()) == list(body.output_names())


def test_a_kind_refuses_the_other_kinds_file_naming_it():
    path = FILES / "clamped_rod.npz"
    with pytest.raises(ParameterError, match=r"clamped_rod\.npz: a clamped body \(allowed: a free body"):
        FreeBody.load(path)
    with pytest.raises(ParameterError, match=r"free_rod\.npz: a free body \(allowed: a clamped body"):
        ClampedBody.load(FILES / "free_rod.npz")


def test_the_kind_is_the_class_and_read_only():
    body = FlexBody.load(FILES / "free_rod.npz")
    with pytest.raises(AttributeError, match="read-only"):
        body.kind = "clamped"
    assert body.kind == "free" and FreeBody.kind == "free" and ClampedBody.kind == "clamped"
    fields = {f.name: getattr(body, f.name) for f in dataclasses.fields(body)}
    assert "kind" not in fields
    with pytest.raises(TypeError, match="no kind"):
        FlexBody(**fields)
    assert type(dataclasses.replace(body, name="other")) is FreeBody


def test_a_free_body_has_no_linear_form():
    sim = FlexBodySimulator(FlexBody.load(FILES / "free_rod.npz"))
    with pytest.raises(ParameterError, match="body: a free body"):
        sim.lti_probe()
