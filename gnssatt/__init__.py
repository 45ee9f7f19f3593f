"""gnssatt: GNSS attitude determination, as an importable science library.

Sub-packages, each one capability:
- `gnssatt.gnss`: RINEX/SP3/ANTEX/clock I/O, time, frames, rotations, orbits, positioning, alignment.
- `gnssatt.estimation`: the EKF (Joseph form), LAMBDA/MLAMBDA and the body-constrained search, AR validation.
- `gnssatt.attitude`: the seed 000 multi-antenna carrier-phase EKF and the attitude job's products.
- `gnssatt.calibration`: in-flight baselines and differential PCV maps over many sets.
- `gnssatt.ttff`: the seed 000 Table 5 time-to-first-fix study.
- `gnssatt.sim`: the truth simulator.
- `gnssatt.plots`, `gnssatt.report`: PNG plots and the HTML report from products.

Depends on numpy, scipy, erfa, numba and matplotlib only: it never imports the service (`app`, `worker`),
a database, a queue or HTTP (tests/test_import_boundaries.py checks every module).
"""
