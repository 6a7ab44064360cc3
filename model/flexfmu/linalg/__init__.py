"""Eigen-solvers: natural frequencies and mode shapes of beam models (dense / shift-invert) and the
modal basis of large solid models (block Lanczos, optional MKL PARDISO)."""
