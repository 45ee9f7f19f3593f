"""The fork server job children come from (worker.isolation), started once per test run as the worker starts it
(~20-40 s: the pipelines' imports and the filter kernels), so no test's own timing counts it."""
from __future__ import annotations

import pytest

from worker import isolation


@pytest.fixture(scope="session")
def fork_server() -> None:
    isolation.start_fork_server()
