"""The attitude job on short simulated passes against the simulator's truth/attitude.csv (issue 6).

Short passes (6 minutes) keep the suite fast; the 106-minute figures of the Done-when are in
bench/bench_attitude.py and docs/BENCHMARKS.md.
"""
from __future__ import annotations

import csv

import numpy as np
import pytest

from tests.attitude.conftest import set_files
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.products import all_products
from gnssatt.attitude.settings import AttitudeSettings
from gnssatt.attitude.truth import (attitude_errors_deg, clock_jump_match, score_fixes,
                                    slips_seen_by_single_differences)


@pytest.fixture(scope="module")
def clean_solutions(clean_pass):
    inputs = load_inputs(set_files(clean_pass))
    return {m: process(inputs, AttitudeSettings.preset("seed000", mode=m)) for m in ("kinematic", "dynamic")}


def test_clean_pass_fixes_quickly_and_never_wrongly(clean_pass, clean_solutions):
    for mode, sol in clean_solutions.items():
        ang, _ = attitude_errors_deg(clean_pass, sol)
        fixed = sol.att_fixed
        assert fixed.mean() >= 0.95, (mode, fixed.mean())
        assert np.argmax(fixed) <= 30, "first fix within 30 s of switch-on"
        # stricter than the wrong-fix definition (gnssatt.attitude.wrong_fix: beyond 6 own sigmas and 1 deg): every
        # fixed epoch within 1 deg of the truth; kinematic epochs are single-epoch solutions whose noise (sigma ~0.3
        # deg in pitch/roll, seed 000 Table 4) may exceed 1 deg at 3-4 sigma, so there the limit is also 5 sigmas
        lim = np.maximum(1.0, 5.0 * np.sqrt(np.sum(sol.sigma_euler_deg ** 2, axis=1))) if mode == "kinematic" \
            else 1.0
        assert np.all((ang < lim)[fixed]), f"{mode}: wrong fix (error {ang[fixed].max():.2f} deg while fixed)"
        for b in sol.summary["baselines"]:
            assert b["time_to_first_fix_s"] is not None and b["time_to_first_fix_s"] <= 30


def test_clean_pass_errors_are_unbiased_and_match_the_predicted_sigma(clean_pass, clean_solutions):
    sol = clean_solutions["kinematic"]
    _, de = attitude_errors_deg(clean_pass, sol)
    f = sol.att_fixed
    for i, name in enumerate(("yaw", "pitch", "roll")):
        bias, std = de[f, i].mean(), de[f, i].std()
        pred = np.sqrt(np.mean(sol.sigma_euler_deg[f, i] ** 2))
        assert abs(bias) < 0.1, (name, bias)
        assert 0.6 < std / pred < 1.4, f"{name}: actual {std:.3f} vs predicted {pred:.3f} deg"


def test_noise_model_learns_white_receivers(clean_solutions):
    """White noise independent of C/N0 (the clean pass): no C/N0 growth and a small multipath scale are learnt."""
    for sol in clean_solutions.values():
        nm = sol.summary["noise_model"]
        assert all(g < 0.3 for g in nm["cn0_gamma_phase"].values()), nm
        assert nm["multipath_scale"] < 0.6, nm
        # the simulator's 3 mm per receiver is 4.2 mm per SD on L1 (x1.5 on L2 P(Y))
        assert 0.0036 < nm["sigma_phase_white_m"]["L1"] < 0.0048, nm


def test_dynamic_mode_beats_kinematic_mode_on_every_angle(clean_pass, clean_solutions):
    stds = {}
    for mode, sol in clean_solutions.items():
        _, de = attitude_errors_deg(clean_pass, sol)
        stds[mode] = de[sol.att_fixed].std(axis=0)
    assert np.all(stds["dynamic"] < stds["kinematic"]), stds


def test_reference_attitude_statistics_in_summary(clean_solutions):
    s = clean_solutions["dynamic"].summary          # kinematic epochs may pass 1 deg by noise (see above)
    ref = s["reference"]
    assert ref["frame"] == "GCRF" and ref["wrong_fix_epochs"] == 0 and ref["over_1deg_epochs"] == 0
    for name in ("yaw", "pitch", "roll"):
        st = ref["fixed"][name]
        assert st["sigma_deg"] > 0 and st["predicted_sigma_deg"] > 0
    for b in s["baselines"]:
        # seed 000 eq. 3-4 expectations are present and of the Table 4 order (tenths of a degree)
        assert 0.02 < b["expected_sigma_yaw_deg"] < 1.0 and 0.3 < b["hdop"] < 5 and 0.3 < b["vdop"] < 5


