"""Time to first fix of one observation set in one call, without a server: `study_set(files, ...)` is what one
fan-out task of the ttff job does (gnssatt.ttff.data.load_study_set + gnssatt.ttff.study.run_set); the Table 5
layout of many sets' runs is gnssatt.ttff.study.table5_rows / table5_markdown. See docs/library.md and docs/ttff.md.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

from gnssatt.attitude.api import ATTITUDE_KINDS, identify_files
from gnssatt.ttff.data import load_study_set
from gnssatt.ttff.study import StudyOptions, run_set

__all__ = ["study_set"]


def study_set(files: Iterable[str | Path], *, truth_dir: str | Path | None = None,
              options: StudyOptions | None = None, label: str | None = None) -> dict:
    """TTFF runs of one set: run_set's JSON-able result {"set", "runs": [row per configuration, baseline and
    method], "initial_euler_deg", "truth", "n_epochs", ...}.

    Args:
        files: paths of the set (RINEX obs per antenna, navigation, platform.json, reference attitude or a
            simulator truth folder); kinds from the content, as gnssatt.attitude.solve.
        truth_dir: a simulator truth/ folder (exact integer checks); None: the reference attitude only.
        options: StudyOptions (configurations, methods, seconds used); None: its defaults.
        label: the set's name in the tables (default: the name of the folder holding all the files).
    """
    paths = [Path(p) for p in files]
    options = options or StudyOptions()
    triples = [t for t in identify_files(paths) if t[1] in ATTITUDE_KINDS]
    ss = load_study_set(triples, label or Path(os.path.commonpath(paths)).name, truth_dir=Path(truth_dir) if truth_dir else None,
                        max_duration_s=options.max_duration_s)
    return run_set(ss, options)
