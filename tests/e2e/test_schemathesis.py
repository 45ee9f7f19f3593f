"""Property-based API fuzzing with schemathesis against the spec a live server serves, on both backends
(SQLite + Huey, PostgreSQL + Redis): no 5xx, and every response conforms to the spec (status codes, content
types, headers, schemas), including negative data, in every phase: examples, coverage, fuzzing and stateful
(the spec's OpenAPI links from created sets, jobs and maps, and the ones schemathesis infers). Bounded: 30
examples per operation, about 40 s of schemathesis per backend.

Excluded check: `positive_data_acceptance`. A schema-valid request can be rightly refused with 422 here: the
spec cannot say that an uploaded file must be valid RINEX, or that `type` must name a registered job type.
"""
from __future__ import annotations

import subprocess
import sys

import pytest

from gnssatt.sim.sample_set import write_sample_set

pytestmark = pytest.mark.e2e


def test_api_conforms_to_its_spec(service, tmp_path):
    service.start_api()
    service.start_worker()
    key = service.create_key("fuzz")
    with service.client(key) as c:  # something to find: one set and one job
        paths = write_sample_set(tmp_path / "set", n_epochs=5)
        files = [("files", (p.name, p.read_bytes(), "application/octet-stream")) for p in paths]
        assert c.post("/v1/observation-sets", files=files).status_code == 201
        assert c.post("/v1/jobs", json={"type": "selftest", "config": {"duration_s": 0}}).status_code == 202
    run = subprocess.run(
        [sys.executable, "-m", "schemathesis.cli", "run", service.url + "/openapi.json",
         "-H", f"Authorization: Bearer {key}", "--checks", "all",
         "--exclude-checks", "positive_data_acceptance", "--max-examples", "30", "--seed", "20261124",
         "--phases", "examples,coverage,fuzzing,stateful", "--max-response-time", "10", "--no-color"],
        capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-6000:] + run.stderr[-2000:]
    assert "passed" in run.stdout
    assert "✅ Stateful" in run.stdout and "API Links:" in run.stdout, run.stdout[-3000:]
