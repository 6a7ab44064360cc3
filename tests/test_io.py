""".npz structural model files (flexfmu.core.io): round trip, exact keys, and every rejected input."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from flexfmu.errors import ParameterError
from flexfmu.core.io import REQUIRED_KEYS, load_structure, save_structure, validate_structure
from flexfmu.reframe.plate import paper_plate
from flexfmu.core.structure import Structure


def six_dof_structure(n_nodes: int = 4) -> Structure:
    """Small 6-DOF model: lumped translational mass and rotary inertia, a random SPD K."""
    rng = np.random.default_rng(7)
    n_dof = 6 * n_nodes
    mdiag = np.tile([2.0, 2.0, 2.0, 1e-3, 2e-3, 3e-3], n_nodes)
    B = rng.standard_normal((n_dof, n_dof))
    K = B @ B.T * 1e3
    K[np.abs(K) < 500.0] = 0.0                      # make it genuinely sparse, still symmetric
    return Structure(nodes=rng.random((n_nodes, 3)), dofs_per_node=6, M=sp.diags(mdiag).tocsr(),
                     K=sp.csr_matrix(K), name="six")


@pytest.fixture(scope="module")
def plate():
    return paper_plate((6, 1, 1))


def _arrays(structure: Structure) -> dict:
    d = {"nodes": structure.nodes, "dofs_per_node": np.array(structure.dofs_per_node)}
    for key in ("M", "K"):
        A = sp.csr_matrix(getattr(structure, key))
        d[f"{key}_data"], d[f"{key}_indices"] = A.data.copy(), A.indices.copy()
        d[f"{key}_indptr"], d[f"{key}_shape"] = A.indptr.copy(), np.array(A.shape)
    return d


# --------------------------------------------------------------------------- round trip
@pytest.mark.parametrize("which", ["plate", "six"])
def test_round_trip(which, plate, tmp_path):
    s = plate if which == "plate" else six_dof_structure()
    path = save_structure(tmp_path / "model.npz", s)
    assert path == tmp_path / "model.npz"
    back = load_structure(path)
    assert back.dofs_per_node == s.dofs_per_node
    assert back.name == "model"
    np.testing.assert_array_equal(back.nodes, s.nodes)
    for key in ("M", "K"):
        A, B = getattr(s, key), getattr(back, key)
        assert sp.isspmatrix_csr(B) or isinstance(B, sp.csr_array)
        assert abs(A - B).max() == 0.0      # exact: a save/load round trip copies the bits
        assert abs(B - B.T).max() == 0.0    # exact: paper_plate symmetrises as (A + A^T) / 2 (commutative addition)


def test_file_has_exactly_the_required_keys(plate, tmp_path):
    path = save_structure(tmp_path / "plate", plate)           # suffix added
    assert path.name == "plate.npz"
    with np.load(path) as npz:
        assert sorted(npz.files) == sorted(REQUIRED_KEYS)
        assert npz["nodes"].shape == (plate.n_nodes, 3)
        assert int(npz["dofs_per_node"]) == 3
        assert tuple(npz["M_shape"]) == tuple(npz["K_shape"]) == (plate.n_dof, plate.n_dof)
        M = sp.csr_matrix((npz["M_data"], npz["M_indices"], npz["M_indptr"]), shape=tuple(npz["M_shape"]))
    # DOF order node by node: the x-DOFs carry the whole x-translation mass
    tx = np.zeros(plate.n_dof)
    tx[0::3] = 1.0
    from error_bounds import U, gamma
    from test_plate import _form_bound      # the P2 mass's rounding bound (Gram-term scale, roundings per entry)
    assert abs(tx @ (M @ tx) - 9.35) <= _form_bound(M, tx) + (gamma(3) + U) * 9.35


def test_small_asymmetry_is_accepted_and_symmetrised(tmp_path):
    s = six_dof_structure()
    d = _arrays(s)
    d["K_data"][1] *= 1 + 1e-12
    np.savez(tmp_path / "m.npz", **d)
    K = load_structure(tmp_path / "m.npz").K
    assert abs(K - K.T).max() == 0.0      # exact: the loader symmetrises as (K + K^T) / 2 (commutative addition)


# --------------------------------------------------------------------------- bad files
def _break(d, key, value):
    d[key] = value


def _del(d, key):
    del d[key]


def _poke(d, key, index, value):
    d[key] = d[key].astype(float) if key.endswith("_data") else d[key].copy()
    d[key][index] = value


def _offdiag_index(d, key):
    """Index into key_data of a stored off-diagonal entry (row != column)."""
    ptr, ind = d[key + "_indptr"], d[key + "_indices"]
    rows = np.repeat(np.arange(ptr.size - 1), np.diff(ptr))
    return int(np.flatnonzero(rows != ind)[0])


BAD_CASES = {
    "missing M_data": (lambda d: _del(d, "M_data"), "M_data"),
    "missing K_indptr": (lambda d: _del(d, "K_indptr"), "K_indptr"),
    "missing nodes": (lambda d: _del(d, "nodes"), "nodes"),
    "unknown key": (lambda d: _break(d, "C_data", np.zeros(3)), "C_data"),
    "nodes N x 2": (lambda d: _break(d, "nodes", d["nodes"][:, :2]), "nodes"),
    "nodes NaN": (lambda d: _poke(d, "nodes", (0, 1), np.nan), "nodes"),
    "one node too few": (lambda d: _break(d, "nodes", d["nodes"][:-1]), "M_shape"),
    "dofs_per_node 4": (lambda d: _break(d, "dofs_per_node", np.array(4)), "dofs_per_node"),
    "dofs_per_node 3.5": (lambda d: _break(d, "dofs_per_node", np.array(3.5)), "dofs_per_node"),
    "dofs_per_node vector": (lambda d: _break(d, "dofs_per_node", np.array([6, 6])), "dofs_per_node"),
    "dofs_per_node 3 for a 6-DOF model": (lambda d: _break(d, "dofs_per_node", np.array(3)), "M_shape"),
    "M_shape wrong": (lambda d: _break(d, "M_shape", d["M_shape"] + 1), "M_shape"),
    "K_shape non-square": (lambda d: _break(d, "K_shape", np.array([24, 23])), "K_shape"),
    "K_indptr too short": (lambda d: _break(d, "K_indptr", d["K_indptr"][:-1]), "K_indptr"),
    "K_indptr does not end at nnz": (lambda d: _poke(d, "K_indptr", -1, 3), "K_indptr"),
    "K_indices out of range": (lambda d: _poke(d, "K_indices", 0, 10_000), "K_indices"),
    "K_indices negative": (lambda d: _poke(d, "K_indices", 0, -1), "K_indices"),
    "M_indices length": (lambda d: _break(d, "M_indices", d["M_indices"][:-1]), "M_indices"),
    "M_data NaN": (lambda d: _poke(d, "M_data", 0, np.nan), "M_data"),
    "K_data inf": (lambda d: _poke(d, "K_data", 3, np.inf), "K_data"),
    "K non-symmetric": (lambda d: _poke(d, "K_data", _offdiag_index(d, "K"), 1e9), "K_data"),
    "M negative diagonal": (lambda d: _poke(d, "M_data", 3, -1e-3), "M_data"),
    "K negative diagonal": (lambda d: _break(d, "K_data", np.where(
        d["K_indices"] == np.repeat(np.arange(24), np.diff(d["K_indptr"])), -d["K_data"], d["K_data"])), "K_data"),
    "M mass differs by direction": (lambda d: _poke(d, "M_data", 0, 3.0), "M_data"),
    "M zero": (lambda d: _break(d, "M_data", np.zeros_like(d["M_data"])), "M_data"),
}


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_bad_file_names_the_key(case, tmp_path):
    mutate, key = BAD_CASES[case]
    d = _arrays(six_dof_structure())
    mutate(d)
    np.savez(tmp_path / "bad.npz", **d)
    with pytest.raises(ParameterError) as err:
        load_structure(tmp_path / "bad.npz")
    assert err.value.parameter == key, str(err.value)
    assert err.value.allowed


def test_missing_and_unreadable_file(tmp_path):
    with pytest.raises(ParameterError) as err:
        load_structure(tmp_path / "nope.npz")
    assert err.value.parameter == "path"
    (tmp_path / "junk.npz").write_text("not a zip file")
    with pytest.raises(ParameterError) as err:
        load_structure(tmp_path / "junk.npz")
    assert err.value.parameter == "path"


def test_save_validates_the_structure(tmp_path):
    s = six_dof_structure()
    K = s.K.tolil()
    K[0, 1] += 1.0e6
    with pytest.raises(ParameterError) as err:
        save_structure(tmp_path / "x.npz", Structure(s.nodes, 6, s.M, K.tocsr()))
    assert err.value.parameter == "structure.K"
    assert not (tmp_path / "x.npz").exists()
    with pytest.raises(ParameterError) as err:
        validate_structure(Structure(s.nodes, 6, s.M[:-6, :-6], s.K))
    assert err.value.parameter == "structure.M"
