"""FMI Cross-Check packages (flexfmu.fmi.cross_check, ``flexfmu cross-check``): the tree of FFRBeam, ReframeBody and
the bracket of examples/bracket exported clamped, FMI 2.0 and 3.0, co-simulation and model exchange, generated once
(the ``package`` fixture), passes fmpy's cross-check validator with no problem, holds what the rules ask, and fmpy
simulating each FMU with its _in.csv and _ref.opt reproduces its _ref.csv (the flexfmu library's result).

Bounds.  Co-simulation: CS_RTOL per variable, relative to its largest magnitude over the record.  The FMU and the
reference step the same discrete model (the native kind's C code, the library's simulator), whose agreement
docs/fmu.md states as 1e-10 relative in every output (the native FMU against the Python FMU, which steps the same
library simulator through the same flexfmu.fmi.plumbing as the reference here; tests/test_fmu_native.py); the
package adds no error: the FMU gets exactly the held input values the reference was stepped with (the staircase
rows of _in.csv) and every number of the CSVs reads back as the same double.  Model exchange: the reference is the
exact solution of the ODE under the held inputs (the LTI kind's zero-order-hold step), fmpy's CVode approximates it
to its tolerance: the rules' comparison (fmpy's validate_result) must pass at the _ref.opt's RelTol, and a 100 times
tighter tolerance must bring fmpy at least 10 times closer (CVode's error control keeps the global error roughly
proportional to the tolerance; a factor 10 leaves a wide margin for its order changes)."""
from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.cross_check import validate_result
from fmpy.util import read_csv, read_ref_opt_file

from flexfmu.cli import main
from flexfmu.errors import ParameterError
from flexfmu.fmi import cross_check
from flexfmu.fmi.cross_check import BRACKET, MODELS, binary_folders, generate, rule_problems, validate

# fmpy.cross_check imports scipy.ndimage.filters, which SciPy deprecates: not ours to fix
pytestmark = [pytest.mark.fmu, pytest.mark.filterwarnings("ignore:Please import:DeprecationWarning")]

CS_RTOL = 1e-10
ME_MODELS = ("FFRBeam", "BracketClamped")          # the ODE kinds; ReframeBody's reframe kind is a stepping method


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    if not BRACKET.is_file():
        pytest.skip("examples/bracket is not in this checkout")
    out = tmp_path_factory.mktemp("cross-check")
    return out, generate(out, interfaces=("cs", "me"))


def model_folders(out: Path, interface: str = "*", version: str = "*", platform: str = "*") -> list[Path]:
    return sorted(p for p in (out / "fmus").glob(f"{version}/{interface}/{platform}/flexfmu/*/*") if p.is_dir())


def fmpy_run(folder: Path, **options):
    """fmpy simulating the folder's FMU as fmpy.cross_check does (the _ref.opt's step and stop time, the _in.csv),
    in the folder's interface; (result at the reference's times, reference, options)."""
    name = folder.name
    opt, reference = read_ref_opt_file(str(folder / f"{name}_ref.opt")), read_csv(str(folder / f"{name}_ref.csv"))
    me = folder.parents[3].name == "me"
    result = simulate_fmu(str(folder / f"{name}.fmu"), validate=False, step_size=opt["StepSize"],
                          stop_time=opt["StopTime"], input=read_csv(str(folder / f"{name}_in.csv")),
                          output=list(reference.dtype.names[1:]), fmi_type="ModelExchange" if me else "CoSimulation",
                          **options)
    assert validate_result(result=result, reference=reference, t_start=opt["StartTime"], t_stop=opt["StopTime"]) \
        is None
    # model exchange records t_k before and after an input's jump: the reference's row is the one before
    rows = np.searchsorted(result["time"], reference["time"] - 1e-9 * opt["StepSize"])
    np.testing.assert_allclose(result["time"][rows], reference["time"], rtol=0, atol=1e-12)
    return result[rows], reference, opt


def relative_differences(result, reference) -> dict:
    return {v: float(np.max(np.abs(result[v] - reference[v]))) / float(np.max(np.abs(reference[v])))
            for v in reference.dtype.names[1:]}


# ---------------------------------------------------------------------------------------------- the tree
def test_fmpys_validator_finds_no_problem(package):
    from fmpy.cross_check.validate_vendor_repo import validate_repo

    out, report = package
    assert report.problems == []
    count, problems = validate(out)
    folders = model_folders(out)
    assert problems == [] and count == len(folders) == len(report.folders)
    # fmpy's validate_repo alone, as the cross-check repository's CI ran it: FMI 2.0 and the rules' platforms
    _, _, problems = validate_repo(str(out))
    assert problems == []
    names = {(f.name, f.parents[3].name) for f in folders}
    assert names == {(m, "cs") for m in MODELS} | {(m, "me") for m in ME_MODELS}


