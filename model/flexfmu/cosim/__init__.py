"""Co-simulation masters for a system of FMUs (fmpy, libcosim, the library)."""
