"""The shared core: the Structure passed between stages, its .npz format, the on-disk cache,
rotations (Rodrigues, skew) and 3-vector helpers, parameter checks, small BLAS calls on one thread."""
