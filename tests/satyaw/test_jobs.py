"""satellite-yaw and satellite-baseline jobs end to end on simulated RINEX sets, and their bad-input errors."""
import json

import numpy as np
import pytest

from gnssatt.satyaw.attitude_models import wrap_deg
from gnssatt.satyaw.orbex import read_orbex
from gnssatt.sim.satellite_pair import SatPairScenario, simulate_satellite_pair, write_satellite_pair_set
from worker.errors import JobInputError
from worker.local import local_set, run_job_locally


def _set(tmp_path, sc, name="set"):
    tr = simulate_satellite_pair(sc)
    paths = write_satellite_pair_set(tr, tmp_path / name)
    stations = json.loads(paths["stations.json"].read_text())
    sats = json.loads(paths["satellites.json"].read_text())
    files = [p for k, p in paths.items() if k not in ("stations.json", "satellites.json")]
    return tr, local_set(files, name), stations, sats


@pytest.fixture(scope="module")
def yaw_set(tmp_path_factory):
    sc = SatPairScenario(duration_s=3 * 3600.0, interval_s=60.0, n_stations=8, beta_deg=0.3,
                         midnight_s=1.5 * 3600.0, pcv_amplitude_mm=0.0, seed=11)
    return _set(tmp_path_factory.mktemp("yaw"), sc)


def test_satellite_yaw_job_through_midnight_turn(yaw_set, tmp_path):
    tr, obs_set, stations, sats = yaw_set
    out = run_job_locally("satellite-yaw", [obs_set], {"stations": stations, "satellites": sats, "smooth": True,
                                                       "triple_frequency": True},
                          tmp_path / "out", progress=None)
    assert {"yaw.csv", "yaw.obx", "events.csv", "residuals.csv", "summary.json", "yaw.png", "report.html"} <= set(out)
    rows = np.genfromtxt(out["yaw.csv"], delimiter=",", names=True, dtype=None, encoding="ascii")
    err = wrap_deg(rows["yaw_deg"] - tr.yaw_deg[: len(rows)])
    # RINEX F14.3 phases (0.2 mm steps), 8 stations: well under 1 deg through the 0.055 deg/s turn
    assert np.sqrt(np.nanmean(err ** 2)) < 1.0
    assert 0.7 < np.sqrt(np.nanmean((err / rows["sigma_yaw_deg"]) ** 2)) < 1.3
    assert np.nanmax(np.abs(wrap_deg(rows["model_yaw_deg"] - tr.yaw_deg))) < 1e-3   # model = what it flew
    summary = json.loads(out["summary.json"].read_text())
    assert summary["satellites"]["J02"]["mode"] == "per-epoch"
    assert summary["satellites"]["J02"]["agrees_with_model"]
    att = read_orbex(out["yaw.obx"])
    assert len(att.time) == np.isfinite(rows["yaw_deg"]).sum()
    # the ORBEX quaternions are the yaw of yaw.csv: body +x (row 0 of R_body_from_ecef) in the orbital frame
    from gnssatt.gnss.rotations import quat_to_dcm

    k = np.flatnonzero(np.isfinite(rows["yaw_deg"]))[: len(att.time)]
    x_b = quat_to_dcm(att.q_body_from_ecef)[:, 0, :]
    R_o = tr.geometry.R_orbital_from_ecef[k]
    yaw_q = np.degrees(np.arctan2(np.einsum("ni,ni->n", x_b, R_o[:, 1]), np.einsum("ni,ni->n", x_b, R_o[:, 0])))
    np.testing.assert_allclose(wrap_deg(yaw_q - rows["yaw_deg"][k]), 0.0, atol=1e-3)   # CSV keeps 4 decimals
    # the rate-limited smoother is no worse than the epoch-wise yaw, and its sigma is smaller
    err_s = wrap_deg(rows["smoothed_yaw_deg"] - tr.yaw_deg[: len(rows)])
    assert np.sqrt(np.nanmean(err_s ** 2)) <= np.sqrt(np.nanmean(err ** 2)) * 1.05
    assert np.nanmedian(rows["sigma_smoothed_deg"]) < np.nanmedian(rows["sigma_yaw_deg"])
    # the triple-frequency path from L1Z, L2L, L5Q of the files: a few degrees (seed 004: ~4 deg)
    err3 = wrap_deg(rows["triple_yaw_deg"] - tr.yaw_deg[: len(rows)])
    assert 1.0 < np.sqrt(np.nanmean(err3 ** 2)) < 10.0
    assert summary["satellites"]["J02"]["triple_observable"]


