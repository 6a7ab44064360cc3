"""The pythonfmu side of a Python-runtime FMU (flexfmu.fmi.slave): one protocol for every FMU spec, one slave
script, readable in the FMU, whose do_step refuses to run outside the flexfmu runtime."""
from __future__ import annotations

import importlib.util
import typing
import zipfile

import pytest

from flexfmu.fmi import registry
from flexfmu.fmi.body_fmu import ExportedSpec
from flexfmu.fmi.slave import FmuModel, slave_script


def protocol_members() -> set[str]:
    names = set(typing.get_type_hints(FmuModel))
    names |= {n for n, v in vars(FmuModel).items() if not n.startswith("_") and (callable(v) or isinstance(v, property))}
    return names


@pytest.mark.parametrize("spec_class", [registry.FmuSpec, ExportedSpec])
def test_both_kinds_of_spec_follow_the_one_protocol(spec_class):
    fields = set(spec_class.__dataclass_fields__)
    missing = [n for n in protocol_members() if n not in fields and not hasattr(spec_class, n)]
    assert not missing, f"{spec_class.__name__} lacks {missing}"
    assert {"config_class", "make_simulator", "slave_source", "variable_info"} <= protocol_members()


def test_every_registry_entry_is_an_fmu_model_and_its_script_compiles():
    for spec in registry.FMUS:
        assert isinstance(spec, FmuModel), spec.name
        compile(slave_script(spec), f"{spec.name}.py", "exec")


def test_the_script_is_in_the_fmu_and_its_do_step_refuses_to_run_outside_the_runtime(fmus, tmp_path):
    """pythonfmu's own binary would call do_step: it must not return as if the model had stepped."""
    with zipfile.ZipFile(fmus["FFRBeam"]) as zf:
        loaded = zf.read("resources/FFRBeam.py").decode()
        readable = zf.read("documentation/FFRBeam_slave.py").decode()
    assert loaded == readable == slave_script(registry.BY_NAME["FFRBeam"])
    path = tmp_path / "FFRBeam.py"
    path.write_text(loaded)
    spec = importlib.util.spec_from_file_location("ffrbeam_slave_script", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with pytest.raises(RuntimeError, match="built for the flexfmu runtime"):
        module.FFRBeam.do_step(None, 0.0, 1e-3)
