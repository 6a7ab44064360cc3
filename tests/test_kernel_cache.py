"""The compiled reframe kernels are cached by source content, so an FMU's freshly extracted copy of
flexfmu reuses them instead of recompiling (25-50 s) in every new folder."""
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
    beam = build_beam_model(load_scene("spatial_double_L"), "free", 2).structure()
    integ = ReframeIntegrator(beam, modal_basis(beam, 2))
    loads = integ.prepare_loads(PointLoad(0, constant_load([1.0, 0.0, 0.0])))
    state = integ.advance(integ.state, 1e-4, loads)
    integ.snapshot(state, loads, integ.point_indices([0]))
    stats = k.consistent_steps.stats
    print(json.dumps({"hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
                      "path": stats.cache_path}))
""")


@pytest.mark.skipif(not _reframe_kernels.NUMBA, reason="numba not installed: kernels run as numpy")
def test_relocated_copy_of_the_package_hits_the_kernel_cache(tmp_path):
    import json
    results = []
    for copy in ("first", "second"):   # two extraction folders, as two FMU instantiations would make
        root = tmp_path / copy
        shutil.copytree(Path(flexfmu.__file__).parent, root / "flexfmu",
                        ignore=shutil.ignore_patterns("__pycache__"))
        out = subprocess.run([sys.executable, "-c", RUN, str(root)], capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, out.stderr
        results.append(json.loads(out.stdout.strip().splitlines()[-1]))
    second = results[1]
    assert second["misses"] == 0 and second["hits"] > 0, results
    assert str(tmp_path) not in second["path"], "the cache must not live in the extraction folder"
