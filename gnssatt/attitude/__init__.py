"""Multi-antenna GNSS attitude: the carrier-phase EKF of seed 000 (CASSIOPE/GAP), quality control, integer
ambiguity resolution, attitude from baselines and the job's products. Pure numpy/scipy/erfa (no web imports).

Modules: settings (all tuning constants, with units and their source), observations (per-antenna arrays on
common epochs), geometry (platform state, lines of sight), filter (the EKF with QC and AR), ambiguity (DD + MLAMBDA
+ baseline-length validation), solution (QUEST/TRIAD, Euler angles, formal sigmas), products (CSV, JSON, CCSDS
AEM, NMEA HDT), process (the whole job on files).
"""
from gnssatt._lazy import lazy_exports

#: public entry points (imported on first use): solve(files, platform, nav, settings) -> AttitudeSolution and
#: write_products(solution, out_dir); see gnssatt.attitude.api and docs/library.md
_EXPORTS = {"solve": "api", "write_products": "api", "identify_files": "api", "AttitudeSolution": "process",
            "InputProblem": "process", "AttitudeSettings": "settings"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
