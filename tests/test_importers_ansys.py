"""MAPDL .full files (flexfmu.importers.ansys) against the example files ansys-mapdl-reader ships.

What the files are (found out by reading them; tests/reference/importers/README.md):
``HexBeam.cdb``  a 1 x 1 x 5 bar of 40 SOLID186 (20-node hexahedra), 321 nodes, inch units;
``file.full``    stiffness and mass of that mesh with its 21 nodes at z = 0 clamped (63 constrained DOFs);
``file.rst``     MAPDL's free-free modal solution of the same mesh, titanium in inch, lbf, s
                 (EX = 16.9e6 psi, NUXY = 0.31, DENS = 4.1408e-4 lbf s^2/in^4): six flexible frequencies.
The .rst's frequencies are MAPDL's own solution, a reference independent of flexfmu; so is the .full's
stiffness, against flexfmu's scikit-fem assembly of the archive's mesh.
"""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse as sp

from flexfmu.errors import ModelFileError, ParameterError
from flexfmu.importers import load_structure
from error_bounds import gamma

reader = pytest.importorskip("ansys.mapdl.reader")
meshio = pytest.importorskip("meshio")
from ansys.mapdl.reader import Archive, examples, read_binary  # noqa: E402

TITANIUM_IN = {"E": 16.9e6, "nu": 0.31, "rho": 4.1408e-4}     # file.rst's material, inch-lbf-s numbers
INCH = 0.0254


def _eigenvalues(K, M):
    return sl.eigh(np.asarray(K.todense() if sp.issparse(K) else K), np.asarray(M.todense() if sp.issparse(M) else M),
                   eigvals_only=True)


@pytest.fixture(scope="module")
def structure():
    return load_structure(examples.fullfile, coordinates=examples.hexarchivefile, length_unit="in")


@pytest.fixture(scope="module")
def hexbeam_vtu(tmp_path_factory):
    """HexBeam.cdb's mesh as meshio hexahedron20 cells: SOLID186's node order I..P, Q..X, Y, Z, A, B (MAPDL
    element reference) is VTK's quadratic hexahedron order."""
    archive = Archive(examples.hexarchivefile)
    nodes = np.array([e[10:] for e in archive.elem])
    assert nodes.shape == (40, 20) and all(len(set(row)) == 20 for row in nodes)      # no degenerate shapes
    path = tmp_path_factory.mktemp("hexbeam") / "hexbeam.vtu"
    meshio.write(path, meshio.Mesh(archive.nodes, [("hexahedron20", np.searchsorted(archive.nnum, nodes))]))
    return path


def test_eigenvalues_equal_those_of_mapdls_raw_matrices(structure):
    dof_ref, k, m = read_binary(examples.fullfile).load_km()             # upper triangles, MAPDL's own order
    K = k.toarray() + np.triu(k.toarray(), 1).T
    M = m.toarray() + np.triu(m.toarray(), 1).T
    free = np.flatnonzero(np.diag(K) != 0.0)
    raw = _eigenvalues(K[np.ix_(free, free)], M[np.ix_(free, free)])
    keep = np.setdiff1d(np.arange(structure.n_dof), structure.constrained_dofs)
    ours = _eigenvalues(structure.K[keep][:, keep], structure.M[keep][:, keep])
    assert ours.size == raw.size == 900
    err = np.max(np.abs(ours / raw - 1.0))
    print(f"\nfile.full: {raw.size} eigenvalues, max relative difference to MAPDL's raw matrices {err:.1e}; "
          f"first {np.sqrt(raw[:3]) / (2 * np.pi)} Hz")
    assert err < 1e-9