def test_what_was_left_out_is_said(package):
    _, report = package
    for version in ("2.0", "3.0"):
        assert any(note.startswith(f"ReframeBody: FMI {version} me skipped:") and "co-simulation only" in note
                   for note in report.notes), report.notes
    for folder in report.folders:
        if folder.parents[4].name == "2.0" and "aarch64-linux" in binary_folders(folder / f"{folder.name}.fmu"):
            assert any("aarch64-linux: the cross-check rules name no FMI 2.0 platform" in n for n in report.notes)


def test_the_folders_hold_what_the_rules_ask(package):
    out, _ = package
    fmus = {}
    for folder in model_folders(out):
        name, platform, interface, version = folder.name, folder.parents[2].name, folder.parents[3].name, \
            folder.parents[4].name
        files = {p.name for p in folder.iterdir()}
        assert files == {f"{name}.fmu", f"{name}_in.csv", f"{name}_ref.csv", f"{name}_ref.opt", "README.md"}
        assert all((folder / f).stat().st_size <= (10e6 if f.endswith(".fmu") else 1e6) for f in files)
        fmu = folder / f"{name}.fmu"
        md = read_model_description(str(fmu))
        assert md.fmiVersion == version and (md.modelExchange if interface == "me" else md.coSimulation)
        assert platform in binary_folders(fmu)          # the FMI version's names: linux64 in 2.0, x86_64-linux in 3.0
        fmus.setdefault((version, interface, name), set()).add(hashlib.sha256(fmu.read_bytes()).hexdigest())
        opt = read_ref_opt_file(str(folder / f"{name}_ref.opt"))
        reference, inputs = read_csv(str(folder / f"{name}_ref.csv")), read_csv(str(folder / f"{name}_in.csv"))
        assert float(md.defaultExperiment.stepSize) == opt["StepSize"] == opt["OutputIntervalLength"]
        assert reference["time"][0] == opt["StartTime"] and reference["time"][-1] == pytest.approx(opt["StopTime"])
        assert len(reference) <= 1001 and len(reference.dtype.names) - 1 <= 10
        assert set(inputs.dtype.names[1:]) == {v.name for v in md.modelVariables if v.causality == "input"}
        # every reference variable moves: a comparison of zeros would prove nothing
        assert all(np.ptp(reference[v]) > 0 for v in reference.dtype.names[1:])
    # one FMU per FMI version and interface, copied into each of its platform folders
    assert all(len(hashes) == 1 for hashes in fmus.values())
    assert {f.parents[2].name for f in model_folders(out, version="2.0")} >= {"linux64"}
    assert {f.parents[2].name for f in model_folders(out, version="3.0")} >= {"x86_64-linux"}


# ---------------------------------------------------------------------------------------------- the results
@pytest.mark.parametrize("version", ["2.0", "3.0"])
@pytest.mark.parametrize("model", list(MODELS))
def test_fmpy_reproduces_the_reference_in_co_simulation(package, model, version):
    out, report = package
    (folder,) = [f for f in model_folders(out, "cs", version) if f.name == model and f.parents[2].name in
                 ("linux64", "x86_64-linux")]
    result, reference, _ = fmpy_run(folder)
    difference = relative_differences(result, reference)
    worst = max(difference, key=difference.get)
    print(f"\n{model} FMI {version} cs: {len(reference)} samples of {len(difference)} variables, worst relative "
          f"difference {difference[worst]:.2e} ({worst})")
    assert difference[worst] <= CS_RTOL, difference


@pytest.mark.parametrize("version", ["2.0", "3.0"])
@pytest.mark.parametrize("model", ME_MODELS)
def test_fmpy_converges_to_the_reference_in_model_exchange(package, model, version):
    out, _ = package
    (folder,) = [f for f in model_folders(out, "me", version) if f.name == model and f.parents[2].name in
                 ("linux64", "x86_64-linux")]
    opt = read_ref_opt_file(str(folder / f"{model}_ref.opt"))
    worst = {}
    for rel_tol in (opt["RelTol"], opt["RelTol"] / 100):
        result, reference, _ = fmpy_run(folder, relative_tolerance=rel_tol)
        worst[rel_tol] = max(relative_differences(result, reference).values())
    print(f"\n{model} FMI {version} me: worst relative difference {worst}")
    assert worst[opt["RelTol"] / 100] <= worst[opt["RelTol"]] / 10, worst


