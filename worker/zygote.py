"""What the fork server (worker/isolation.py) loads before it forks any job child: every pipeline with the modules
in its PRELOAD tuple, and the attitude filter's compiled kernels. Imported by the fork server only, in its one
thread; `PYTHON_THREADS` records how many Python threads it had then (one: nothing here starts a thread)."""
from __future__ import annotations

import threading

from worker.main import _warm_up_kernels, preload_pipelines

preload_pipelines()
_warm_up_kernels()

PYTHON_THREADS = threading.active_count()
