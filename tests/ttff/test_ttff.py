"""The TTFF study (issue 7) on a few short simulated starts: truth integers read right, single-epoch solutions
checked against them, the study rows and the Table 5 layout, the job pipeline's products, refusals."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from tests.attitude.conftest import set_files
from worker.context import JobContext
from worker.errors import JobInputError
from worker.jobs.ttff import TtffConfig
from worker.pipelines.ttff import payloads, run
from gnssatt.sim import simulate_scenario
from gnssatt.ttff.data import load_study_set, subset_signals
from gnssatt.ttff.single_epoch import SingleEpochOptions, epoch_problem, solve_constrained, solve_lambda
from gnssatt.ttff.starts import BENIGN_OVERRIDES, random_starts, start_overrides
from gnssatt.ttff.study import StudyOptions, run_set, runs_csv, summarize, table5_rows

DURATION_S = 20.0


@pytest.fixture(scope="module")
def sim_set(tmp_path_factory):
    """One realistic start (yaw 120, pitch -50, roll 30 deg), 20 s."""
    d = tmp_path_factory.mktemp("ttff_set")
    start = {"index": 3, "yaw_deg": 120.0, "pitch_deg": -50.0, "roll_deg": 30.0, "rate_deg_s": 0.3}
    simulate_scenario("ttff", d, seed=11, overrides=start_overrides(start, DURATION_S))
    return d, start


@pytest.fixture(scope="module")
def study_set(sim_set):
    d, _ = sim_set
    return load_study_set(set_files(d), "start 3", truth_dir=d / "truth")


def test_random_starts_ranges_and_determinism():
    a = random_starts(300, 5)
    assert a == random_starts(300, 5) and a != random_starts(300, 6)
    y = np.array([s["yaw_deg"] for s in a])
    p = np.array([s["pitch_deg"] for s in a])
    r = np.array([s["roll_deg"] for s in a])
    w = np.array([s["rate_deg_s"] for s in a])
    assert np.abs(y).max() <= 180 and np.abs(y).max() > 170
    assert np.abs(p).max() <= 70 and np.abs(r).max() <= 40
    assert w.min() >= 0.1 and w.max() <= 0.5


def test_initial_offset_is_the_simulated_start(study_set, sim_set):
    from gnssatt.ttff.data import initial_offset_euler_deg
    _, start = sim_set
    y, p, r = initial_offset_euler_deg(study_set)
    # reference attitude noise 3 arcsec; the slew starts at rest (min-jerk)
    assert abs(y - start["yaw_deg"]) < 0.01 and abs(p - start["pitch_deg"]) < 0.01 and abs(r - start["roll_deg"]) < 0.01


def test_truth_integers_explain_the_phases(study_set):
    """DD phase - DD range / lambda - DD truth integer is a small fraction of a cycle (noise, multipath, PCV)."""
    ss = study_set
    k = 5
    R = ss.truth.R_body_from_ecef[k]
    for f, lam in enumerate(ss.pobs.wavelength_m):
        for j, (a, b) in enumerate(ss.bl_idx):
            b_ecef = ss.body_baselines_m[j] @ R
            sd = ss.pobs.phase_m[b, k, :, f] - ss.pobs.phase_m[a, k, :, f] + ss.geom.los_ecef[k] @ b_ecef
            n = ss.truth.n_cyc[b, k, :, f] - ss.truth.n_cyc[a, k, :, f]
            res = sd / lam - n
            m = np.isfinite(res)
            dd = res[m] - res[m][0]
            assert m.sum() >= 5
            assert np.abs(dd).max() < 0.5, (f, j, dd)
            # a wrong integer would leave whole cycles: the truth must not be off by any
            assert np.abs(np.round(dd)).max() == 0


def test_single_epoch_l1_both_methods_right(study_set):
    opts = SingleEpochOptions()
    n_right = {"lambda": 0, "constrained": 0}
    n = 0
    for k in range(0, len(study_set.t_s), 4):
        prob = epoch_problem(study_set, k, ["L1"], opts)
        assert prob is not None and prob.usable.all()
        assert all(t is not None for t in prob.truth_dd)
        n += 1
        for name, fn in (("lambda", solve_lambda), ("constrained", solve_constrained)):
            out = fn(prob, study_set.body_baselines_m, opts)
            assert not any(c is False for c in out.correct), (name, k, out.detail)   # never a wrong fix
            n_right[name] += int(all(c is True for c in out.correct))
    assert n_right["constrained"] >= n - 1
    assert n_right["lambda"] >= 1


def test_judge_flags_a_wrong_integer(study_set):
    """Shifting the truth by one cycle on one DD must make the check say 'wrong'."""
    from gnssatt.ttff.single_epoch import _judge
    prob = epoch_problem(study_set, 0, ["L1"], SingleEpochOptions())
    rows = {i: t.copy() for i, (blk, t) in enumerate(zip(prob.sol.blocks, prob.truth_dd)) if blk.baseline == 0}
    assert _judge(prob, 0, rows, prob.b_true_ecef_m[0]) is True
    first = next(iter(rows))
    rows[first][0] += 1
    assert _judge(prob, 0, rows, prob.b_true_ecef_m[0]) is False


def test_subset_signals(study_set):
    p = subset_signals(study_set.pobs, ["L2"])
    assert p.signals == ["L2"] and p.code_m.shape[-1] == 1
    np.testing.assert_array_equal(p.phase_m[..., 0], study_set.pobs.phase_m[..., 1])


def test_run_set_rows_and_table(study_set):
    opts = StudyOptions(configurations=("L1+L2", "L1"), methods=("filter", "epoch-constrained"),
                        single_epoch_step_s=5.0)
    res = run_set(study_set, opts)
    rows = res["runs"]
    assert len(rows) == 2 * 2 * 2          # configurations x methods x baselines
    for r in rows:
        assert r["yaw_deg"] == pytest.approx(120.0, abs=0.01)
        if r["ttff_s"] is not None:
            assert r["fix_right"] is True, r        # no wrong first fix on this start
    dual = [r for r in rows if r["configuration"] == "L1+L2" and r["method"] == "filter"]
    assert all(r["ttff_s"] is not None and r["ttff_s"] <= 5.0 for r in dual)
    con = [r for r in rows if r["method"] == "epoch-constrained"]
    assert all(r["single_epoch_n"] == 5 and r["single_epoch_wrong"] == 0 for r in con)
    t = table5_rows(rows, "filter")
    assert t["columns"][:3] == ["Yaw [deg]", "Pitch [deg]", "Roll [deg]"] and len(t["columns"]) == 3 + 4
    assert [f[0] for f in t["footer"]] == ["Instant fix [%]", "Mean TTFF (> 0) [s]", "Never fixed",
                                           "Wrong first fix"]
    s = summarize(rows)
    assert s["sets"] == 1 and s["wrong_fixes_total"] == 0
    assert runs_csv(rows).count("\n") == len(rows) + 1


def test_summary_counts_instant_and_wrong():
    base = {"yaw_deg": 0, "pitch_deg": 0, "roll_deg": 0, "configuration": "L1", "baseline": "A>B",
            "method": "filter", "fix_error_deg": None, "wrong_fixed_epochs": 0, "fixed_epochs": 1}
    rows = [dict(base, set="s1", ttff_s=0.0, fix_right=True), dict(base, set="s2", ttff_s=4.0, fix_right=False),
            dict(base, set="s3", ttff_s=None, fix_right=None), dict(base, set="s4", ttff_s=2.0, fix_right=True)]
    d = summarize(rows)["methods"]["filter"]["L1"]["A>B"]
    assert d["instant_fix_share"] == 0.25 and d["mean_nonzero_ttff_s"] == 3.0
    assert d["never_fixed"] == 1 and d["wrong_first_fixes"] == 1
    t = table5_rows(rows, "filter")
    assert t["rows"][1][3] == "4.0*" and t["rows"][2][3] == "–"
    assert t["footer"][0][3] == "25" and t["footer"][3][3] == "1"


def _ctx(tmp: Path, sets) -> JobContext:
    def store(path: Path):
        data = Path(path).read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)
    return JobContext(job_id="t", attempt=1, sets=sets, workdir=tmp, _store_blob=store)


def test_pipeline_simulated_and_uploaded(tmp_path, sim_set):
    from worker.context import InputFile, InputSet
    d, _ = sim_set
    up = InputSet("set-1", "uploaded start", [InputFile(n, k, p, {}) for n, k, p in set_files(d)], {})
    cfg = TtffConfig.model_validate({"simulate": {"count": 2, "seed": 4}, "duration_s": 15.0,
                                     "configurations": ["L1"], "methods": ["filter", "epoch-constrained"],
                                     "single_epoch_step_s": 5.0})
    ctx = _ctx(tmp_path, [up])
    run(ctx, cfg)
    assert {"runs.csv", "runs.json", "summary.json", "table5.html", "table5_filter.csv", "table5_filter.md",
            "table5_epoch-constrained.md", "report.html", "ttff_table.png", "ttff_histogram.png"} <= set(ctx.products)
    report = (tmp_path / "products" / "report.html").read_text()
    assert "Time to first fix" in report and "Table 5 layout, method filter" in report and "<script" not in report
    summary = json.loads((tmp_path / "products" / "summary.json").read_text())
    assert summary["sets"] == 3
    assert summary["tasks_per_worker"]["local"][0] == 3 and summary["task_cpu_seconds_total"] > 0
    labels = [s["label"] for s in summary["sets_list"]]
    assert labels == ["uploaded start", "start 000", "start 001"]
    # the uploaded set has no arcs.csv: checked by the reference attitude only
    assert summary["sets_list"][0]["truth"] == "reference attitude"
    assert summary["sets_list"][1]["truth"].endswith("arcs.csv")
    runs = json.loads((tmp_path / "products" / "runs.json").read_text())["runs"]
    assert len(runs) == 3 * 2 * 2
    assert not any(r["fix_right"] is False for r in runs)


def test_pipeline_refusals(tmp_path):
    with pytest.raises(JobInputError):
        run(_ctx(tmp_path, []), TtffConfig())
    with pytest.raises(JobInputError):
        run(_ctx(tmp_path / "b", []), TtffConfig.model_validate({"simulate": {"count": 1, "overrides":
                                                                              {"no_such_parameter": 1}}}))
    with pytest.raises(ValueError):
        TtffConfig.model_validate({"methods": ["filter", "filter"]})
    with pytest.raises(ValueError):
        TtffConfig.model_validate({"simulate": {"rate_deg_s": [0.5, 0.1]}})


def test_payloads_are_deterministic():
    from types import SimpleNamespace
    cfg = TtffConfig.model_validate({"simulate": {"count": 3, "seed": 2}})
    a = payloads(SimpleNamespace(sets=[]), cfg)
    assert a == payloads(SimpleNamespace(sets=[]), cfg) and len(a) == 3
    assert "pcv" not in a[0]["overrides"]          # realism is the preset's own
    from worker.pipelines.ttff import _options
    assert _options(a[0]["options"]).filter_settings_by_configuration == {"L2": {"ambiguity": {"min_ratio_first_fix": 2.0}}}
    b = payloads(SimpleNamespace(sets=[]), TtffConfig.model_validate({"simulate": {"count": 3, "seed": 2,
                                                                                   "realistic": False}}))
    assert all(b[0]["overrides"][k] == v for k, v in BENIGN_OVERRIDES.items())
    assert a[0]["overrides"]["start_gps"] != a[1]["overrides"]["start_gps"]


def test_job_type_registered():
    from worker.jobs.registry import job_types
    spec = job_types()["ttff"]
    assert spec.min_sets == 0 and spec.max_sets is None


def test_ttff_preset_carries_the_realism_and_other_presets_are_unchanged():
    """Issue 7 item 2 is the preset itself (no bench-level overrides); the other presets keep their values."""
    from gnssatt.sim.observables import noise_scale
    from gnssatt.sim.scenarios import make_params

    p = make_params("ttff")
    assert p.pcv_peak_to_peak_mm == 35.0 and p.mp_code_m == [0.1, 1.0, 2.0]
    assert p.noise_grows_with_cn0 and p.noise_scale_max == 2.0 and p.l2_noise_factor == 1.2
    for name in ("earth-pointing", "slew", "hard", "cubesat", "calibration"):
        q = make_params(name)
        assert q.noise_scale_max == 4.0 and q.l2_noise_factor == 1.5
    assert make_params("earth-pointing").pcv_peak_to_peak_mm == 10.0
    assert make_params("earth-pointing").mp_code_m == [0.1, 0.6, 1.5]
    cn0 = np.array([50.0, 45.0, 39.0, 30.0, 20.0])
    np.testing.assert_allclose(noise_scale(cn0, 45.0, True), np.clip(10 ** ((45 - cn0) / 20), 0.5, 4.0))
    np.testing.assert_allclose(noise_scale(cn0, 45.0, True, 2.0)[2:], [10 ** 0.3, 2.0, 2.0])


def test_filter_integers_scored_against_truth(study_set):
    """The filter's integer constraints agree with the truth arcs; one cycle off on one constraint is flagged
    from its epoch on, on its baseline only."""
    from gnssatt.attitude.filter import run_filter
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.ttff.study import filter_integer_errors

    ss = study_set
    fr = run_filter(ss.pobs, ss.geom, ss.bl_idx, ss.body_baselines_m, ss.boresight_body,
                    AttitudeSettings.preset("seed000", signals=["L1", "L2"]), ss.R_ref_from_ecef[0])
    log = fr.fix_log
    assert log["epoch"].size >= 10
    w = filter_integer_errors(ss, log, ["L1", "L2"])
    assert w.shape == fr.fixed.shape and not w.any()
    bad = {k: np.array(v, copy=True) for k, v in log.items()}
    i = int(np.argmax(bad["bl"] == 1))
    bad["dd_cyc"][i] += 1
    w = filter_integer_errors(ss, bad, ["L1", "L2"])
    assert w[bad["epoch"][i]:bad["last_epoch"][i] + 1, 1].all() and not w[:, 0].any()
    assert not w[:bad["epoch"][i], 1].any()