def test_the_bound_tells_a_one_percent_error(package):
    """The co-simulation bound is no formality: inputs 1 % too strong (a linear model: every output 1 % off) fail it
    by orders of magnitude, while the rules' comparison (a band of 10 % of each signal's range) lets them pass."""
    out, _ = package
    (folder,) = [f for f in model_folders(out, "cs", "2.0", "linux64") if f.name == "FFRBeam"]
    reference = read_csv(str(folder / "FFRBeam_ref.csv"))
    inputs = read_csv(str(folder / "FFRBeam_in.csv"))
    for name in inputs.dtype.names[1:]:
        inputs[name] *= 1.01
    result = simulate_fmu(str(folder / "FFRBeam.fmu"), step_size=1e-4, stop_time=0.05, input=inputs,
                          output=list(reference.dtype.names[1:]))
    assert validate_result(result=result, reference=reference, t_start=0.0, t_stop=0.05) is None
    assert min(relative_differences(result, reference).values()) > 1e3 * CS_RTOL


# ---------------------------------------------------------------------------------------------- the checks can fail
def test_the_validators_find_a_damaged_folder(package, tmp_path):
    out, _ = package
    (folder,) = [f for f in model_folders(out, "cs", "2.0", "linux64") if f.name == "FFRBeam"]
    copy = tmp_path / folder.relative_to(out)
    shutil.copytree(folder, copy)
    ref = copy / "FFRBeam_ref.csv"
    ref.write_text(ref.read_text().replace('"tip_u_x"', '"tip_u_q"', 1))
    (copy / "README.md").unlink()
    (copy / "FFRBeam_in.csv").write_text("\n".join(line.rsplit(",", 1)[0] for line in
                                                  (copy / "FFRBeam_in.csv").read_text().splitlines()) + "\n")
    count, problems = validate(tmp_path)
    assert count == 1 and len(problems) == 1 and "Variable 'tip_u_q' does not exist in the FMU" in problems[0]
    found = rule_problems(copy)
    assert any("no README.md" in p for p in found) and any("does not hold exactly the FMU's inputs" in p
                                                           for p in found)


# ---------------------------------------------------------------------------------------------- the command
def test_bad_input_is_refused_before_any_build(tmp_path, capsys):
    for options, parameter in [({"models": ("Beam",)}, "model"), ({"fmi_versions": (4,)}, "fmi-version"),
                               ({"interfaces": ("se",)}, "interface"), ({"platforms": ("sparc64",)}, "platform"),
                               ({"models": ()}, "model")]:
        with pytest.raises(ParameterError, match=f"^{parameter}: .*allowed: "):
            generate(tmp_path, **options)
    (tmp_path / "file").write_text("")
    with pytest.raises(ParameterError, match="^out_dir: "):
        generate(tmp_path / "file")
    with pytest.raises(SystemExit) as exc:
        main(["cross-check", str(tmp_path), "--platform", "sparc64"])
    assert exc.value.code == 2 and "--platform" in capsys.readouterr().err
    assert not (tmp_path / "fmus").exists()


def test_the_command_writes_and_validates(package, tmp_path, capsys):
    assert main(["cross-check", str(tmp_path), "--model", "FFRBeam", "--fmi-version", "3",
                 "--platform", "x86_64-linux"]) == 0
    printed = capsys.readouterr().out
    assert "fmpy's cross-check validator: 0 problem(s) in 1 model folder(s)" in printed
    assert "FFRBeam FMI 3 cs: fmpy reproduces the reference to" in printed
    assert [f.relative_to(tmp_path).parts[:4] for f in model_folders(tmp_path)] == [
        ("fmus", "3.0", "cs", "x86_64-linux")]
    assert cross_check.TOOL == model_folders(tmp_path)[0].parents[1].name


def test_model_exchange_is_skipped_with_a_note_where_the_builder_has_no_interface(tmp_path, monkeypatch):
    """A builder without the ``interface`` parameter (as before model exchange): "me" is left out with a note
    naming it, nothing is built, and "cs" is unaffected."""
    def build_registry_fmu(name, settings=None, *, target=None, fmi_version=2):
        raise AssertionError("built")

    assert not cross_check.accepts_interface(build_registry_fmu)
    assert cross_check.accepts_interface(lambda name, *, interface="cs": None)
    monkeypatch.setattr(cross_check, "_builder", lambda model: build_registry_fmu)
    report = generate(tmp_path, models=("FFRBeam",), fmi_versions=(2, 3), interfaces=("me",))
    assert report.folders == [] and report.problems == [] and report.validated == 0
    assert report.notes == [f"FFRBeam: FMI {v} me skipped: flexfmu.fmi.native.build_registry_fmu builds "
                            "co-simulation FMUs only" for v in ("2.0", "3.0")]
