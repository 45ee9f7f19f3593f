"""How often a job's event stream (GET /v1/jobs/{id}/events) reads the job: every 0.25 s, every 0.05 s in a running
job's last stretch (progress >= 0.9: products and plots) so that the end is seen ~25 ms after it on average, but
only for the first 10 s of that stretch (a job stuck there is not read 20 times a second for hours)."""
from __future__ import annotations

import pytest

from app.routes.jobs import SSE_FINAL_FOR_S, SSE_FINAL_POLL_S, SSE_POLL_S, sse_poll_s


@pytest.mark.parametrize("doc, final_for_s, want", [
    ({"state": "running", "progress": 0.95}, 0.0, SSE_FINAL_POLL_S),
    ({"state": "running", "progress": 0.9}, SSE_FINAL_FOR_S - 0.1, SSE_FINAL_POLL_S),
    ({"state": "running", "progress": 0.95}, SSE_FINAL_FOR_S, SSE_POLL_S),
    ({"state": "running", "progress": 0.5}, 0.0, SSE_POLL_S),
    ({"state": "queued", "progress": 0.95}, 0.0, SSE_POLL_S),
])
def test_the_stream_reads_a_job_faster_only_in_its_last_stretch(doc, final_for_s, want):
    assert sse_poll_s(doc, final_for_s) == want
    assert SSE_FINAL_POLL_S < SSE_POLL_S <= 0.25
