"""A small clamped-solid test model: a steel bar of linear hexahedra as an Abaqus .inp (meshio) with its model JSON,
node sets ``root`` (x = 0) and ``tip`` (x = L); what tests of exported solid bodies build in a second or two."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

#: m: length (x), width (y), thickness (z), centred on the x axis
SIZE = (0.4, 0.04, 0.02)
MATERIAL = {"E": 2.1e11, "nu": 0.3, "rho": 7850.0}       # Pa, 1, kg/m^3


def bar_model(folder: Path, cells_along: int = 10) -> Path:
    """Write the bar (``cells_along`` x 2 x 1 hexahedra) into ``folder``; returns its model JSON."""
    import meshio
    length, width, thickness = SIZE
    axes = [np.linspace(0.0, length, cells_along + 1), np.linspace(-width / 2, width / 2, 3),
            np.linspace(-thickness / 2, thickness / 2, 2)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    index = np.arange(X.size).reshape(X.shape)
    cells = [[c[0, 0, 0], c[1, 0, 0], c[1, 1, 0], c[0, 1, 0], c[0, 0, 1], c[1, 0, 1], c[1, 1, 1], c[0, 1, 1]]
             for c in (index[i:i + 2, j:j + 2, 0:2] for i in range(cells_along) for j in range(2))]
    folder = Path(folder)
    meshio.write(str(folder / "bar.inp"), meshio.Mesh(np.column_stack([X.ravel(), Y.ravel(), Z.ravel()]),
                                                      [("hexahedron", np.array(cells))],
                                                      point_sets={"root": index[0].ravel(), "tip": index[-1].ravel()}))
    (folder / "bar.json").write_text(json.dumps({"mesh": "bar.inp", "material": MATERIAL}))
    return folder / "bar.json"
