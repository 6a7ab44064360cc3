"""The reframe flexible-body integrator (Liu): conventional models (the paper's plate, beam scenes,
.npz files), the integrator and its schemes, compiled kernels, and ReframeBody.fmu's simulator."""
