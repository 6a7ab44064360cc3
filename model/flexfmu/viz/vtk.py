"""A deformed series as VTK files for ParaView: one unstructured grid (.vtu, meshio) per frame holding the undeformed
mesh with the point data ``displacement`` (m, body frame; ParaView's "Warp By Vector" draws the deformed body) and
``von_mises`` (Pa, when the body has stress shapes), and a .pvd collection naming each frame with its time."""
from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from flexfmu.errors import ParameterError
from flexfmu.viz.series import DeformedSeries


def _meshio_cells(series: DeformedSeries) -> list:
    cells = [(kind, np.asarray(data, dtype=np.int64)) for kind, data in series.cells.items() if len(data)]
    if not cells:                                   # no connectivity: the nodes as vertices, so ParaView shows them
        cells = [("vertex", np.arange(series.nodes.shape[0], dtype=np.int64)[:, None])]
    return cells


def write_vtk_series(series: DeformedSeries, directory, *, basename: str = "frame") -> Path:
    """Write ``directory``/<basename>_0000.vtu ... (one per frame) and ``directory``/<basename>.pvd (the collection:
    each frame's file and time, series.t).  Files of an earlier series of the same basename are removed first, so the
    folder holds this series only.  Returns the .pvd's path."""
    try:
        import meshio
    except ImportError:
        raise ParameterError("vtk", "writing VTK files needs meshio", "pip install meshio") from None
    if not basename or any(c in basename for c in "/\\") or basename.startswith("."):
        raise ParameterError("basename", f"{basename!r}", "a plain file-name stem")
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise ParameterError("vtk", f"{directory} exists and is not a folder", "a folder to write the .vtu files in")
    directory.mkdir(parents=True, exist_ok=True)
    for old in directory.glob(f"{basename}_[0-9]*.vtu"):
        old.unlink()
    cells = _meshio_cells(series)
    width = max(4, len(str(series.n_frames - 1)))
    entries = []
    for k in range(series.n_frames):
        point_data = {"displacement": series.displacement[k]}
        if series.von_mises is not None:
            point_data["von_mises"] = series.von_mises[k]
        name = f"{basename}_{k:0{width}d}.vtu"
        try:
            meshio.write(directory / name, meshio.Mesh(series.nodes, cells, point_data=point_data),
                         file_format="vtu")
        except (KeyError, ValueError) as exc:       # a cell type VTK has no number for
            raise ParameterError("cells", f"meshio cannot write them as VTK: {exc}",
                                 "meshio cell types VTK knows (tetra, tetra10, hexahedron, triangle, line, ...)") from None
        entries.append(f'    <DataSet timestep="{float(series.t[k])!r}" group="" part="0" file={quoteattr(name)}/>')
    pvd = directory / f"{basename}.pvd"
    pvd.write_text('<?xml version="1.0"?>\n'
                   '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                   "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n", encoding="utf-8")
    return pvd
