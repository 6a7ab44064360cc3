"""Model size for a frequency band and a tolerance, for both sides: mesh, modes, static correction.

model_size: the equations and every name; common: the truncation estimate both sides use; mesh and beam:
FFRBeam's mesh, modes and static correction; solid: ReframeBody's modal basis (n_flexible_modes = -1) and the mode
search and residual vectors it shares with interfaces: a flexible body's modes for its interfaces (flexfmu.body)."""