def test_summary_wrong_fixes_follow_the_one_definition(clean_pass, clean_solutions):
    """summary.json's reference counts, the quality block's and a count from the simulator's truth made here (an
    axis error beyond 6 own sigmas and 1 deg; over 1 deg otherwise) agree in both modes. On this clean pass they
    are all 0; non-zero counts are checked in tests/attitude/test_wrong_fix.py (hand-made errors) and
    tests/products/test_quality.py (against the reference, computed independently)."""
    from gnssatt.attitude.quality import quality_block, reference_series

    for mode, sol in clean_solutions.items():
        _, de = attitude_errors_deg(clean_pass, sol)
        f = sol.att_fixed
        big = np.abs(de[f]) > 1.0
        wrong = (big & (np.abs(de[f]) > 6.0 * sol.sigma_euler_deg[f])).any(axis=1)
        over = big.any(axis=1) & ~wrong
        ref = sol.summary["reference"]
        assert ref["fixed_epochs_compared"] == int(f.sum()), mode
        assert (ref["wrong_fix_epochs"], ref["over_1deg_epochs"]) == (int(wrong.sum()), int(over.sum())), mode
        items = {it["key"]: it for it in quality_block(sol, reference_series(sol))["items"]}
        assert (items["wrong_fixes"]["value"], items["wrong_fixes"]["over_1deg"]) == (int(wrong.sum()),
                                                                                      int(over.sum())), mode


def test_products_follow_conventions_and_aem_parses(clean_solutions):
    sol = clean_solutions["dynamic"]
    prods = all_products(sol)
    att = prods["attitude.csv"].splitlines()
    assert att[0].split(",")[:19] == ["time_gps", "gps_week", "gps_sow", "qe_w", "qe_x", "qe_y", "qe_z", "qi_w",
                                      "qi_x", "qi_y", "qi_z", "yaw_deg", "pitch_deg", "roll_deg", "sigma_yaw_deg",
                                      "sigma_pitch_deg", "sigma_roll_deg", "fixed", "n_sats"]
    rows = [r.split(",") for r in att[1:]]
    q = np.array([[float(v) for v in r[3:11]] for r in rows])
    assert np.all(q[:, 0] >= 0) and np.all(q[:, 4] >= 0)
    assert np.allclose(np.linalg.norm(q[:, :4], axis=1), 1, atol=1e-9)
    times = [r[0] for r in rows]
    assert times == sorted(times)
    bl = prods["baselines.csv"].splitlines()
    assert bl[0].startswith("time_gps,gps_week,gps_sow,baseline,x_ecef_m,y_ecef_m,z_ecef_m,length_m,azimuth_deg")
    assert prods["events.csv"].startswith("time_gps,gps_sow,event,")
    assert "fix" in prods["events.csv"]
    res = prods["residuals.csv"].splitlines()
    assert len(res) > 1000 and ",phase," in res[5] or ",code," in res[5]
    from ccsds_ndm.ndm_io import NdmIo

    aem = NdmIo().from_string(prods["attitude.aem"])
    assert type(aem).__name__.lower().startswith("aem")
    text = prods["attitude.aem"]
    assert text.count("\n") > len(rows)


def test_slew_keeps_the_fix(slew_pass):
    sol = process(load_inputs(set_files(slew_pass)), AttitudeSettings.preset("seed000", mode="dynamic"))
    ang, _ = attitude_errors_deg(slew_pass, sol)
    f = sol.att_fixed
    first = int(np.argmax(f))
    assert f[first:].mean() > 0.99, "no fix lost during the slew"
    assert np.percentile(ang[f], 95) < 0.6
    assert "fix_lost" not in sol.summary["events"]


