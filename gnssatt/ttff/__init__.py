"""Time to first fix (issue 7, seed 000 sec. 5 and Table 5): for many observation sets that start far from the
assumed Earth-pointing attitude, the time from filter start to the first accepted ambiguity fix per baseline and
frequency configuration, whether the fix was right, the single-epoch success rate of the integer search (paper's
LAMBDA + length validation, and the body-constrained C-/MC-LAMBDA), and the Table 5 layout of the results.
Pure numpy/scipy (no web imports).

Modules: data (a set parsed once, with truth), single_epoch (every epoch solved on its own), study (one set:
every configuration; many sets: the table and summary), starts (random starts for the simulator).
"""
from gnssatt._lazy import lazy_exports

#: public entry point (imported on first use): study_set(files, truth_dir=None, options=None) -> dict
_EXPORTS = {"study_set": "api", "StudyOptions": "study"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
