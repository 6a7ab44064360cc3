"""The wave-energy converter: waves, the floating box's components (WaveExcitation, Hydrostatics,
Platform, PTO simulators) and the system studies (energy audit, power, tuning sweep).

The BEM side (optional: ``pip install 'flexfmu[bem]'``, Capytaine) lives in flexfmu.wec.bem (hydrodynamic
database, exact hydrostatics, frequency-domain RAO) and flexfmu.wec.radiation (the Cummins radiation
memory as a fitted state-space model, its fixed-step ZOH form); they are imported from there, so that
importing flexfmu.wec never needs Capytaine or xarray.
"""