def test_hard_pass_completes_and_reports_every_event(hard_pass):
    sol = process(load_inputs(set_files(hard_pass)), AttitudeSettings.preset("seed000", mode="kinematic"))
    ev = sol.summary["events"]
    # every integer the filter fixed is the truth's, over the whole time it was held (slips after a fix included)
    sc = score_fixes(sol, hard_pass / "truth")
    assert sc["constraints"] > 20 and sc["wrong_constraints"] == 0, sc["details"]
    # every slip the single differences can see is in events.csv (with or without LLI, phase in use or not)
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)
    seen = {(e["sat"], e["signal"], t[e["epoch"]]) for e in sol.fr.events if e["event"] == "cycle_slip"}
    slips = slips_seen_by_single_differences(sol, hard_pass / "truth")
    assert len(slips) >= 5
    missed = [x for x in slips if not any(s == x[0] and f == x[1] and abs(tt - x[2]) < 1.5 for s, f, tt in seen)]
    assert not missed, missed
    assert ev.get("cycle_slip", 0) > 0
    assert ev.get("fix", 0) >= 2
    arcs = list(csv.DictReader(open(hard_pass / "truth" / "arcs.csv")))
    assert any(a["cause"] == "slip" for a in arcs)
    jumps, missed, spurious = clock_jump_match(sol, hard_pass / "truth")
    assert jumps and not missed and not spurious, (jumps, missed, spurious)
    # nothing is carried into the all-receiver outage: no attitude rows inside it
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    assert not np.any((t > 201) & (t < 229))
    prods = all_products(sol)
    assert "clock_jump" in prods["events.csv"] or ev.get("clock_jump", 0) == 0


@pytest.mark.parametrize("mode", ["kinematic", "dynamic"])
def test_realistic_pass_right_integers_and_honest_sigma(realistic_pass, mode):
    """Multipath, PCV and C/N0-dependent noise: every fixed integer is the truth's and the errors' scatter matches
    the predicted sigma (noise model: C/N0 growth of the white noise + off-boresight multipath variance, inflated
    for its time correlation in dynamic mode; docs/attitude.md)."""
    sol = process(load_inputs(set_files(realistic_pass)), AttitudeSettings.preset("seed000", mode=mode))
    sc = score_fixes(sol, realistic_pass / "truth")
    assert sc["constraints"] > 10 and sc["wrong_constraints"] == 0, sc["details"]
    # the simulator's noise grows as 10^((45 - C/N0)/20) in sigma: the estimated variance exponent is ~1
    nm = sol.summary["noise_model"]
    assert all(0.7 < g < 1.3 for g in nm["cn0_gamma_phase"].values()), nm
    _, de = attitude_errors_deg(realistic_pass, sol)
    f = sol.att_fixed
    assert f.mean() > 0.95
    # the scatter against the sigma without the antennas' consider term (a constant error per pass, not in a std;
    # gnssatt.attitude.antenna_consider, tested in test_antenna_consider.py)
    sig2 = sol.sigma_euler_deg ** 2 - sol.sigma_consider_euler_deg ** 2
    assert np.all(sol.sigma_consider_euler_deg[f] > 0)
    for i, name in enumerate(("yaw", "pitch", "roll")):
        std, pred = de[f, i].std(), np.sqrt(np.mean(sig2[f, i]))
        assert 0.65 < std / pred < 1.35, f"{mode} {name}: actual {std:.3f} vs predicted {pred:.3f} deg"


def test_ml_attitude_is_more_accurate_than_quest_in_kinematic_mode(clean_pass, clean_solutions):
    """attitude_method "ml" on the same filter run: lower error rms than QUEST, and its predicted sigmas honest."""
    sol_q = clean_solutions["kinematic"]
    sol_m = process(load_inputs(set_files(clean_pass)), AttitudeSettings.preset("seed000", mode="kinematic", attitude_method="ml"))
    assert np.array_equal(sol_q.att_fixed, sol_m.att_fixed)
    f = sol_q.att_fixed
    ang_q, _ = attitude_errors_deg(clean_pass, sol_q)
    ang_m, de_m = attitude_errors_deg(clean_pass, sol_m)
    rms = lambda a: float(np.sqrt(np.mean(a[f] ** 2)))  # noqa: E731
    assert rms(ang_m) < 0.97 * rms(ang_q), (rms(ang_m), rms(ang_q))
    ratio = de_m[f].std(0) / np.sqrt(np.mean(sol_m.sigma_euler_deg[f] ** 2, 0))
    assert np.all((0.6 < ratio) & (ratio < 1.3)), ratio