def test_constraints_nodes_and_sets(structure):
    assert structure.constrained_dofs.size == 63 and structure.meta["clamped_only"]
    clamped_nodes = np.unique(structure.constrained_dofs // 3)
    np.testing.assert_array_equal(np.unique(structure.constrained_dofs % 3), [0, 1, 2])
    assert np.all(structure.nodes[clamped_nodes, 2] == 0.0)                   # the z = 0 end
    assert np.count_nonzero(structure.nodes[:, 2] == 0.0) == clamped_nodes.size
    assert structure.nodes[:, 2].max() == pytest.approx(5 * INCH)
    archive = Archive(examples.hexarchivefile)
    assert set(structure.node_sets) == set(archive.node_components)
    np.testing.assert_array_equal(structure.meta["node_ids"][structure.node_sets["NCOMP2"]],
                                  np.sort(archive.node_components["NCOMP2"]))
    assert "in, lbf" in structure.provenance.units and structure.provenance.format == "ansys-full"


def test_unit_system_does_not_change_frequencies(structure):
    si = load_structure(examples.fullfile, coordinates=examples.rstfile)    # numbers read as SI
    keep = np.setdiff1d(np.arange(si.n_dof), si.constrained_dofs)
    a = _eigenvalues(si.K[keep][:, keep], si.M[keep][:, keep])
    b = _eigenvalues(structure.K[keep][:, keep], structure.M[keep][:, keep])
    assert np.max(np.abs(a / b - 1.0)) < 1e-9
    assert structure.K[keep][:, keep].max() == pytest.approx(si.K[keep][:, keep].max() * 4.4482216152605 / INCH)
    # the coordinates come from two files: the .rst's doubles and the .cdb's NBLOCK text (e21.13: 14 significant
    # digits, within 5e-14 |x| of the double, + u |x| parsing); each then one rounded product by 0.0254: gamma(3)
    bound = (5e-14 + gamma(3)) * np.abs(si.nodes) * INCH
    assert np.all(np.abs(structure.nodes - si.nodes * INCH) <= bound)


@pytest.mark.parametrize("integration, tolerance", [("reduced", 1e-5), ("full", 5e-3)])
def test_flexfmu_assembly_of_hexbeam_matches_mapdls_modal_solution(hexbeam_vtu, integration, tolerance):
    """SOLID186 integrates its stiffness with 2 x 2 x 2 points by default (KEYOPT(2) = 0), as flexfmu's
    integration="reduced"; full 3 x 3 x 3 integration is stiffer by up to 0.4 %."""
    mapdl = read_binary(examples.rstfile).time_values                    # Hz, MAPDL's Block Lanczos
    s = load_structure(hexbeam_vtu, material=TITANIUM_IN, integration=integration)
    f = np.sqrt(np.abs(_eigenvalues(s.K, s.M))) / (2 * np.pi)
    assert np.all(f[:6] < 1e-5 * f[6])                                     # six rigid modes
    err = f[6:12] / mapdl - 1.0
    print(f"\n{integration}: flexfmu {np.round(f[6:12], 2)} Hz, MAPDL {np.round(mapdl, 2)} Hz, "
          f"max relative difference {np.max(np.abs(err)):.1e}")
    assert np.max(np.abs(err)) < tolerance
    if integration == "full":
        assert np.all(err > 0)


def test_full_stiffness_equals_flexfmu_assembly_of_the_archive(hexbeam_vtu):
    # both in the files' own numbers (inch, lbf): the .full read as SI, the mesh with the inch material
    mapdl = load_structure(examples.fullfile, coordinates=examples.hexarchivefile)
    ours = load_structure(hexbeam_vtu, material=TITANIUM_IN, integration="reduced")
    keep = np.setdiff1d(np.arange(mapdl.n_dof), mapdl.constrained_dofs)
    K_mapdl, K_ours = mapdl.K[keep][:, keep], ours.K[keep][:, keep]
    diff = abs(K_mapdl - K_ours).max() / abs(K_mapdl).max()
    print(f"\nfile.full K vs flexfmu's reduced-integration SOLID186 K: max relative difference {diff:.1e}")
    assert diff < 1e-9
    np.testing.assert_array_equal(ours.nodes, mapdl.nodes)


def test_full_without_coordinates_is_refused(tmp_path):
    shutil.copy(examples.fullfile, tmp_path / "beam.full")
    with pytest.raises(ModelFileError, match=r"beam\.full \[coordinates\]: holds no node coordinates and neither "
                                             r"beam\.cdb nor beam\.rst is beside it"):
        load_structure(tmp_path / "beam.full")
    shutil.copy(examples.hexarchivefile, tmp_path / "beam.cdb")             # found beside it
    assert load_structure(tmp_path / "beam.full").n_dof == 963


def test_not_a_full_file(tmp_path):
    (tmp_path / "junk.full").write_bytes(b"\x00" * 64)
    with pytest.raises(ModelFileError, match=r"junk\.full: cannot be read as full file \(\.full\)"):
        load_structure(tmp_path / "junk.full", coordinates=examples.hexarchivefile)
    shutil.copy(examples.rstfile, tmp_path / "result.full")
    with pytest.raises(ModelFileError, match=r"result\.full: is a MAPDL Result, not a full file"):
        load_structure(tmp_path / "result.full", coordinates=examples.hexarchivefile)


def test_coordinates_must_be_an_archive_or_result_file(tmp_path):
    with pytest.raises(ParameterError, match=r"coordinates: '.*beam\.vtu' is neither a \.cdb nor a \.rst"):
        load_structure(examples.fullfile, coordinates=tmp_path / "beam.vtu")
    with pytest.raises(ParameterError, match=r"coordinates: no such file: '.*none\.cdb'"):
        load_structure(examples.fullfile, coordinates=tmp_path / "none.cdb")
