"""Studies shared by benchmarks and tests (the spin-up beam)."""
