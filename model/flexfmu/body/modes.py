"""Natural modes of any Structure, clamped or free (``flexfmu modal MODEL``), and a picture of their shapes.

Clamped: the lowest eigenpairs of K phi = omega^2 M phi on the DOFs the clamp leaves free
(flexfmu.linalg.modal.solve_modes).  Free: the elastic modes of the free structure, the six rigid-body
modes left out (flexfmu.linalg.modal_basis.modal_basis).  Shapes are returned on all DOFs (zero at clamps).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from flexfmu.core.checks import is_int, shown
from flexfmu.core.structure import Structure
from flexfmu.errors import ParameterError


@dataclass
class NaturalModes:
    """kind "free" | "clamped"; clamp: how the model is held (text); frequencies_hz (k,); shapes (n_dof, k),
    mass-normalised, zero on clamped DOFs; mass: the structure's mass, kg."""

    name: str
    kind: str
    clamp: str
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    mass: float

    def table(self) -> str:
        head = (f"{self.name or 'model'}: {self.kind} ({self.clamp}), mass {self.mass:.6g} kg\n"
                f"{'mode':>4}  {'f (Hz)':>14}")
        rows = [f"{k:>4}  {f:14.6f}" for k, f in enumerate(self.frequencies_hz, start=1)]
        return "\n".join([head, *rows])


def natural_modes(structure: Structure, *, clamp=None, n_modes: int = 6, progress: bool = False) -> NaturalModes:
    """The lowest ``n_modes`` natural modes: clamped as build_body's ``clamp`` ("file" or a node-set name),
    or free (clamp None: elastic modes only).  Large models take the sparse block Lanczos solver (free:
    modal_basis; clamped: flexfmu.linalg.sparse_modes beyond BEAM_MODES_DENSE_MAX_DOF free DOFs); ``progress`` shows
    its converged modes on stderr."""
    from flexfmu.body.build import check_parts, clamped_dofs
    from flexfmu.core.io import validate_structure
    from flexfmu.errors import ModalConvergenceError
    from flexfmu.linalg.cutoffs import BEAM_MODES_DENSE_MAX_DOF
    from flexfmu.linalg.modal import solve_modes
    from flexfmu.linalg.modal_basis import mass_properties, modal_basis
    from flexfmu.linalg.sparse_modes import lanczos_modes

    if not is_int(n_modes) or n_modes < 1:
        raise ParameterError("modes", f"{shown(n_modes)}", "an integer >= 1")
    checked = validate_structure(structure)
    mass = float(mass_properties(checked).mass)
    if clamp is None:
        check_parts(checked, np.zeros(0, dtype=np.int64), "free")
        basis = modal_basis(checked, int(n_modes), damping_ratio=0.0, progress=progress)
        return NaturalModes(structure.name, "free", "free: the six rigid-body modes left out",
                            np.asarray(basis.frequencies_hz, float), np.asarray(basis.flexible), mass)
    fixed, how = clamped_dofs(structure, clamp)
    check_parts(checked, fixed, how)
    free = np.setdiff1d(np.arange(checked.n_dof), fixed)
    if n_modes > free.size:
        raise ParameterError("modes", f"{n_modes}", f"1 ... {free.size} (the DOFs the clamp leaves free)")
    K = sp.csr_matrix(checked.K)[free][:, free]
    M = sp.csr_matrix(checked.M)[free][:, free]
    try:
        if free.size > BEAM_MODES_DENSE_MAX_DOF and n_modes < free.size - 1:
            modes = lanczos_modes(K, M, int(n_modes), progress=progress, label="modes")
        else:
            modes = solve_modes(K, M, int(n_modes))
    except ModalConvergenceError:
        raise
    except RuntimeError as exc:                    # SuperLU: "Factor is exactly singular"; a zero-energy mode
        raise ParameterError("clamp", f"{how} leaves the body free to move ({exc})",
                             "clamps that hold every rigid-body motion") from None
    shapes = np.zeros((checked.n_dof, modes.shapes.shape[1]))
    shapes[free] = modes.shapes
    return NaturalModes(structure.name, "clamped", how, np.asarray(modes.frequencies_hz, float), shapes, mass)


def plot_modes(structure: Structure, modes: NaturalModes, path, n_shown: int = 6) -> Path:
    """A PNG of the first ``n_shown`` mode shapes: the nodes undeformed (grey) and displaced (coloured by the
    displacement), each scaled to 10 % of the model's size; three views per mode would not fit, so one
    oblique 3D view."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ParameterError("plot", "needs matplotlib", "pip install matplotlib") from None
    nodes = np.asarray(structure.nodes, float)
    dpn = int(structure.dofs_per_node)
    size = float(np.max(np.ptp(nodes, axis=0))) or 1.0
    k = min(n_shown, modes.shapes.shape[1])
    cols = min(3, k)
    rows = -(-k // cols)
    fig = plt.figure(figsize=(4.2 * cols, 3.8 * rows))
    fixed = np.zeros(nodes.shape[0], bool)
    for j in range(k):
        u = modes.shapes[:, j].reshape(-1, dpn)[:, :3]
        amp = float(np.max(np.linalg.norm(u, axis=1))) or 1.0
        moved = nodes + 0.1 * size * u / amp
        mag = np.linalg.norm(u, axis=1) / amp
        if j == 0:
            fixed = np.all(modes.shapes.reshape(nodes.shape[0], dpn, -1) == 0.0, axis=(1, 2))
        ax = fig.add_subplot(rows, cols, j + 1, projection="3d")
        ax.scatter(*nodes.T, s=2, c="0.75", depthshade=False)
        sc = ax.scatter(*moved.T, s=4, c=mag, cmap="viridis", vmin=0.0, vmax=1.0, depthshade=False)
        if modes.kind == "clamped" and np.any(fixed):
            ax.scatter(*nodes[fixed].T, s=6, c="crimson", marker="s", depthshade=False)
        ax.set_title(f"mode {j + 1}: {modes.frequencies_hz[j]:.4g} Hz", fontsize=10)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.set_ylabel("y (m)", fontsize=8)
        ax.set_zlabel("z (m)", fontsize=8)
        ax.tick_params(labelsize=6)
        lo, hi = nodes.min(axis=0), nodes.max(axis=0)
        centre, half = 0.5 * (lo + hi), 0.6 * size
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
    fig.suptitle(f"{modes.name or 'model'}: {modes.kind} ({modes.clamp}); grey: undeformed, colour: |u| / max "
                 + ("; red: clamped nodes" if modes.kind == "clamped" else ""), fontsize=10)
    fig.colorbar(sc, ax=fig.axes, shrink=0.6, label="|u| / max |u|")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
