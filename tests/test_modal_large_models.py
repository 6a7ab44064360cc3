"""flexfmu modal of large solid models: the size check before a mesh is assembled (flexfmu.core.checks.MAX_SOLID_DOFS,
--max-dofs, FLEXFMU_MAX_DOFS), the sparse block Lanczos solver of held solids (flexfmu.linalg.sparse_modes) and
its progress line.

The limits are decisions on counted sizes, tested as such (no wall time): the assembly is replaced by a function that
fails the test, so a refusal is shown to come first.  The Lanczos modes are compared with a dense scipy eigh of the
same matrices, within the residual bound of each returned pair (Kahan: an eigenvalue lies within |r|_{M^-1} of the
Rayleigh quotient of an M-normalised vector) plus the dense solve's round-off.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from flexfmu.core import checks
from flexfmu.core.checks import MAX_DOFS_ENV, dof_limit
from flexfmu.errors import ParameterError
from test_model_size_limits import STEEL, forbid, run_cli

meshio = pytest.importorskip("meshio")


@pytest.fixture
def no_env_limit(monkeypatch):
    monkeypatch.delenv(MAX_DOFS_ENV, raising=False)


def tet_box(path, divisions, clamp_set=False):
    from test_importers import box_mesh

    points, cells = box_mesh("tetra", divisions, (1.0, 0.25, 0.25))
    sets = {"clamp": np.flatnonzero(points[:, 0] == 0.0)} if clamp_set else {}
    meshio.write(path, meshio.Mesh(points, [("tetra", cells)], point_sets=sets))
    return path, len(points)


def test_modal_of_a_mesh_is_refused_before_assembly(tmp_path, capsys, monkeypatch, no_env_limit):
    path, nodes = tet_box(tmp_path / "box.vtu", (8, 2, 2))
    forbid(monkeypatch, "flexfmu.importers.build.assemble", "the assembly")
    code, out, err = run_cli(capsys, "modal", path, "--material", "2.1e11,0.3,7850", "--max-dofs", 3 * nodes - 1)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert f"{3 * nodes:,} DOFs" in err and f"{nodes:,} nodes" in err and "--max-dofs" in err
    monkeypatch.setenv(MAX_DOFS_ENV, str(3 * nodes - 1))          # the environment, when no option is given
    code, out, err = run_cli(capsys, "modal", path, "--material", "2.1e11,0.3,7850")
    assert code == 2 and MAX_DOFS_ENV in err


def test_modal_refuses_an_assembled_model_file_above_the_limit(tmp_path, capsys):
    from flexfmu.core.io import save_structure
    from flexfmu.importers import load_structure

    path, nodes = tet_box(tmp_path / "box.vtu", (8, 2, 2))
    npz = save_structure(tmp_path / "box.npz", load_structure(path, material=STEEL))
    code, out, err = run_cli(capsys, "modal", npz, "--max-dofs", 3 * nodes - 1)
    assert code == 2 and f"{3 * nodes:,} DOFs" in err


def test_limits_outside_flexfmu_modal_leave_the_importers_alone(tmp_path):
    """The library assembles any size: the importers' check acts only inside model_size_limit."""
    from flexfmu.importers import load_structure

    path, nodes = tet_box(tmp_path / "box.vtu", (8, 2, 2))
    assert load_structure(path, material=STEEL).n_dof == 3 * nodes
    with checks.model_size_limit(dof_limit(10, 10, "--max-dofs"), "MODEL", "a coarser mesh"):
        with pytest.raises(ParameterError, match="MODEL"):
            load_structure(path, material=STEEL)


# ------------------------------------------------------------------------------------------- held solids: Lanczos
def held_box(tmp_path, divisions=(16, 4, 4)):
    from flexfmu.importers import load_structure

    path, _ = tet_box(tmp_path / "held.inp", divisions, clamp_set=True)
    return load_structure(path, material=STEEL)


def test_clamped_modes_of_a_large_model_take_block_lanczos(tmp_path, monkeypatch):
    """Above the dense cut-off a clamped model's modes come from flexfmu.linalg.sparse_modes, not ARPACK's eigsh
    (which took 212 s on a clamped box of 56k DOFs), and agree with a dense eigh of the same matrices."""
    from flexfmu.body.modes import natural_modes
    from flexfmu.linalg.cutoffs import BEAM_MODES_DENSE_MAX_DOF

    s = held_box(tmp_path)
    clamp = s.node_sets["clamp"]
    fixed = (3 * clamp[:, None] + np.arange(3)).ravel()
    free = np.setdiff1d(np.arange(s.n_dof), fixed)
    assert free.size > BEAM_MODES_DENSE_MAX_DOF
    forbid(monkeypatch, "flexfmu.linalg.modal.solve_modes", "ARPACK's eigsh path")
    modes = natural_modes(s, clamp="clamp", n_modes=6)
    K, M = s.K[free][:, free].toarray(), s.M[free][:, free].toarray()
    reference = sla.eigh(K, M, eigvals_only=True, subset_by_index=[0, 5])
    lam = (2 * np.pi * modes.frequencies_hz) ** 2
    phi = modes.shapes[free]
    residual = K @ phi - M @ phi * lam
    kahan = np.sqrt(np.einsum("ij,ij->j", residual, np.linalg.solve(M, residual)))   # |r|_{M^-1}, phi^T M phi = 1
    np.testing.assert_allclose(np.einsum("ij,ij->j", phi, M @ phi), 1.0, rtol=1e-12)
    from error_bounds import gamma
    n = K.shape[0]
    # |A|_2 <= |A|_1 for symmetric A; the smallest eigenvalue of M by a one-value eigvalsh
    m_min = sla.eigvalsh(M, subset_by_index=[0, 0])[0]
    dense = 2 * gamma(n * n) * (np.abs(K).sum(0).max() + reference * np.abs(M).sum(0).max()) / m_min
    assert np.all(np.abs(lam - reference) <= kahan + dense), (lam, reference, kahan, dense)


def test_lanczos_modes_refuse_a_structure_that_is_not_held(tmp_path):
    from flexfmu.linalg.sparse_modes import lanczos_modes

    s = held_box(tmp_path, (8, 2, 2))                       # no clamp: six zero-energy (rigid-body) modes
    with pytest.raises(RuntimeError, match="zero-energy|factorised"):
        lanczos_modes(s.K, s.M, 6)


def test_the_solve_shows_its_progress(tmp_path, monkeypatch, capsys):
    """progress=True: the count of converged modes on stderr (a line per tenth in a log, after the delay, here 0)."""
    import flexfmu.core.progress as progress
    from flexfmu.linalg.sparse_modes import lanczos_modes

    s = held_box(tmp_path, (8, 2, 2))
    clamp = s.node_sets["clamp"]
    free = np.setdiff1d(np.arange(s.n_dof), (3 * clamp[:, None] + np.arange(3)).ravel())
    K, M = s.K[free][:, free], s.M[free][:, free]
    lanczos_modes(K, M, 4)
    assert capsys.readouterr().err == ""                   # off by default
    monkeypatch.setattr(progress, "DEFAULT_DELAY_S", 0.0)
    lanczos_modes(K, M, 4, progress=True, label="modes")
    err = capsys.readouterr().err
    assert "modes: 100 % (4 of 4 modes" in err
