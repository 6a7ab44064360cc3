"""Robustness of the simulators the FMUs wrap: bounded work (no hangs), early errors naming the input or
parameter at fault, no NaN/inf with an OK status, no stray exception types, and the state of a failed step's
start kept.  Cases that used to hang run in a subprocess with a timeout, so that a regression fails instead of
stalling the suite."""
import json
import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from flexfmu.errors import FlexfmuError, NonFiniteError, ParameterError, StepRejected
from flexfmu.ffr.simulator import INPUT_NAMES as FFR_INPUTS
from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
from flexfmu.wec.hydrostatics import HydrostaticsConfig, HydrostaticsSimulator
from flexfmu.reframe.models import load_model
from flexfmu.wec.platform import PlatformConfig, PlatformSimulator
from flexfmu.wec.pto import PTOConfig, PTOSimulator
from flexfmu.reframe.simulator import INPUT_NAMES as RB_INPUTS
from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
from flexfmu.ffr.scene import load_scene
from flexfmu.wec.wave_excitation import WaveExcitationConfig, WaveExcitationSimulator

from error_bounds import gamma

# the extreme values below overflow on purpose: numpy's warnings on the way to the named error are expected
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning",
                                        "ignore:invalid value encountered:RuntimeWarning")

BEAM = "beam:spatial_double_L"
TIP = dict(load_point_x=0.14, load_point_y=0.15, load_point_z=0.16,   # the free end; the output point at the first
           output_point_x=0.0, output_point_y=0.0, output_point_z=0.0)   # node (points must lie on the body)
#: exception types that must never leave a simulator (the FMU maps only FlexfmuError to a named message)
STRAY = (OverflowError, FloatingPointError, ZeroDivisionError, RecursionError, UnicodeDecodeError)


