"""The `calibration` job on small simulated campaigns, run in-process through the pipeline (fan-out run locally):
recovery of injected offsets and maps, identical maps on a re-run, refusals naming the set."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from bench.local_jobs import input_set, job_context, product_bytes
from gnssatt.calibration.simulated import compare_maps_mm, simulate_campaign, truth_map_mm, truth_of, truth_split
from worker.errors import JobInputError
from worker.jobs.calibration import HELD_OUT_ATTITUDE_DEFAULT, CalibrationConfig
from worker.jobs.calibration import run

BENIGN = {"noise": False, "multipath": False, "cn0_jitter_db": 0.0}
FAST_CFG = {"azimuth_step_deg": 10.0, "elevation_step_deg": 5.0, "min_count": 10}


@pytest.fixture(scope="module")
def pcv_campaign(benign_campaign_4x600):
    """Four 10-minute benign passes (no noise, no multipath) with the preset's offsets, PCO and 35 mm PCV."""
    return benign_campaign_4x600


def test_campaign_recovers_offsets_without_pcv(tmp_path):
    dirs = simulate_campaign(tmp_path / "sets", 3, 600.0, seed=5, overrides={**BENIGN, "pcv": False})
    ctx = job_context(tmp_path / "job", [input_set(d) for d in dirs])
    run(ctx, CalibrationConfig(**FAST_CFG))
    doc = json.loads(product_bytes(ctx)["baselines.json"])
    truth = truth_of(dirs[0])
    assert doc["frames"] == "body" and len(doc["baselines"]) == 2
    for b in doc["baselines"]:
        t = truth["baselines"][(b["from"], b["to"])]
        err_mm = (np.asarray(b["calibrated_m"]) - t["mean_m"]) * 1e3
        moved_mm = (np.asarray(b["a_priori_m"]) - t["mean_m"]) * 1e3
        # the a priori is several mm off (seed 000 Table 3 offsets); the calibration lands within 0.5 mm (only the
        # L1/L2 PCO difference is left without PCV and noise)
        assert np.max(np.abs(moved_mm)) > 4.0
        assert np.all(np.abs(err_mm) < 0.5), err_mm


def test_campaign_recovers_maps_and_is_deterministic(tmp_path, pcv_campaign):
    sets = [input_set(d) for d in pcv_campaign]
    cfg = CalibrationConfig(**FAST_CFG, held_out_set=sets[-1].id)
    ctx = job_context(tmp_path / "a", sets)
    run(ctx, cfg)
    prod = product_bytes(ctx)
    for name in ("baselines.json", "baselines.csv", "residual_statistics.json", "held_out_attitude.json",
                 "calibration_summary.json", "pcv_maps.png", "pcv_counts.png", "report.html"):
        assert name in prod, name
    report = prod["report.html"] if isinstance(prod["report.html"], str) else prod["report.html"].decode()
    assert "Table 3 layout" in report and "data:image/png;base64" in report
    assert len(ctx.pcv_maps) == 4 and ctx.pcv_maps[0][0].startswith("CASSIOPE-like calibration GPS-2>GPS-0 ")
    truth = truth_of(pcv_campaign[0])
    cal = {(b["from"], b["to"]): np.asarray(b["calibrated_m"]) for b in json.loads(prod["baselines.json"])["baselines"]}
    for first, second in cal:
        for sig in ("L1", "L2"):
            doc = json.loads(prod[f"pcv_{first}_{second}_{sig}.json"])
            values = np.array([[np.nan if v is None else v for v in row] for row in doc["values_mm"]])
            count = np.asarray(doc["count"])
            az, el = np.meshgrid(doc["azimuth_deg"], doc["elevation_deg"])
            want = truth_map_mm(truth, (first, second, sig), cal[(first, second)], az, el)
            rms = compare_maps_mm(values, want, count)
            print(first, second, sig, "map rms vs truth mm", round(rms, 3))
            # 10 x 5 deg bins averaging a bilinear 5-deg pattern with up to 50 mm p-p: a few mm of smoothing
            assert rms < 2.5, (first, second, sig, rms)
            assert np.nanmax(values) - np.nanmin(values) > 15.0  # a real pattern, not a flat map
    # the baselines against the injected truth in the calibration's baseline/map split (CONVENTIONS.md, no twin
    # needed): without noise only the within-bin spread of the samples (10 x 5 deg bins, g taken at the bin centres)
    # separates them; the solid-angle weights of the split give the low bins, where that spread matters most, more
    # weight than the former count weights (z -0.25 mm here, was < 0.2): 0.3 mm is issue 21's figure
    for first, second in cal:
        counts = {}
        for sig in ("L1", "L2"):
            doc = json.loads(prod[f"pcv_{first}_{second}_{sig}.json"])
            v = np.array([[np.nan if x is None else x for x in row] for row in doc["values_mm"]])
            counts[sig] = np.where(np.isfinite(v), np.asarray(doc["count"]), 0)
        b_true, maps_true = truth_split(truth, (first, second), doc["azimuth_deg"], doc["elevation_deg"], counts)
        err_mm = (cal[(first, second)] - b_true) * 1e3
        print(first, second, "baseline - truth (split) mm", np.round(err_mm, 3))
        assert np.all(np.abs(err_mm) < 0.3), err_mm
        phys_mm = (truth["baselines"][(first, second)]["mean_m"] - b_true) * 1e3
        assert np.max(np.abs(phys_mm)) > 1.0, phys_mm   # the PCV's offset-like part is in the baseline
    res = json.loads(prod["residual_statistics.json"])
    for key, after in res["after"].items():
        assert after["rms_mm"] < 0.5 * res["before"][key]["rms_mm"], key
    summary = json.loads(prod["calibration_summary.json"])
    assert all(m["converged"] for m in summary["maps"])
    # re-run: the same maps bit for bit
    ctx2 = job_context(tmp_path / "b", sets)
    run(ctx2, cfg)
    prod2 = product_bytes(ctx2)
    for name in prod:
        if name.startswith("pcv_") and name.endswith(".json") or name == "baselines.json":
            assert prod[name] == prod2[name], name


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("observations_*.csv"))
    return dst


