"""Model size limits (flexfmu.core.checks: MAX_BEAM_DOFS, FLEXFMU_MAX_DOFS, --max-dofs) of the beam models: FFRBeam,
ReframeBody's beam:<scene> and flexfmu modal of a scene (tests/test_modal_large_models.py: model files).

The limits are decisions on counted sizes, tested as such (no wall time): a model above the limit is refused before
it is built, naming its size, the limit and the override, and the work it would have done is shown not to start
(the builder replaced by one that fails the test).  The size a check counts is compared with the size of the model
actually built.
"""
from __future__ import annotations

import json

import pytest

from flexfmu.core.checks import MAX_BEAM_DOFS, MAX_DOFS_ENV, dof_limit
from flexfmu.errors import ParameterError

STEEL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}


def zigzag_scene(path, n_segments, diameter=0.01, last_point=None):
    points = [[0.08 * i, 0.06 * (i % 2), 0.0] for i in range(n_segments + 1)]
    if last_point is not None:
        points[-1] = last_point
    path.write_text(json.dumps({"name": "zigzag", "points": points, "section": {"shape": "circle",
                                "diameter": diameter}, "material": STEEL, "clamps": [0.0]}))
    return path


@pytest.fixture
def no_env_limit(monkeypatch):
    monkeypatch.delenv(MAX_DOFS_ENV, raising=False)


def forbid(monkeypatch, target: str, what: str):
    """Replace ``target`` (module.attribute) by a function failing the test: the work must not start."""
    def refuse(*args, **kwargs):
        pytest.fail(f"{what} started although the model is above the limit")
    monkeypatch.setattr(target, refuse)


# ------------------------------------------------------------------------------------------- the limit itself
def test_limit_default_environment_and_option(monkeypatch, no_env_limit):
    assert dof_limit(MAX_BEAM_DOFS).limit == MAX_BEAM_DOFS
    monkeypatch.setenv(MAX_DOFS_ENV, "1234")
    assert dof_limit(MAX_BEAM_DOFS).limit == 1234
    assert dof_limit(MAX_BEAM_DOFS, 99, "--max-dofs").limit == 99          # the option wins
    for bad in ("abc", "0", "-5", "1e3"):
        monkeypatch.setenv(MAX_DOFS_ENV, bad)
        with pytest.raises(ParameterError, match=MAX_DOFS_ENV):
            dof_limit(MAX_BEAM_DOFS)
    with pytest.raises(ParameterError, match="--max-dofs"):
        dof_limit(MAX_BEAM_DOFS, 0, "--max-dofs")


def test_the_message_names_size_limit_and_override(no_env_limit):
    limit = dof_limit(100, None, "--max-dofs")
    limit.check(100, "a model", "MODEL", "a coarser mesh")                  # at the limit: allowed
    with pytest.raises(ParameterError) as info:
        limit.check(101, "a model", "MODEL", "a coarser mesh")
    text = str(info.value)
    assert info.value.parameter == "MODEL"
    assert "101 DOFs" in text and "100 DOFs" in text and "--max-dofs" in text and MAX_DOFS_ENV in text


def test_counted_dofs_are_the_built_models(no_env_limit):
    from flexfmu.ffr.assembly import boundary_clamps, build_beam_model
    from flexfmu.ffr.scene import beam_model_dofs, load_scene

    scene = load_scene("spatial_double_L")
    for n_el, extra in ((1, ()), (8, (0.45, 0.04)), (5, (0.1234,))):
        for boundary in ("XFF", "FXF_mid", "scene"):
            clamps = boundary_clamps(scene, boundary)
            built = build_beam_model(scene, boundary, n_el, extra_arc_lengths=extra)
            counted = beam_model_dofs(scene, n_el, tuple(extra) + tuple(clamps))
            # an upper bound, exact unless an extra node falls on an existing one (merged)
            assert built.n_dof <= counted <= built.n_dof + 6 * (len(extra) + len(clamps))


# ------------------------------------------------------------------------------------------- FFRBeam
def test_ffrbeam_refuses_a_scene_above_the_limit_before_building(tmp_path, monkeypatch, no_env_limit):
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    n_segments = MAX_BEAM_DOFS // 48 + 1                    # 8 elements x 6 DOFs per segment: just above
    scene = zigzag_scene(tmp_path / "long.json", n_segments)
    forbid(monkeypatch, "flexfmu.ffr.ffrbeam_build.build_beam_model", "FFRBeam's model")
    with pytest.raises(ParameterError) as info:
        FFRBeamSimulator(FFRBeamConfig(scene=str(scene)))
    assert info.value.parameter == "scene"
    text = str(info.value)
    assert f"{n_segments} segments" in text and f"{MAX_BEAM_DOFS:,} DOFs" in text and MAX_DOFS_ENV in text


