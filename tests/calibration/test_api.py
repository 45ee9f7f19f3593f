"""gnssatt.calibration.run_campaign, the library's one-call campaign: on simulated set folders it gives the
calibration job's products byte for byte (but the run-time fields), whatever order its map function runs the
tasks in; the passes reach the map function as FanOut records; refusals come as CampaignError."""
from __future__ import annotations

import json

import pytest

from bench.local_jobs import input_set, job_context, product_bytes
from gnssatt.calibration import CampaignError, CampaignOptions, run_campaign
from gnssatt.calibration.binning import Grid2D
from gnssatt.calibration.simulated import simulate_campaign
from gnssatt.calibration.tasks import HELD_OUT_COST, STAGE_PASS1, STAGE_PASS2, run_task, task_cost
from gnssatt.product_files import product_bytes as encode
from worker.jobs.calibration import CalibrationConfig, run

BENIGN = {"noise": False, "multipath": False, "cn0_jitter_db": 0.0}
FAST_CFG = {"azimuth_step_deg": 10.0, "elevation_step_deg": 5.0, "min_count": 10}


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Three 5-minute benign passes (the preset's offsets, PCO and PCV, no noise or multipath)."""
    return simulate_campaign(tmp_path_factory.mktemp("cal_api"), 3, 300.0, seed=11, overrides=BENIGN)


def _without_run_time(doc):
    """The document without wall/CPU seconds and the runtime's per-worker record."""
    if isinstance(doc, dict):
        return {k: _without_run_time(v) for k, v in doc.items()
                if k not in ("timing_s", "workers") and not k.endswith(("seconds", "cpu_s"))}
    if isinstance(doc, list):
        return [_without_run_time(v) for v in doc]
    return doc


def test_run_campaign_gives_the_job_products_in_any_task_order(tmp_path, campaign):
    ctx = job_context(tmp_path / "job", [input_set(d) for d in campaign])
    run(ctx, CalibrationConfig(**FAST_CFG, held_out_set="set_002"))
    job = product_bytes(ctx)

    options = CampaignOptions(grid=Grid2D.regular(10.0, 5.0))
    fans = []

    def reversed_map(fan):
        """Runs the tasks last first (as a queue of workers might) and hands the results back in task order."""
        fans.append(fan)
        sets = [input_set(d) for d in campaign]
        return [run_task(fan, t, sets, options) for t in fan.tasks[::-1]][::-1]

    result = run_campaign(campaign, options=options, held_out="set_002", map_fn=reversed_map)
    lib = {name: encode(content) for name, content in result.products(job_id=ctx.job_id).items()}

    assert set(lib) == set(job) - {"tasks.csv"}
    for name in lib:
        if name in ("calibration_summary.json", "held_out_attitude.json"):
            assert _without_run_time(json.loads(lib[name])) == _without_run_time(json.loads(job[name])), name
        elif name != "report.html":     # its time stamp and the seconds in its tables
            assert lib[name] == job[name], name
    assert result.pcv_maps == \
        {key: json.loads(job[f"pcv_{key[0]}_{key[1]}_{key[2]}.json"]) for key in result.pcv_maps}

    # the passes as the map function saw them: pass 1 over the calibration sets, pass 2 with the held-out set last,
    # its cost raised for the two attitude filter runs, and the calibration shared by every task
    assert [(f.pass_number, f.stage) for f in fans] == [(1, STAGE_PASS1), (2, STAGE_PASS2)]
    assert [t.label for t in fans[0].tasks] == ["set_000", "set_001"] and not any(t.held_out for t in fans[0].tasks)
    assert [(t.label, t.held_out) for t in fans[1].tasks] == [("set_000", False), ("set_001", False),
                                                              ("set_002", True)]
    held_span_s = task_cost(input_set(campaign[2]))
    assert held_span_s > 250.0 and fans[1].tasks[2].cost_s == HELD_OUT_COST * held_span_s
    assert set(fans[1].shared) == {"calibrated", "maps"} and fans[1].held_out is not None
    assert result.sets == ["set_000", "set_001"] and result.held_out_set == ["set_002"]
    assert {r["angle"] for r in result.held_out_table} == {"yaw", "pitch", "roll"}


def test_write_products_and_refusals(tmp_path, campaign):
    result = run_campaign(campaign[:2], options=CampaignOptions(grid=Grid2D.regular(10.0, 5.0)))
    written = result.write_products(tmp_path / "out")
    assert {"baselines.json", "baselines.csv", "residual_statistics.json", "calibration_summary.json",
            "pcv_maps.png", "report.html"} <= set(written)
    assert "held_out_attitude.json" not in written and result.held_out_attitude is None
    summary = json.loads(written["calibration_summary.json"].read_text())
    assert summary["sets"] == 2 and "workers" not in summary
    assert summary["grid"] == {"azimuth_step_deg": 10.0, "elevation_step_deg": 5.0,
                               "elevation_range_deg": [0.0, 90.0], "min_count": 10}
    with pytest.raises(CampaignError) as exc:
        run_campaign(campaign, held_out="no_such_set")
    assert exc.value.title == "Unknown held-out set" and "no_such_set" in exc.value.detail
    with pytest.raises(CampaignError) as exc:
        run_campaign([campaign[0], campaign[0]])
    assert exc.value.title == "Sets overlap in time"