def test_refuses_a_set_without_reference_attitude(tmp_path, pcv_campaign):
    sets = [input_set(pcv_campaign[0]), input_set(pcv_campaign[1], skip=("reference_attitude.csv",))]
    with pytest.raises(JobInputError) as exc:
        run(job_context(tmp_path, sets), CalibrationConfig(**FAST_CFG))
    assert "set_001" in exc.value.detail and "reference attitude" in exc.value.detail


def test_refuses_overlapping_sets(tmp_path, pcv_campaign):
    sets = [input_set(pcv_campaign[0]), input_set(pcv_campaign[1]), input_set(pcv_campaign[0], set_id="copy_of_0")]
    with pytest.raises(JobInputError) as exc:
        run(job_context(tmp_path, sets), CalibrationConfig(**FAST_CFG))
    assert "overlap" in exc.value.detail and "copy_of_0" in exc.value.detail and "set_000" in exc.value.detail


def test_refuses_a_set_of_another_platform(tmp_path, pcv_campaign):
    other = _copy(pcv_campaign[1], tmp_path / "other")
    doc = json.loads((other / "platform.json").read_text())
    doc["antennas"]["GPS-1"]["position_m"][1] = 1.2
    (other / "platform.json").write_text(json.dumps(doc))
    sets = [input_set(pcv_campaign[0]), input_set(other)]
    with pytest.raises(JobInputError) as exc:
        run(job_context(tmp_path / "job", sets), CalibrationConfig(**FAST_CFG))
    assert exc.value.title == "Set of another platform"
    assert "'other'" in exc.value.detail and "GPS-1" in exc.value.detail


def test_refuses_a_reference_that_does_not_cover_the_observations(tmp_path, pcv_campaign):
    cut = _copy(pcv_campaign[1], tmp_path / "cut")
    lines = (cut / "reference_attitude.csv").read_text().splitlines()
    (cut / "reference_attitude.csv").write_text("\n".join(lines[:200] + lines[260:]) + "\n")  # a 60 s hole
    sets = [input_set(pcv_campaign[0]), input_set(cut)]
    with pytest.raises(JobInputError) as exc:
        run(job_context(tmp_path / "job", sets), CalibrationConfig(**FAST_CFG))
    assert "'cut'" in exc.value.detail and "uncovered" in exc.value.detail and exc.value.file == "reference_attitude.csv"
    # with a gap limit above the hole it is bridged and accepted
    run(job_context(tmp_path / "job2", sets), CalibrationConfig(**FAST_CFG, max_reference_gap_s=120.0))