def bounded(code: str, timeout: float = 90.0) -> dict:
    """Run ``code`` (which sets ``result`` to a callable) in a fresh interpreter; return what it raised:
    {"type", "parameter", "message", "seconds"} ("type" None when it returned), or fail when it does not finish
    within ``timeout`` s."""
    script = textwrap.dedent("""
        import json, time
        result = None
        {code}
        t0 = time.perf_counter()
        try:
            value = result()
            out = {{"type": None, "value": value}}
        except BaseException as exc:
            out = {{"type": type(exc).__name__, "parameter": getattr(exc, "parameter", None), "message": str(exc)}}
        out["seconds"] = time.perf_counter() - t0
        print("RESULT " + json.dumps(out, default=str))
    """).format(code=textwrap.dedent(code))
    try:
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=timeout,
                              env=dict(os.environ))
    except subprocess.TimeoutExpired:
        pytest.fail(f"did not finish within {timeout:g} s (a hang):\n{code}")
    lines = [ln for ln in done.stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, done.stderr[-3000:]
    return json.loads(lines[-1][len("RESULT "):])


# ------------------------------------------------------------------------------- 1. bounded model choice
def test_ffr_auto_modes_with_f_max_above_the_given_mesh_keep_every_mode():
    """n_modes = -1 on a given mesh whose every mode lies below f_max: the complete basis is kept (docs: at most
    the free DOFs), logged as such (no truncation error, the mesh does not resolve f_max) instead of looping."""
    r = bounded("""
        from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
        def result():
            sim = FFRBeamSimulator(FFRBeamConfig(n_modes=-1, f_max=1e6))
            return [sim.model_choice.n_modes, sim.model_choice.n_free, sim.messages]
    """)
    assert r["type"] is None, r
    n_modes, n_free, messages = r["value"]
    assert n_modes == n_free == 144
    text = " ".join(messages)
    assert "no truncation error" in text and "does not resolve" in text and "273656 Hz" in text
    assert "inf" not in text.replace("information", "")
    assert "static correction not needed" in text


@pytest.mark.parametrize("f_max", [3e5, 1e6, 1e8])
def test_ffr_auto_mesh_far_beyond_what_512_elements_resolve_is_refused_quickly(f_max):
    r = bounded(f"""
        from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
        def result():
            FFRBeamSimulator(FFRBeamConfig(n_modes=-1, elements_per_segment=0, f_max={f_max!r}))
    """)
    assert r["type"] == "ParameterError" and r["parameter"] == "f_max", r
    assert r["seconds"] < 5.0, r
    assert "f_max <= about" in r["message"] and "above 2" not in r["message"]


def test_ffr_auto_mesh_with_more_modes_than_it_resolves_names_n_modes():
    r = bounded("""
        from flexfmu.ffr.simulator import FFRBeamConfig, FFRBeamSimulator
        def result():
            FFRBeamSimulator(FFRBeamConfig(n_modes=3000, elements_per_segment=0))
    """)
    assert r["type"] == "ParameterError" and r["parameter"] == "n_modes" and r["seconds"] < 5.0, r
    assert "at most 200 modes" in r["message"]


def test_unreachable_tolerance_states_a_range_that_exists():
    """The refusal's allowed range is one the parameters can take: no "a tolerance above 2" (its range is
    1e-6 .. 0.1)."""
    from flexfmu.ffr.mesh_choice import choose_elements_per_segment
    from flexfmu.sizing.model_size import TOLERANCE_RANGE
    scene = load_scene("spatial_double_L")
    for f_max, tolerance, max_el in ((3e5, 1e-3, 512), (3e4, 1e-3, 4), (300.0, 1e-5, 2), (2e4, 1e-6, 512)):
        with pytest.raises(ParameterError) as exc:
            choose_elements_per_segment(scene, "XFF", f_max, tolerance, max_elements_per_segment=max_el)
        text = str(exc.value)
        assert exc.value.parameter in ("tolerance", "f_max") and "above 2" not in text, text
        for word in text.split("tolerance >= ")[1:]:
            assert float(word.replace("about ", "").split()[0].rstrip(",)")) <= TOLERANCE_RANGE[1], text


def test_reframe_auto_modes_with_f_max_above_every_mode_log_no_truncation_error():
    sim = ReframeBodySimulator(ReframeBodyConfig(model=BEAM, n_flexible_modes=-1, f_max=1e6, **TIP))
    text = sim.messages[0]
    assert "complete modal basis, so there is no truncation error" in text and " is inf" not in text, text
    assert sim.integrator.data.nf == 144


def test_reframe_auto_modes_refuse_a_band_beyond_the_mode_cap_naming_f_max():
    """More flexible modes below f_max than n_flexible_modes = -1 computes (200): refused, not silently cut."""
    from flexfmu.ffr.assembly import build_beam_model
    from flexfmu.sizing.model_size import auto_basis
    structure = build_beam_model(load_scene("spatial_double_L"), "free", 16).structure()     # 288 flexible modes
    with pytest.raises(ParameterError) as exc:
        auto_basis(structure, 1e6, 1e-3, 0.05, 10, 0)
    assert exc.value.parameter == "f_max" and "f_max < 273997 Hz" in exc.value.allowed


# ------------------------------------------------------------------- 2. internal steps: counted, capped
@pytest.mark.parametrize("force", [1e20, 1e300])
def test_reframe_huge_force_is_refused_naming_it_before_stepping(force):
    r = bounded(f"""
        from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
        sim = ReframeBodySimulator(ReframeBodyConfig())
        def result():
            sim.set_inputs(F_x={force!r})
            sim.step(0.01)
    """)
    assert r["type"] == "ParameterError" and r["parameter"] == "F_x" and r["seconds"] < 5.0, r
    assert "angular acceleration" in r["message"] and "max_internal_steps" in r["message"]


@pytest.mark.parametrize("omega", [1e9, 1e300])
def test_reframe_implausible_initial_spin_is_refused_at_construction(omega):
    r = bounded(f"""
        from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
        def result():
            sim = ReframeBodySimulator(ReframeBodyConfig(omega0_1={omega!r}))
            sim.step(0.01)
    """)
    assert r["type"] == "ParameterError" and r["parameter"] == "omega0_1", r
    assert "|omega0| <= 8.891e+08 rad/s" in r["message"]


def test_reframe_long_communication_step_is_rejected_and_a_smaller_one_succeeds():
    """RK4 with 60 flexible modes: a 10 s step needs ~1e6 internal steps (~40 s of CPU before the cap):
    StepRejected, counted before stepping, the state of the step's start kept; the suggested step runs."""
    r = bounded(f"""
        from flexfmu.reframe.simulator import ReframeBodyConfig, ReframeBodySimulator
        sim = ReframeBodySimulator(ReframeBodyConfig(model="{BEAM}", scheme="consistent", n_flexible_modes=60,
                                                     **{TIP!r}))
        sim.set_inputs(F_x=1.0)
        def result():
            sim.step(10.0)
    """)
    assert r["type"] == "StepRejected" and r["parameter"] == "max_internal_steps" and r["seconds"] < 2.0, r
    assert "internal steps for this communication step of 10 s (cap 100000)" in r["message"]
    sim = ReframeBodySimulator(ReframeBodyConfig(model=BEAM, scheme="consistent", n_flexible_modes=60,
                                                 max_internal_steps=50, **TIP))
    sim.set_inputs(F_x=1.0)
    before = sim.get_state()
    with pytest.raises(StepRejected) as exc:
        sim.step(0.01)
    assert sim.get_state() == before
    h_ok = float(str(exc.value).split("(<= ")[1].split(" s)")[0])
    sim.step(h_ok)
    n = sim.internal_steps(h_ok)
    # the kernel accumulates t += h / n over n internal steps: 1 division + n additions of terms <= h
    assert sim.time == pytest.approx(h_ok, rel=gamma(n + 1), abs=0) and n <= 50


def test_exponential_split_count_is_bounded_and_exact():
    """The exponential split is computed in closed form (no loop over the count) and meets its bound."""
    sim = ReframeBodySimulator(ReframeBodyConfig(omega0_3=5e4))
    n = sim.internal_steps(0.1)
    w, a = sim._rates()
    h = 0.1 / n
    assert w * h + 0.5 * a * h * h <= sim._theta_max < w * (0.1 / (n - 1))
    with pytest.raises(StepRejected):
        sim.step(1.0)                                     # 5.6e5 internal steps > 1e5
    assert sim.time == 0.0


def test_ffr_rk4_substeps_are_capped():
    sim = FFRBeamSimulator(FFRBeamConfig(integrator="rk4"))
    sim.set_inputs(F_z=1.0)
    with pytest.raises(StepRejected) as exc:
        sim.step(1e300)                                   # 8e302 sub-steps
    assert exc.value.parameter == "max_internal_steps" and "<= 124.5 s" in str(exc.value)
    small = FFRBeamSimulator(FFRBeamConfig(integrator="rk4", max_internal_steps=10))
    with pytest.raises(StepRejected):
        small.step(0.02)                                  # 17 sub-steps of the 1.38 ms limit
    small.step(0.01)
    assert small.time == 0.01


@pytest.mark.parametrize("config, name", [
    (dict(max_internal_steps=0), "max_internal_steps"), (dict(max_internal_steps=True), "max_internal_steps"),
    (dict(max_internal_steps=1.5), "max_internal_steps"), (dict(max_internal_steps=10**9), "max_internal_steps"),
    (dict(internal_step=1e-12), "internal_step")])
def test_reframe_cap_parameters_are_range_checked(config, name):
    with pytest.raises(ParameterError) as exc:
        ReframeBodySimulator(ReframeBodyConfig(**config))
    assert exc.value.parameter == name and exc.value.allowed and "inf" not in exc.value.allowed


def test_reframe_rk4_model_too_stiff_for_the_cap_is_refused_naming_the_scheme():
    with pytest.raises(ParameterError) as exc:
        ReframeBodySimulator(ReframeBodyConfig(model=BEAM, scheme="consistent", n_flexible_modes=144,
                                               max_internal_steps=1, **TIP))
    assert exc.value.parameter == "scheme" and "exponential" in exc.value.allowed


# --------------------------------------------------------------------------- 3. overflow named, not NaN
def test_ffr_huge_base_rotation_names_it_instead_of_nan_outputs():
    for integrator in ("exact", "rk4"):
        sim = FFRBeamSimulator(FFRBeamConfig(integrator=integrator))
        sim.set_inputs(base_w_x=1e160)
        with pytest.raises(NonFiniteError) as exc:
            sim.output_vector()
        assert exc.value.parameter == "base_w_x"
        with pytest.raises(NonFiniteError) as exc:
            sim.step(1e-3)
        assert exc.value.parameter == "base_w_x" and sim.time == 0.0


def test_ffr_static_correction_energy_overflow_names_the_force():
    sim = FFRBeamSimulator(FFRBeamConfig(static_correction=1))
    sim.set_inputs(F_z=1e200)
    with pytest.raises(NonFiniteError) as exc:
        sim.outputs()
    assert exc.value.parameter == "F_z" and "elastic_energy" in str(exc.value)


def test_ffr_failed_step_keeps_the_state_and_names_the_input():
    sim = FFRBeamSimulator(FFRBeamConfig())
    sim.set_inputs(F_z=1.0)
    sim.step(1e-3)
    before = sim.get_state()
    sim.set_inputs(F_z=1e300)
    with pytest.raises(FlexfmuError) as exc:
        sim.step(1e-3)
    assert exc.value.parameter == "F_z" and "diverged" in str(exc.value)
    after = sim.get_state()
    after["inputs"] = before["inputs"]
    assert after == before
    with pytest.raises(StepRejected) as exc:              # the exact step's transition matrix overflows
        FFRBeamSimulator(FFRBeamConfig()).step(1e300)
    assert exc.value.parameter == "step_size"


def test_reframe_overflow_is_named_not_nan():
    sim = ReframeBodySimulator(ReframeBodyConfig(scheme="consistent"))
    sim.set_inputs(F_x=1e300)
    before = sim.get_state()
    with pytest.raises(NonFiniteError) as exc:
        sim.step(0.01)
    assert exc.value.parameter == "F_x"
    after = sim.get_state()
    assert after["t"] == before["t"] and after["position"] == before["position"] and after["eta"] == before["eta"]
    sim = ReframeBodySimulator(ReframeBodyConfig(scheme="paper", internal_step=1e-4, v0_x=1e300))
    with pytest.raises(NonFiniteError) as exc:
        sim.step(1e-2)
    assert exc.value.parameter == "v0_x"


@pytest.mark.parametrize("make, inputs, name", [
    (lambda: HydrostaticsSimulator(HydrostaticsConfig()), {"pos_z": 1e305}, "pos_z"),
    (lambda: PTOSimulator(PTOConfig()), {"v_x": 1e200}, "v_x")])
def test_wave_converter_output_overflow_names_the_input(make, inputs, name):
    sim = make()
    sim.set_inputs(**inputs)
    with pytest.raises(NonFiniteError) as exc:
        sim.outputs()
    assert exc.value.parameter == name


def test_platform_failed_step_keeps_the_state():
    sim = PlatformSimulator(PlatformConfig())
    sim.set_inputs(wave_F_z=1.0)
    sim.step(0.1)
    before = sim.get_state()
    sim.set_inputs(wave_F_z=1e308, pto_F_x=1e308)
    with pytest.raises(NonFiniteError) as exc:
        sim.step(0.1)
    assert exc.value.parameter in ("wave_F_z", "pto_F_x")
    after = sim.get_state()
    after["inputs"] = before["inputs"]
    assert after == before


EXTREMES = (1e300, -1e300, 1e154, 1e-300)


def _sweep(make, names, setter="set_inputs"):
    """Every input at extreme values: either finite outputs, or a FlexfmuError with the state kept."""
    for name in names:
        for value in EXTREMES:
            sim = make()
            getattr(sim, setter)(**{name: value})
            before = sim.get_state()
            try:
                out = sim.outputs()
                assert all(math.isfinite(v) for v in out.values()), (name, value, out)
                sim.step(1e-3)
                out = sim.outputs()
                assert all(math.isfinite(v) for v in out.values()), (name, value, out)
            except FlexfmuError as exc:
                assert exc.parameter, (name, value, exc)
            except STRAY as exc:
                pytest.fail(f"{name} = {value:g}: {type(exc).__name__}: {exc}")
            else:
                continue
            if sim.get_state()["t"] == before["t"]:
                assert sim.get_state() == before


def test_extreme_inputs_never_give_nan_or_a_stray_exception():
    _sweep(lambda: FFRBeamSimulator(FFRBeamConfig(static_correction=1)), FFR_INPUTS)
    _sweep(lambda: FFRBeamSimulator(FFRBeamConfig(integrator="rk4")), FFR_INPUTS[9:15])
    _sweep(lambda: ReframeBodySimulator(ReframeBodyConfig(model=BEAM, n_flexible_modes=4, **TIP)), RB_INPUTS)
    _sweep(lambda: ReframeBodySimulator(ReframeBodyConfig()), RB_INPUTS[:3])
    _sweep(lambda: HydrostaticsSimulator(HydrostaticsConfig()), HydrostaticsSimulator.INPUTS)
    _sweep(lambda: PlatformSimulator(PlatformConfig()), ("wave_F_x", "payload_M_z", "pto_F_y"))
    _sweep(lambda: PTOSimulator(PTOConfig()), PTOSimulator.INPUTS)


# ------------------------------------------------------------------------------------- 4. files
@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bad_scenes")
    scene = json.loads((load_scene.__globals__["resources"].files("flexfmu") / "scenes" /
                        "spatial_double_L.json").read_text())
    files = {"deep": "[" * 200_000 + "]" * 200_000, "empty": "", "blank": "  \n", "not_json": "{points: 1}",
             "overflow": json.dumps({**scene, "points": [[0, 0, 0], [1e308, 1e308, 0]]}),
             "huge_int": json.dumps(scene).replace("0.16]", "1" + "0" * 400 + "]", 1),
             "long_int": json.dumps(scene).replace("0.16]", "1" + "0" * 5000 + "]", 1)}
    paths = {}
    for name, text in files.items():
        paths[name] = folder / f"{name}.json"
        paths[name].write_text(text, encoding="utf-8")
    paths["latin1"] = folder / "latin1.json"
    paths["latin1"].write_bytes(json.dumps({**scene, "name": "x"}).replace('"x"', '"caf\\u00e9"').encode()
                                .replace(b"\\u00e9", b"\xe9"))
    paths["directory"] = folder / "a_directory.json"
    paths["directory"].mkdir()
    paths["missing"] = folder / "missing.json"
    paths["long_name"] = "a" * 5000
    paths["npz_empty"] = folder / "empty.npz"
    paths["npz_empty"].write_bytes(b"")
    paths["npz_text"] = folder / "text.npz"
    paths["npz_text"].write_text("not a zip")
    paths["npz_dir"] = folder / "dir.npz"
    paths["npz_dir"].mkdir()
    return paths


SCENE_CASES = ["deep", "empty", "blank", "not_json", "overflow", "huge_int", "long_int", "latin1", "directory",
               "missing", "long_name"]


@pytest.mark.parametrize("case", SCENE_CASES)
def test_bad_scene_files_are_parameter_errors_naming_the_parameter(bad_files, case):
    path = str(bad_files[case])
    for make, name in ((lambda: FFRBeamSimulator(FFRBeamConfig(scene=path)), "scene"),
                       (lambda: ReframeBodySimulator(ReframeBodyConfig(model="beam:" + path)), "model")):
        try:
            make()
        except ParameterError as exc:
            text = str(exc)
            assert len(text) < 600 and "inf m" not in text, text
            if case != "overflow" and case != "huge_int":
                assert exc.parameter == name, text
        except STRAY as exc:
            pytest.fail(f"{case}: {type(exc).__name__}: {exc}")
        else:
            pytest.fail(f"{case}: accepted")


@pytest.mark.parametrize("case", ["npz_empty", "npz_text", "npz_dir", "missing"])
def test_bad_npz_models_are_parameter_errors_naming_model(bad_files, case):
    path = str(bad_files[case]) if case != "missing" else str(bad_files[case]).replace(".json", ".npz")
    with pytest.raises(ParameterError) as exc:
        load_model(path)
    assert exc.value.parameter == "model", str(exc.value)


def test_scene_errors_describe_the_file(bad_files):
    messages = {}
    for case in ("deep", "latin1", "empty", "directory", "overflow"):
        with pytest.raises(ParameterError) as exc:
            load_scene(bad_files[case])
        messages[case] = str(exc.value)
    assert "too deeply" in messages["deep"] and "not UTF-8" in messages["latin1"] and "0xe9" in messages["latin1"]
    assert "is empty" in messages["empty"] and "is a directory" in messages["directory"]
    assert messages["overflow"].startswith("points[1]") and "<= inf" not in messages["overflow"]


# ------------------------------------------------------------------------------ 5.-6. every config field
BAD_CONFIGS = [
    (FFRBeamSimulator, FFRBeamConfig, dict(damping_ratio="0.1"), "damping_ratio"),
    (FFRBeamSimulator, FFRBeamConfig, dict(f_max=True), "f_max"),
    (FFRBeamSimulator, FFRBeamConfig, dict(tolerance=True), "tolerance"),
    (FFRBeamSimulator, FFRBeamConfig, dict(scene=123), "scene"),
    (FFRBeamSimulator, FFRBeamConfig, dict(scene=["x"]), "scene"),
    (FFRBeamSimulator, FFRBeamConfig, dict(boundary=["XFF"]), "boundary"),
    (FFRBeamSimulator, FFRBeamConfig, dict(sensor_s=float("inf")), "sensor_s"),
    (FFRBeamSimulator, FFRBeamConfig, dict(load_s="tip"), "load_s"),
    (FFRBeamSimulator, FFRBeamConfig, dict(integrator=["rk4"]), "integrator"),
    (FFRBeamSimulator, FFRBeamConfig, dict(n_modes=True), "n_modes"),
    (FFRBeamSimulator, FFRBeamConfig, dict(max_internal_steps=0), "max_internal_steps"),
    (FFRBeamSimulator, FFRBeamConfig, dict(max_internal_steps=False), "max_internal_steps"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(n_flexible_modes=True), "n_flexible_modes"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(force_follows_body=1), "force_follows_body"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(tolerance=1e-12), "tolerance"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(scheme=["exponential"]), "scheme"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(damping_ratio="x"), "damping_ratio"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(model=None), "model"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(f_max=True), "f_max"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(internal_step=-1.0), "internal_step"),
    (ReframeBodySimulator, ReframeBodyConfig, dict(internal_step=float("inf")), "internal_step"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(seed=-1), "seed"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(seed=True), "seed"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(gamma=0.5), "gamma"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(n_components=0), "n_components"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(n_components=True), "n_components"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(depth=0.1), "depth"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(length=True), "length"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(length="1"), "length"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(sea_state=1), "sea_state"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(wave_period=1e-300), "wave_period"),
    (WaveExcitationSimulator, WaveExcitationConfig, dict(rho=1e300, g=1e10), "rho"),
    (HydrostaticsSimulator, HydrostaticsConfig, dict(zeta_heave=True), "zeta_heave"),
    (HydrostaticsSimulator, HydrostaticsConfig, dict(rho=-1.0), "rho"),
    (HydrostaticsSimulator, HydrostaticsConfig, dict(length="1"), "length"),
    (HydrostaticsSimulator, HydrostaticsConfig, dict(rho=1e300, length=1e100), "rho"),
    (PlatformSimulator, PlatformConfig, dict(draft=0.0), "draft"),
    (PlatformSimulator, PlatformConfig, dict(mount_x=True), "mount_x"),
    (PlatformSimulator, PlatformConfig, dict(rho=1e300, length=1e100), "rho"),
    (PTOSimulator, PTOConfig, dict(damping=-1.0), "damping"),
    (PTOSimulator, PTOConfig, dict(damping=True), "damping"),
    (PTOSimulator, PTOConfig, dict(axis_x="1"), "axis_x"),
]


@pytest.mark.parametrize("sim, config, values, name", BAD_CONFIGS,
                         ids=[f"{c.__name__}-{next(iter(v))}={v[next(iter(v))]!r}"[:60] for _, c, v, _ in BAD_CONFIGS])
def test_every_config_field_is_checked_naming_it(sim, config, values, name):
    try:
        sim(config(**values))
    except ParameterError as exc:
        assert exc.parameter == name and exc.allowed, str(exc)
        assert "<= inf" not in str(exc) and ".. inf" not in str(exc)
    except STRAY + (TypeError, ValueError) as exc:
        pytest.fail(f"{type(exc).__name__}: {exc}")
    else:
        pytest.fail(f"{values} accepted")


def test_pto_axis_of_any_length_is_a_direction():
    sim = PTOSimulator(PTOConfig(axis_x=1e308, axis_y=1e308))
    # axis / max|axis| = (1, 1, 0) exactly, its norm fl(sqrt 2) (1 rounding), the division (1); 2 ** -0.5 from
    # libm pow within 1 ulp (<= 2 u): gamma(4), the zero component exactly 0
    np.testing.assert_allclose(sim.axis, [2 ** -0.5, 2 ** -0.5, 0.0], rtol=gamma(4), atol=0)


def test_numpy_error_mode_raise_gives_named_errors_not_floating_point_errors():
    """Another FMU in the same interpreter may set numpy's error mode to raise: still a named error (or a
    normal result), never a FloatingPointError."""
    with np.errstate(all="raise"):
        sim = FFRBeamSimulator(FFRBeamConfig(static_correction=1))
        sim.set_inputs(F_z=1.0)
        sim.step(1e-3)
        assert np.all(np.isfinite(sim.output_vector()))
        sim.set_inputs(F_z=1e200)
        with pytest.raises(NonFiniteError):
            sim.output_vector()
        body = ReframeBodySimulator(ReframeBodyConfig(scheme="consistent"))
        body.set_inputs(F_x=1e300)
        with pytest.raises(NonFiniteError):
            body.step(0.01)
        pto = PTOSimulator(PTOConfig())
        pto.set_inputs(v_x=1e200)
        with pytest.raises(NonFiniteError):
            pto.outputs()


@pytest.mark.parametrize("bad", ["x", 10 ** 400])
def test_inputs_that_are_not_floats_are_named(bad):
    """A string or an int too large for a float: ParameterError naming the input (not TypeError/OverflowError)."""
    for sim, n in ((FFRBeamSimulator(FFRBeamConfig()), len(FFR_INPUTS)),
                   (ReframeBodySimulator(ReframeBodyConfig()), len(RB_INPUTS))):
        for call in (lambda: sim.set_input_vector([bad] + [0.0] * (n - 1)), lambda: sim.set_inputs(F_x=bad)):
            with pytest.raises(ParameterError) as exc:
                call()
            assert exc.value.parameter == "F_x" and len(str(exc.value)) < 300
    with pytest.raises(ParameterError) as exc:
        HydrostaticsSimulator(HydrostaticsConfig()).set_inputs(pos_x=bad)
    assert exc.value.parameter == "pos_x"


@pytest.mark.parametrize("section", [{"shape": "circle", "diameter": 1e100},
                                     {"shape": "tube", "outer_diameter": 1e100, "inner_diameter": 0.0},
                                     {"shape": "rectangle", "width": 1e200, "height": 1e200}])
def test_scene_section_overflow_is_named(section):
    from flexfmu.ffr.scene import scene_from_dict
    with pytest.raises(ParameterError) as exc:
        scene_from_dict({"points": [[0, 0, 0], [1, 0, 0]], "section": section,
                         "material": {"E": 2e11, "nu": 0.3, "rho": 7850}})
    assert exc.value.parameter == "section"
