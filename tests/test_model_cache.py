"""On-disk cache of models and modal bases (flexfmu.core.cache): hits equal fresh results, changed inputs
miss, bad files and failed writes never leak into results."""
import numpy as np
import pytest

from flexfmu.core import cache
from flexfmu.errors import ParameterError
from flexfmu.linalg.modal_basis import modal_basis
from flexfmu.reframe.models import load_model
from flexfmu.reframe.plate import paper_plate
from flexfmu.core.structure import Structure

DIVISIONS = (10, 2, 1)          # 945 DOFs: the sparse path, a fraction of a second


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("FLEXFMU_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("FLEXFMU_CACHE", raising=False)
    return tmp_path / "models"


def entries(folder, kind):
    return sorted(folder.glob(f"{kind}-*.npz")) if folder.is_dir() else []


def assert_same_basis(a, b):
    np.testing.assert_array_equal(a.shapes, b.shapes)
    np.testing.assert_array_equal(a.stiffness, b.stiffness)
    np.testing.assert_array_equal(a.rigid_transform, b.rigid_transform)
    assert (a.mass, a.method) == (b.mass, b.method)
    np.testing.assert_array_equal(a.inertia, b.inertia)


def test_basis_hit_equals_fresh_computation(cache_dir):
    plate = paper_plate(DIVISIONS)
    fresh = modal_basis(plate, 8, cache=False)
    assert entries(cache_dir, "modal_basis") == []
    first = modal_basis(plate, 8, cache=True)               # miss: computes and stores
    assert len(entries(cache_dir, "modal_basis")) == 1
    hit = modal_basis(paper_plate(DIVISIONS), 8, cache=True)   # an equal structure built again
    assert_same_basis(first, hit)
    # against the uncached computation: identity (the same solver code on the same matrices in this process; the
    # cache stores the doubles unchanged), so the same numbers bit for bit, and the same subspace
    np.testing.assert_array_equal(hit.frequencies_hz, fresh.frequencies_hz)
    overlap = np.abs(fresh.shapes.T @ (plate.M @ hit.shapes))
    np.testing.assert_allclose(overlap, np.eye(14), atol=1e-9)


def test_damping_is_applied_after_the_lookup(cache_dir):
    plate = paper_plate(DIVISIONS)
    a = modal_basis(plate, 4, 0.05, cache=True)
    b = modal_basis(plate, 4, [0.01, 0.02, 0.03, 0.04], cache=True)
    assert len(entries(cache_dir, "modal_basis")) == 1          # one entry serves both
    np.testing.assert_array_equal(a.shapes, b.shapes)
    np.testing.assert_allclose(b.damping[6:], 2 * np.array([0.01, 0.02, 0.03, 0.04]) * b.omega, rtol=1e-15)
    np.testing.assert_allclose(a.damping[6:], 2 * 0.05 * a.omega, rtol=1e-15)


def test_changed_parameters_miss(cache_dir):
    plate = paper_plate(DIVISIONS)
    base = modal_basis(plate, 6, cache=True)
    more = modal_basis(plate, 7, cache=True)                    # another number of modes
    heavier = paper_plate(DIVISIONS, corner_mass=2.0)           # another model parameter
    other = modal_basis(heavier, 6, cache=True)
    shifted = modal_basis(plate, 6, sigma=-2.0, cache=True)     # another solver setting
    assert len(entries(cache_dir, "modal_basis")) == 4
    assert more.n_flexible == 7 and base.n_flexible == 6
    # the heavier corners lower the frequencies: a stale hit would have returned the first basis
    assert np.all(other.frequencies_hz < base.frequencies_hz)
    # identity: the cached entry was computed by the same code on the same matrices in this process
    np.testing.assert_array_equal(other.frequencies_hz, modal_basis(heavier, 6, cache=False).frequencies_hz)
    # another shift is another computation (not the cached bits), equal to the solver's accuracy
    # (~1e-9 on the lowest mode, see test_modal_basis)
    assert not np.array_equal(shifted.shapes, base.shapes)
    np.testing.assert_allclose(shifted.frequencies_hz, base.frequencies_hz, rtol=1e-8)


def test_flexfmu_version_is_part_of_the_key(cache_dir, monkeypatch):
    plate = paper_plate(DIVISIONS)
    modal_basis(plate, 4, cache=True)
    monkeypatch.setattr(cache, "__version__", "999.0")
    modal_basis(plate, 4, cache=True)
    assert len(entries(cache_dir, "modal_basis")) == 2


def test_corrupt_and_truncated_entries_are_recomputed(cache_dir):
    plate = paper_plate(DIVISIONS)
    good = modal_basis(plate, 5, cache=True)
    (path,) = entries(cache_dir, "modal_basis")
    data = path.read_bytes()
    for bad in (data[: len(data) // 2], data[:-40] + bytes(40), b"not a zip file"):
        path.write_bytes(bad)
        again = modal_basis(plate, 5, cache=True)
        assert_same_basis(again, good)
        assert path.read_bytes() == data                         # rewritten whole


def test_an_entry_under_another_key_is_not_used(cache_dir):
    plate = paper_plate(DIVISIONS)
    good = modal_basis(plate, 5, cache=True)
    (path,) = entries(cache_dir, "modal_basis")
    other = paper_plate(DIVISIONS, corner_mass=3.0)
    modal_basis(other, 5, cache=True)
    (other_path,) = [p for p in entries(cache_dir, "modal_basis") if p != path]
    path.write_bytes(other_path.read_bytes())                    # right name, wrong content (stored key differs)
    assert_same_basis(modal_basis(plate, 5, cache=True), good)


def test_failed_write_leaves_no_file(cache_dir, monkeypatch):
    def fail(*args, **kwargs):
        raise OSError("disk full")
    monkeypatch.setattr(cache.np, "savez", fail)
    plate = paper_plate(DIVISIONS)
    basis = modal_basis(plate, 3, cache=True)                     # still computed
    assert basis.n_flexible == 3
    assert list(cache_dir.iterdir()) == []                       # no entry, no temporary file


def test_cache_can_be_disabled(cache_dir, monkeypatch):
    monkeypatch.setenv("FLEXFMU_CACHE", "0")
    modal_basis(paper_plate(DIVISIONS), 3, cache=True)
    load_model("paper_plate", divisions=DIVISIONS)
    assert not cache_dir.exists()


def test_automatic_caching_only_for_large_models(cache_dir):
    modal_basis(paper_plate(DIVISIONS), 3)                       # 945 DOFs < CACHE_MIN_DOF
    assert entries(cache_dir, "modal_basis") == []


def test_bad_cache_argument():
    with pytest.raises(ParameterError, match="cache"):
        modal_basis(paper_plate(DIVISIONS), 3, cache="yes")


def test_cached_paper_plate_equals_assembled(cache_dir):
    first = load_model("paper_plate", divisions=DIVISIONS, corner_mass=0.5)
    assert len(entries(cache_dir, "paper_plate")) == 1
    hit = load_model("paper_plate", divisions=DIVISIONS, corner_mass=0.5)
    fresh = paper_plate(DIVISIONS, corner_mass=0.5)
    for s in (first, hit):
        np.testing.assert_array_equal(s.nodes, fresh.nodes)
        for a, b in ((s.M, fresh.M), (s.K, fresh.K)):
            assert a.shape == b.shape and (a != b).nnz == 0
        assert s.name == fresh.name and s.dofs_per_node == 3
        assert s.meta["divisions"] == DIVISIONS and s.points == fresh.points
        np.testing.assert_array_equal(s.meta["load_point"], fresh.meta["load_point"])
        assert (s.meta["model"], s.meta["kind"]) == ("paper_plate", "paper_plate")
    load_model("paper_plate", divisions=DIVISIONS, corner_mass=0.6)
    assert len(entries(cache_dir, "paper_plate")) == 2


def test_paper_plate_options_are_checked_before_the_lookup(cache_dir):
    with pytest.raises(ParameterError, match="corner_mass"):
        load_model("paper_plate", divisions=DIVISIONS, corner_mass=-1.0)
    with pytest.raises(ParameterError, match="divisions"):
        load_model("paper_plate", divisions=(0, 1, 1))


def test_structure_given_in_other_formats_is_validated_then_cached(cache_dir):
    plate = paper_plate(DIVISIONS)
    other = Structure(nodes=plate.nodes.tolist(), dofs_per_node=3, M=plate.M.tocsc(), K=plate.K.tocoo())
    a = modal_basis(other, 4, cache=True)                       # keyed by the validated CSR copy
    b = modal_basis(other, 4, cache=True)
    assert len(entries(cache_dir, "modal_basis")) == 1
    assert_same_basis(a, b)
    # identity: the validated CSR copy of the CSC / COO input is the plate's CSR matrix (same entries, same order),
    # and the same solver code runs on it in this process
    np.testing.assert_array_equal(a.frequencies_hz, modal_basis(plate, 4, cache=False).frequencies_hz)


def test_invalid_structure_is_rejected_not_cached(cache_dir):
    plate = paper_plate(DIVISIONS)
    M = plate.M.copy()
    M.data[0] = np.nan
    with pytest.raises(ParameterError, match="structure.M"):
        modal_basis(Structure(nodes=plate.nodes, dofs_per_node=3, M=M, K=plate.K), 4, cache=True)
    assert entries(cache_dir, "modal_basis") == []


def test_least_recently_used_entries_are_evicted_beyond_the_size_limit(cache_dir, monkeypatch):
    import os
    monkeypatch.setenv("FLEXFMU_CACHE_MAX_MB", "0.35")            # room for three 100 kB entries
    payload = {"x": np.zeros(12_500)}                             # 100 kB
    paths = [cache.store("test", cache.make_key("test", i=i), payload) for i in range(3)]
    for age, p in enumerate(paths):                                # distinct, increasing use times
        os.utime(p, (1e9 + age, 1e9 + age))
    assert cache.load("test", cache.make_key("test", i=0)) is not None   # a hit makes entry 0 the newest
    cache.store("test", cache.make_key("test", i=3), payload)
    remaining = {i for i in range(4) if cache.load("test", cache.make_key("test", i=i)) is not None}
    assert remaining == {0, 2, 3}                                  # entry 1, the least recently used, went


def test_bounded_cache_starts_afresh_when_full():
    from flexfmu.core.cache import BoundedCache
    memo = BoundedCache(3)
    for k in range(3):
        memo[k] = k * k
    memo[1] = 10                                  # an existing key: no reset
    assert dict(memo) == {0: 0, 1: 10, 2: 4}
    memo[3] = 9                                   # a fourth key: the memo starts afresh
    assert dict(memo) == {3: 9}


def test_basis_cache_key_covers_every_solver_module():
    """A change in any module that computes a basis (or picks its path) gives new cache keys."""
    from flexfmu.core import cache as model_cache
    from flexfmu.linalg import cutoffs, lanczos, modal
    from flexfmu.linalg import modal_basis as mbm
    digest = mbm._source_digest()
    for module in (mbm, lanczos, modal, cutoffs):
        assert model_cache.file_digest(module.__file__) in digest