def test_config_refuses_a_grid_that_does_not_divide():
    with pytest.raises(ValueError):
        CalibrationConfig(azimuth_step_deg=7.0)
    with pytest.raises(ValueError):
        CalibrationConfig(elevation_step_deg=0.7)


def test_held_out_comparison_is_the_attitude_filter_with_the_published_calibration(tmp_path, pcv_campaign):
    """held_out_attitude.json comes from the attitude filter (dynamic mode, smoother, all phases: the default
    held_out_attitude_config) on the
    held-out set, a priori vs calibrated baselines + maps, and is exactly what an attitude job with the published
    baselines.json and maps (pcv_map_ids) gives; on this noiseless campaign the calibration removes the
    attitude bias that the Table 3 offsets and the PCV put into the a priori solution."""
    from gnssatt.attitude.process import load_inputs
    from gnssatt.calibration.held_out import filter_errors
    from worker.jobs.attitude import AttitudeConfig, maps_for_settings

    sets = [input_set(d) for d in pcv_campaign]
    ctx = job_context(tmp_path / "job", sets)
    run(ctx, CalibrationConfig(**FAST_CFG, held_out_set=sets[-1].id))
    prod = product_bytes(ctx)
    doc = json.loads(prod["held_out_attitude.json"])
    assert doc["method"].startswith("attitude filter (dynamic mode")
    w0, w1 = doc["without_calibration"], doc["with_calibration"]
    assert w0["fixed_epochs"] > 400 and w1["fixed_epochs"] > 300 and w0["wrong_fix_epochs"] == 0
    b0 = np.linalg.norm([w0[a]["bias_deg"] for a in ("yaw", "pitch", "roll")])
    b1 = np.linalg.norm([w1[a]["bias_deg"] for a in ("yaw", "pitch", "roll")])
    print("bias vector deg", b0, "->", b1, doc["cut"])
    assert b0 > 0.2          # the a priori baselines (Table 3 offsets, PCO, PCV) tilt the attitude
    assert b1 < 0.2 * b0     # the calibration removes >= 80 % of it
    assert set(doc["cut"]) == {"yaw", "pitch", "roll"}
    assert "z_yaw" in doc["epoch_wise"]["cut"]     # the epoch-wise (QUEST) block is kept as secondary
    report = prod["report.html"] if isinstance(prod["report.html"], str) else prod["report.html"].decode()
    assert "Held-out attitude (attitude filter" in report
    # an attitude job on the held-out set with the published products gives the same figures
    maps = [(name, json.loads(prod[name])) for name in sorted(prod) if name.startswith("pcv_") and
            name.endswith(".json")]
    inputs = load_inputs([(f.name, f.kind, f.path) for f in sets[-1].files])
    assert doc["attitude_config"] == HELD_OUT_ATTITUDE_DEFAULT
    settings = AttitudeConfig(**HELD_OUT_ATTITUDE_DEFAULT,
                              calibrated_baselines=json.loads(prod["baselines.json"])).to_settings()
    settings.calibration.pcv_maps = maps_for_settings(maps, list(inputs.platform.baselines))
    job = filter_errors(inputs, settings)
    for a in ("yaw", "pitch", "roll"):
        assert job[a]["bias_deg"] == w1[a]["bias_deg"] and job[a]["std_deg"] == w1[a]["std_deg"], (a, job, w1)
    assert job["fixed_epochs"] == w1["fixed_epochs"]


def test_held_out_attitude_config_is_an_attitude_job_config():
    """held_out_attitude_config is validated as an attitude job config; the calibration's own baselines and maps
    cannot be overridden there."""
    from pydantic import ValidationError

    assert CalibrationConfig(held_out_attitude_config={"mode": "kinematic"}).held_out_attitude_config["mode"] == \
        "kinematic"
    assert CalibrationConfig().held_out_attitude_config == HELD_OUT_ATTITUDE_DEFAULT
    assert CalibrationConfig(held_out_attitude_config={}).held_out_attitude_config == {}
    for bad in ({"calibrated_baselines": {}}, {"pcv_map_ids": ["x"]}, {"no_such_setting": 1}, {"mode": "other"}):
        with pytest.raises(ValidationError) as exc:
            CalibrationConfig(held_out_attitude_config=bad)
        assert "held_out_attitude_config" in str(exc.value), bad
