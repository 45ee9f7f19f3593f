"""The comparison of bench/bench_products_identity.py finds what it must: a change above 1e-6 deg / m, a
quaternion rotation, a last-digit flip (counted apart), a changed event row, a summary key on one side only."""
from __future__ import annotations

import json

from bench.bench_products_identity import compare_csv, compare_events, compare_summary

ATT = ("time_gps,qe_w,qe_x,qe_y,qe_z,yaw_deg,fixed\n"
       "2018-06-06T12:20:03.000,1.000000000000,0.000000000000,0.000000000000,0.000000000000,10.000000,1\n")
BL = "time_gps,baseline,x_ecef_m\n2018-06-06T12:20:03.000,A>B,0.12345\n"


def test_identical_products_have_no_difference():
    d = compare_csv(ATT, ATT)
    assert not d.failed(False) and d.max == {"deg": 0.0, "m": 0.0, "s": 0.0, "q_deg": 0.0} and d.flips == 0


def test_an_angle_change_above_the_tolerance_fails():
    d = compare_csv(ATT, ATT.replace("10.000000,1", "10.000002,1"))
    assert d.failed(False) and abs(d.max["deg"] - 2e-6) < 1e-12


def test_a_quaternion_rotation_is_measured_as_an_angle():
    # q = (cos(a/2), sin(a/2), 0, 0) with a = 1e-4 deg: qx = 8.73e-7
    d = compare_csv(ATT, ATT.replace("1.000000000000,0.000000000000", "1.000000000000,0.000000872665", 1))
    assert abs(d.max["q_deg"] - 1e-4) < 1e-8 and d.failed(False) and not d.other


def test_a_last_digit_flip_is_counted_and_optionally_accepted():
    d = compare_csv(BL, BL.replace("0.12345", "0.12346"))
    assert d.flips == 1 and d.failed(False) and not d.failed(True)
    d = compare_csv(BL, BL.replace("0.12345", "0.12347"))          # two units: not a flip
    assert d.flips == 0 and d.failed(True)


def test_a_changed_flag_or_name_is_another_difference():
    assert compare_csv(ATT, ATT.replace(",1\n", ",0\n")).other
    assert compare_csv(BL, BL.replace("A>B", "A>C")).other


def test_event_rows_must_be_identical():
    ev = "time_gps,gps_sow,event\nt,1.000,fix\n"
    assert not compare_events(ev, ev).failed(False)
    assert compare_events(ev, ev.replace("fix", "fix_lost")).failed(False)


def test_summary_keys_and_values():
    a = {"baselines": [{"median_length_m": 1.0, "sigma_h_mm": 2.0, "hdop": 0.8}], "mode": "dynamic"}
    assert not compare_summary(json.dumps(a), json.dumps(a)).failed(False)
    b = json.loads(json.dumps(a))
    b["baselines"][0]["median_length_m"] += 2e-6
    assert compare_summary(json.dumps(a), json.dumps(b)).failed(False)
    b = json.loads(json.dumps(a))
    b["baselines"][0]["sigma_h_mm"] += 1e-4                       # 1e-7 m
    assert not compare_summary(json.dumps(a), json.dumps(b)).failed(False)
    b = json.loads(json.dumps(a))
    del b["mode"]
    assert compare_summary(json.dumps(a), json.dumps(b)).failed(False)
