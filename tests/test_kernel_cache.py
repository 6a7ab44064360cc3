"""The compiled reframe kernels (the C library of flexfmu/native/csrc, flexfmu.native.compiler) are cached by
source content, so an FMU's freshly extracted copy of flexfmu reuses them instead of recompiling in every new
folder."""
import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import flexfmu
from flexfmu.reframe import kernels as _reframe_kernels

RUN = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, sys.argv[1])
    import flexfmu
    assert flexfmu.__file__.startswith(sys.argv[1]), flexfmu.__file__
    from flexfmu.ffr.assembly import build_beam_model
    from flexfmu.linalg.modal_basis import modal_basis
    from flexfmu.reframe.integrator import PointLoad, ReframeIntegrator, constant_load
    from flexfmu.ffr.scene import load_scene
    from flexfmu.reframe import kernels as k
    from flexfmu.native import reframe as native
    beam = build_beam_model(load_scene("spatial_double_L"), "free", 2).structure()
    integ = ReframeIntegrator(beam, modal_basis(beam, 2))
    loads = integ.prepare_loads(PointLoad(0, constant_load([1.0, 0.0, 0.0])))
    state = integ.advance(integ.state, 1e-4, loads)
    integ.snapshot(state, loads, integ.point_indices([0]))
    assert k.NATIVE and k.consistent_steps is native.consistent_steps, k.NATIVE_REASON
    print(json.dumps({"path": native.library()._name}))
""")


@pytest.mark.skipif(not _reframe_kernels.NATIVE, reason="C kernels not available: kernels run as numpy")
def test_relocated_copy_of_the_package_reuses_the_compiled_kernels(tmp_path):
    cache = tmp_path / "cache"                    # a fresh cache: the first copy compiles, the second must not
    env = dict(os.environ, FLEXFMU_CACHE_DIR=str(cache))
    results = []
    stats = []
    for copy in ("first", "second"):   # two extraction folders, as two FMU instantiations would make
        root = tmp_path / copy
        shutil.copytree(Path(flexfmu.__file__).parent, root / "flexfmu",
                        ignore=shutil.ignore_patterns("__pycache__"))
        out = subprocess.run([sys.executable, "-c", RUN, str(root)], capture_output=True, text=True, timeout=600,
                             env=env)
        assert out.returncode == 0, out.stderr
        results.append(json.loads(out.stdout.strip().splitlines()[-1]))
        st = os.stat(results[-1]["path"])
        stats.append((st.st_ino, st.st_mtime_ns))
    first, second = results
    assert first["path"] == second["path"], results
    assert stats[0] == stats[1], "the second copy rebuilt the library"
    assert Path(second["path"]).is_relative_to(cache / "native")
    assert not Path(second["path"]).is_relative_to(tmp_path / "second"), "the cache must be outside the extraction"
