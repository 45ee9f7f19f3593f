"""What the fork server (worker/isolation.py) loads before it forks any job child: every pipeline with the modules
in its PRELOAD tuple, and the attitude filter's compiled kernels. Imported by the fork server only, in its one
thread; `PYTHON_THREADS` records how many Python threads it had then (one: nothing here starts a thread). The
objects loaded are frozen out of the cyclic garbage collector (gc.freeze) before the first fork."""
from __future__ import annotations

import gc
import threading

from worker.main import _warm_up_kernels, preload_pipelines

preload_pipelines()
_warm_up_kernels()
# everything loaded so far lives as long as the fork server: out of the cyclic collector's sight (CPython's
# advice for servers that fork), a job child's collections do not traverse (and so write to) the inherited pages
gc.freeze()

PYTHON_THREADS = threading.active_count()
