"""The damping analyses of the beam's responses, simulated or measured.

``analysis`` (spectra, modal filtering, the free-decay methods, LSCF), ``estimators``,
``registry`` and ``ssi`` (the damping estimators of random tests behind one protocol),
``uncertainty`` (their standard deviations and intervals), ``peaks`` (the modes a record
shows), ``tables`` (the damping tables of the beam tests: free-decay bands, paper Table 2) and
``multimode`` (the damping of each mode of a structure with several active modes).
"""