def test_ffrbeam_counts_segments_before_checking_every_point(tmp_path, no_env_limit):
    """A scene of 10^5 segments whose last point is bad is refused for its size: the points were not checked one
    by one first (that took 30 s for a million points)."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    scene = zigzag_scene(tmp_path / "huge.json", 100_000, last_point=["x", 0, 0])
    with pytest.raises(ParameterError, match="100000 segments") as info:
        FFRBeamSimulator(FFRBeamConfig(scene=str(scene)))
    assert info.value.parameter == "scene"


def test_ffrbeam_limit_from_the_environment(monkeypatch):
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator

    # spatial_double_L (3 segments) at 40 elements per segment: 6 x (3 x 40 + 1 + 2) = 738 DOFs and more
    monkeypatch.setenv(MAX_DOFS_ENV, "700")
    forbid(monkeypatch, "flexfmu.ffr.ffrbeam_build.build_beam_model", "FFRBeam's model")
    with pytest.raises(ParameterError, match="700 DOFs") as info:
        FFRBeamSimulator(FFRBeamConfig(elements_per_segment=40, n_modes=3))
    assert info.value.parameter == "scene" and MAX_DOFS_ENV in str(info.value)
    monkeypatch.undo()
    monkeypatch.setenv(MAX_DOFS_ENV, "1000")                     # raised: built (f_1 is reported)
    assert FFRBeamSimulator(FFRBeamConfig(elements_per_segment=40, n_modes=3)).frequencies_hz[0] > 0


def test_ffrbeam_automatic_mesh_stops_at_the_limit(monkeypatch):
    """elements_per_segment = 0: each candidate mesh is checked before it is built; a band that needs a mesh above
    the limit is refused naming f_max."""
    from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
    from flexfmu.ffr.scene import beam_model_dofs, load_scene

    scene = load_scene("spatial_double_L")
    built = []
    import flexfmu.ffr.mesh_choice as mesh_choice

    original = mesh_choice.build_beam_model

    def recording(scene_, boundary, n_el, **kwargs):
        model = original(scene_, boundary, n_el, **kwargs)
        built.append(model.n_dof)
        return model

    monkeypatch.setattr(mesh_choice, "build_beam_model", recording)
    limit = beam_model_dofs(scene, 8, (0.45, 0.04, 0.0))          # room for the first meshes, not for a fine one
    monkeypatch.setenv(MAX_DOFS_ENV, str(limit))
    with pytest.raises(ParameterError) as info:
        FFRBeamSimulator(FFRBeamConfig(elements_per_segment=0, n_modes=6, f_max=3000.0, tolerance=1e-6))
    assert info.value.parameter == "f_max" and f"{limit:,} DOFs" in str(info.value)
    assert built and max(built) <= limit


# ------------------------------------------------------------------------------------------- ReframeBody
def test_reframebody_refuses_a_beam_scene_above_the_limit(tmp_path, monkeypatch, no_env_limit):
    from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator

    scene = zigzag_scene(tmp_path / "long.json", MAX_BEAM_DOFS // 48 + 1)
    forbid(monkeypatch, "flexfmu.ffr.assembly.build_beam_model", "ReframeBody's beam model")
    at_origin = dict(load_point_x=0.0, load_point_y=0.0, load_point_z=0.0, output_point_x=0.0, output_point_y=0.0,
                     output_point_z=0.0)
    with pytest.raises(ParameterError) as info:
        ReframeBodySimulator(ReframeBodyConfig(model=f"beam:{scene}", **at_origin))
    assert info.value.parameter == "model" and f"{MAX_BEAM_DOFS:,} DOFs" in str(info.value)


# ------------------------------------------------------------------------------------------- flexfmu modal
def run_cli(capsys, *args):
    from flexfmu.cli import main

    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_modal_of_a_scene_refuses_a_long_scene(tmp_path, capsys, monkeypatch, no_env_limit):
    scene = zigzag_scene(tmp_path / "long.json", MAX_BEAM_DOFS // 12 + 1)   # 2 elements x 6 DOFs per segment
    forbid(monkeypatch, "flexfmu.ffr.report.build_beam_model", "the refinement")
    code, out, err = run_cli(capsys, "modal", scene)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "scene:" in err and f"{MAX_BEAM_DOFS:,} DOFs" in err and "--max-dofs" in err


def test_modal_of_a_scene_stops_refining_at_the_limit(tmp_path, capsys):
    """The refinement doubles the mesh until converged; below a limit it stops at the last mesh that fits and says
    so (table and JSON), every model built within the limit."""
    from flexfmu.ffr.report import modal_analysis
    from flexfmu.ffr.scene import load_scene

    scene = load_scene("spatial_double_L")
    full = modal_analysis(scene, "XFF", n_modes=6)
    assert full.converged and full.elements_per_segment >= 8          # needs 8 or more elements per segment
    limit = full.model.n_dof - 1                                       # the converged mesh does not fit
    code, out, err = run_cli(capsys, "modal", "spatial_double_L", "--boundary", "XFF", "--json",
                             "--max-dofs", limit)
    result = json.loads(out)
    assert code == 0 and not result["converged"]
    assert result["elements_per_segment"] == full.elements_per_segment // 2
    assert result["n_dof_unconstrained"] <= limit and "--max-dofs" in result["refinement_stopped"]
    code, out, err = run_cli(capsys, "modal", "spatial_double_L", "--boundary", "XFF", "--max-dofs", limit)
    assert code == 0 and "not refined beyond" in out
