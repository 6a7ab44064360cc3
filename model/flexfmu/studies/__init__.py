"""The benchmark studies that ``flexfmu bench`` runs (performance, work_precision, stability, spinup; each a
module with ``main(argv)``, benchmarks/<name>.py are shells over them; a study's parts are the modules named after
it, one job each, e.g. work_precision_report), and what they share with the tests: the reference trajectories
(:mod:`flexfmu.studies.references`) and the spin-up models (:mod:`flexfmu.studies.spinup_models`).

The study modules are imported on demand, not here: they are heavy, and the performance study runs itself as
``python -m flexfmu.studies.performance`` in child processes."""