def test_satellite_baseline_job_publishes_table1_and_map(tmp_path):
    # plumbing test: no PCV in the truth (the map's science is in test_estimators); one day at 5 min is too
    # little azimuth coverage for a map, which the job must say
    sc = SatPairScenario(duration_s=86400.0, interval_s=300.0, n_stations=10, beta_deg=25.0,
                         profile="yaw-steering", pcv_amplitude_mm=0.0, seed=2)
    tr, obs_set, stations, sats = _set(tmp_path, sc)
    del sats["satellites"]["J02"]["aux_antenna_m"]
    out = run_job_locally("satellite-baseline", [obs_set], {"stations": stations, "satellites": sats},
                          tmp_path / "out", progress=None)
    got = json.loads(out["satellites.json"].read_text())["satellites"]["J02"]
    err = np.array(got["aux_antenna_m"]) - np.array(sc.baseline_body_m)
    assert np.all(np.abs(err) < 3.5 * np.array(got["sigma_m"]) + 1e-4)   # errors within their sigmas
    assert np.all(np.abs(err[:2]) < 0.01)
    assert "baselines.csv" in out and "report.html" in out
    summary = json.loads(out["summary.json"].read_text())
    assert any("PCV map not estimated" in w for w in summary["satellites"]["J02"]["warnings"])
    # the output feeds a satellite-yaw job unchanged (CONVENTIONS.md)
    assert set(got) >= {"aux_antenna_m", "sigma_m", "n_stations", "n_epochs", "dcb_m", "attitude_model"}


def test_bad_inputs_name_the_file(tmp_path):
    sc = SatPairScenario(duration_s=3600.0, interval_s=60.0, n_stations=3, beta_deg=20.0, profile="yaw-steering")
    tr, obs_set, stations, sats = _set(tmp_path, sc, "ok")
    # a satellite without a baseline
    with pytest.raises(JobInputError, match="no auxiliary-antenna baseline") as exc:
        run_job_locally("satellite-yaw", [obs_set], {"stations": stations, "satellite_ids": ["J07"]},
                        tmp_path / "o1", progress=None)
    assert exc.value.field == "satellites"
    # a one-epoch file
    one = SatPairScenario(duration_s=60.0, interval_s=60.0, n_stations=1, beta_deg=20.0, profile="yaw-steering")
    _, one_set, st1, sats1 = _set(tmp_path, one, "one")
    with pytest.raises(JobInputError, match=r"S000\.rnx: 1 observation epoch") as exc:
        run_job_locally("satellite-yaw", [one_set], {"stations": st1, "satellites": sats1}, tmp_path / "o2",
                        progress=None)
    assert exc.value.file == "S000.rnx"
    # stations without the auxiliary signal: the aux signal names do not match the files
    sats_bad = json.loads(json.dumps(sats))
    sats_bad["satellites"]["J02"]["aux_signals"] = ["C1X", "L1X"]
    with pytest.raises(JobInputError, match="no observation file .S000.rnx") as exc:
        run_job_locally("satellite-yaw", [obs_set], {"stations": stations, "satellites": sats_bad},
                        tmp_path / "o3", progress=None)
    assert "S000.rnx" in exc.value.file


def test_stations_and_satellites_json_in_the_set_stand_in_for_the_config(tmp_path):
    """A set holding stations.json and satellites.json (identified by content, not by name) runs with no config:
    the same yaw as with the documents given in the config."""
    sc = SatPairScenario(duration_s=1800.0, interval_s=60.0, n_stations=4, beta_deg=20.0, profile="yaw-steering",
                         seed=3)
    tr = simulate_satellite_pair(sc)
    paths = write_satellite_pair_set(tr, tmp_path / "set")
    renamed = {k: p.rename(p.with_name(f"upload_{k}")) if k.endswith(".json") else p for k, p in paths.items()}
    whole = local_set(list(renamed.values()), "whole")
    assert {f.kind for f in whole.files} >= {"stations", "satellites", "rinex_obs"}
    out = run_job_locally("satellite-yaw", [whole], {}, tmp_path / "o1", progress=None)
    cfg = {"stations": json.loads(renamed["stations.json"].read_text()),
           "satellites": json.loads(renamed["satellites.json"].read_text())}
    bare = local_set([p for k, p in renamed.items() if not k.endswith(".json")], "bare")
    ref = run_job_locally("satellite-yaw", [bare], cfg, tmp_path / "o2", progress=None)
    a = np.genfromtxt(out["yaw.csv"], delimiter=",", names=True, dtype=None, encoding="ascii")
    b = np.genfromtxt(ref["yaw.csv"], delimiter=",", names=True, dtype=None, encoding="ascii")
    # the same inputs by two routes: the same yaw to the CSV's 4 decimals
    np.testing.assert_allclose(a["yaw_deg"], b["yaw_deg"], atol=1e-4, equal_nan=True)
