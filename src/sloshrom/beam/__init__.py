"""The sloshing beam, in four rooms by job.

* :mod:`~sloshrom.beam.simulation` - the structures (the cantilever with its tank, your own
  modal model, the two-mode wing) and the coupled simulation of any sloshing model in them:
  free and random responses, several cases, an ensemble ROM member by member, the shaker
  programme of the structure's own motion.
* :mod:`~sloshrom.beam.damping` - the damping analyses of a response: spectra, the free-decay
  methods, the damping estimators of random tests (their protocol, registry and intervals) and
  the damping tables (paper Table 2 over case, level and estimator).
* :mod:`~sloshrom.beam.lab` - a laboratory's files: channel maps, the readers of measured tests
  and their checks, the UFF 58 files (written and read), the virtual rig playing the
  laboratory, a campaign folder, and the analysis of a measured test at every mode.
* :mod:`~sloshrom.beam.compare` - a measurement beside its predictions, with verdicts.

Beside them, :mod:`~sloshrom.beam.errors` (the room's error types) and
:mod:`~sloshrom.beam.results` (the result files every room writes: NetCDF, CSV, Markdown).
Each room imports only the rooms before it in this list (``tests/test_architecture.py``).
"""
