"""Multi-antenna GNSS attitude: the carrier-phase EKF of seed 000 (CASSIOPE/GAP), quality control, integer
ambiguity resolution, attitude from baselines and the job's products. Pure numpy/scipy/erfa (no web imports).

Modules: settings (all tuning constants, with units and their source), observations (per-antenna arrays on
common epochs), geometry (platform state, lines of sight), filter (the EKF with QC and AR), ambiguity (DD + MLAMBDA
+ baseline-length validation), solution (QUEST/TRIAD, Euler angles, formal sigmas), products (CSV, JSON, CCSDS
AEM, NMEA HDT), process (the whole job on files).
"""
