"""Model size for a frequency band and a tolerance, for both sides: mesh, modes, static correction."""
