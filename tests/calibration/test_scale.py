"""Fan-out order of the calibration pipeline (longest first, results back in set order) and its task log."""
from __future__ import annotations

import csv
import io
from datetime import datetime, timedelta, timezone

from gnssatt.calibration.tasks import STAGE_PASS1, STAGE_PASS2
from worker.jobs.calibration import _longest_first, _map_in_order, tasks_csv, workers_summary


class _RecordingCtx:
    """A ctx whose map runs the payloads in the order given (as the queue would) and remembers that order."""

    def __init__(self):
        self.seen: list[str] = []

    def map(self, function, payloads, **kw):
        self.seen = [p["label"] for p in payloads]
        return [{"echo": p["label"]} for p in payloads]


def test_longest_first_with_ties_in_set_order():
    payloads = [{"label": x} for x in "abcde"]
    assert _longest_first(payloads, [10.0, 30.0, 10.0, 90.0, 30.0]) == [3, 1, 4, 0, 2]


def test_map_in_order_queues_longest_first_and_returns_set_order():
    ctx = _RecordingCtx()
    payloads = [{"label": x} for x in ("s0", "s1", "held")]
    out = _map_in_order(ctx, "m:f", payloads, [600.0, 900.0, 3 * 600.0])
    assert ctx.seen == ["held", "s1", "s0"]
    assert [r["echo"] for r in out] == ["s0", "s1", "held"]


def test_tasks_csv_and_workers_summary():
    t0 = datetime(2026, 1, 1, tzinfo=timezone.utc)
    rec = [{"stage": STAGE_PASS1, "index": 0, "label": "set,a", "worker": "w1", "attempts": 1,
            "started_at": t0 + timedelta(seconds=1), "finished_at": t0 + timedelta(seconds=3.5), "seconds": 2.5},
           {"stage": STAGE_PASS2, "index": 0, "label": "held", "worker": "w2", "attempts": 2,
            "started_at": t0 + timedelta(seconds=4), "finished_at": t0 + timedelta(seconds=5), "seconds": 1.0},
           {"stage": STAGE_PASS2, "index": 1, "label": "set,a", "worker": "w1", "attempts": 1,
            "started_at": t0 + timedelta(seconds=4), "finished_at": t0 + timedelta(seconds=4.25), "seconds": 0.25}]
    rows = list(csv.DictReader(io.StringIO(tasks_csv(rec, t0))))
    assert [(r["pass"], r["task"], r["set"], r["worker"]) for r in rows] == [
        ("1", "0", "set,a", "w1"), ("2", "0", "held", "w2"), ("2", "1", "set,a", "w1")]
    assert [float(r["start_s"]) for r in rows] == [1.0, 4.0, 4.0]
    assert [float(r["end_s"]) for r in rows] == [3.5, 5.0, 4.25] and rows[1]["attempts"] == "2"
    assert workers_summary(rec) == {"w1": {"tasks": 2, "busy_s": 2.75}, "w2": {"tasks": 1, "busy_s": 1.0}}


def echo_shared_task(payload, sets):
    return {"label": payload["label"], "shared": payload["_shared"]["maps"], "has_sha": "_shared_sha256" in payload}


def test_ctx_map_hands_the_shared_object_to_every_task(tmp_path):
    """ctx.map(shared=...) without a service: every task sees payload["_shared"] (with a service the object is
    stored once in the blob store; tests/e2e/test_calibration_scale.py covers that path)."""
    from worker.context import JobContext

    ctx = JobContext(job_id="t", attempt=1, sets=[], workdir=tmp_path, _store_blob=lambda p: ("x", 0))
    out = ctx.map("tests.calibration.test_scale:echo_shared_task", [{"label": "a"}, {"label": "b"}],
                  shared={"maps": [1.5, None]})
    assert out == [{"label": "a", "shared": [1.5, None], "has_sha": False},
                   {"label": "b", "shared": [1.5, None], "has_sha": False}]
    assert [r["label"] for r in ctx.task_records] == ["a", "b"] and ctx.task_records[0]["worker"] == "local"
