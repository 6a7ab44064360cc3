"""The wave-energy converter: waves, the floating box's components (WaveExcitation, Hydrostatics,
Platform, PTO simulators) and the system studies (energy audit, power, tuning sweep)."""
