"""Model sizes at which the eigen-solvers switch from dense to sparse (method="auto").

Three different decisions, hence three names and values.  Dense solves are exact to round-off but cost
O(n^3) whatever the number of modes wanted; the sparse ones cost roughly in proportion to the DOFs and
the modes wanted, and agree with the dense ones to ~1e-9 (tests/test_ffr_analytic.py,
tests/test_modal_basis.py).  Changing a value moves models from one path to the other: their numbers
change at the round-off level.
"""

#: flexfmu.linalg.modal.solve_modes: free DOFs of a clamped beam model up to which its modes come from the
#: dense inverted problem.  These are the modes an FFRBeam model keeps (solved once per configuration and
#: shared by its instances), so accuracy comes first: the dense path keeps the low modes to ~1e-13, and up to
#: this size it costs a few seconds of CPU at most (measured 0.6-2.3 s at 1008 free DOFs; shift-invert ~0.1 s).
BEAM_MODES_DENSE_MAX_DOF = 1000

#: flexfmu.linalg.modal_basis.modal_basis: DOFs of a free-free model up to which the flexible modes come from
#: a dense solve of the whole problem (rigid modes included) rather than block Lanczos, whose factorisation
#: and Krylov blocks are overhead on small models: the beam models of ReframeBody (150 DOFs at the default
#: mesh) and the small test plates stay dense, the solid plates (thousands of DOFs) go sparse.
BASIS_DENSE_MAX_DOF = 600

#: flexfmu.sizing (mesh choice): free DOFs up to which the meshes of a convergence study are solved densely.
#: Only the lowest frequencies of many meshes are compared, against tolerances of 1e-6 and more; beyond this,
#: shift-invert on the banded matrices is ~30x cheaper (0.1 s against 2-6 s CPU at 576-1152 DOFs) and
#: within ~2e-8 of the dense frequencies, so the cut-off is lower than BEAM_MODES_DENSE_MAX_DOF.
MESH_SCAN_DENSE_MAX_DOF = 200
