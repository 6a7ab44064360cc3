"""Pictures of a deformed body: the displacement and von Mises stress of every node from the shape coordinates
q(t) of an exported body (its shape file, flexfmu.body.shape_file) or from a model's mode shapes, written as a VTK
series (ParaView) or animated (GIF, MP4).

flexfmu.viz.series: deformed_series (u(t) = Psi q(t), von Mises from sigma(t) = S q(t)), mode_series.
flexfmu.viz.vtk: write_vtk_series (one .vtu per frame and a .pvd collection).
flexfmu.viz.animate: animate (matplotlib 3-D view of the deformed outer surface, coloured by von Mises).

Above the body layer (it reads the shape file and the mode shapes) and below fmi: it knows nothing of FMI; the
command line (flexfmu animate, flexfmu modal --animate) reads the FMUs and result files and hands over arrays.
"""
