"""Differential PCV maps applied in the attitude filter (issue 6 item 4, issue 8 item 4).

The lookup (gnssatt.attitude.pcv_correction) against a direct evaluation of the function the map samples and
against the simulator's own bilinear interpolation; a simulated pass with large injected PCV processed with the
simulator's true differential maps and without: the map removes the attitude bias the PCV causes; the job config
`pcv_map_ids` resolved through the JobContext.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from tests.attitude.conftest import CLEAN, _simulate, set_files
from gnssatt.attitude.pcv_correction import epoch_correction_m, lookup_mm, pcv_table
from worker.context import InputFile, InputSet, JobContext
from worker.errors import JobInputError
from worker.jobs.attitude import AttitudeConfig, maps_for_settings


def _smooth_mm(az_deg, el_deg):
    a, e = np.radians(az_deg), np.radians(el_deg)
    return 12.0 * np.cos(e) ** 2 * np.cos(a + 0.4) + 5.0 * np.cos(e) * np.sin(2 * a) + 8.0 * (1 - np.sin(e)) ** 2


def _bin_grid(az_step=2.5, el_step=1.0):
    az = np.arange(az_step / 2, 360.0, az_step)
    el = np.arange(el_step / 2, 90.0, el_step)
    return az, el, _smooth_mm(az[None, :], el[:, None])


def test_lookup_matches_the_sampled_function_and_wraps_in_azimuth():
    az, el, v = _bin_grid()
    tab = pcv_table(az, el, v)
    rng = np.random.default_rng(3)
    qa, qe = rng.uniform(0, 360, 5000), rng.uniform(0.5, 89.5, 5000)
    got = lookup_mm(tab, qa, qe)
    # bilinear error bound of a smooth function on a 2.5 x 1 deg grid: a few hundredths of a mm
    assert np.max(np.abs(got - _smooth_mm(qa, qe))) < 0.05
    # across 0/360: between the bin centres 358.75 and 1.25, continuous and equal to the function
    edge = lookup_mm(tab, np.array([359.9, 0.1, 360.0, -0.5]), np.full(4, 30.0))
    assert np.max(np.abs(edge - _smooth_mm(np.array([359.9, 0.1, 0.0, 359.5]), 30.0))) < 0.05
    # half a bin beyond the outer centres is still inside the grid (clamped), further out is no correction
    assert np.isfinite(lookup_mm(tab, 10.0, 0.0)) and np.isfinite(lookup_mm(tab, 10.0, 90.0))
    assert np.isnan(lookup_mm(tab, 10.0, -1.0))


def test_lookup_equals_the_simulators_bilinear_map():
    from gnssatt.sim.observables import PCV_AZ_DEG, PCV_EL_DEG, bilinear_pcv_mm, pcv_grid_mm

    grid = pcv_grid_mm(np.random.default_rng(5), 40.0)
    tab = pcv_table(PCV_AZ_DEG, PCV_EL_DEG, grid)        # nodes 0..360 (360 == 0), -90..90
    rng = np.random.default_rng(6)
    qa, qe = rng.uniform(0, 360, 3000), rng.uniform(-90, 90, 3000)
    np.testing.assert_allclose(lookup_mm(tab, qa, qe), bilinear_pcv_mm(grid, qa, qe), atol=1e-9)


def test_empty_bins_are_never_filled_in():
    az, el, v = _bin_grid()
    v = v.copy()
    v[20, 40] = np.nan                                  # bin centred at (101.25, 20.5)
    tab = pcv_table(az, el, [[None if np.isnan(x) else x for x in row] for row in v.tolist()])
    assert np.isnan(lookup_mm(tab, 101.3, 20.4))        # inside the empty bin
    # next to it: interpolated over the filled neighbours only, still close to the function
    near = lookup_mm(tab, 102.9, 20.6)
    assert np.isfinite(near) and abs(near - _smooth_mm(102.9, 20.6)) < 0.5


def test_epoch_correction_in_the_first_antennas_frame():
    """A downward-looking first antenna (boresight -z body): the body line of sight is rotated into its frame."""
    from gnssatt.gnss.geometry import R_antenna_from_body, azimuth_elevation_antenna

    az, el, v = _bin_grid()
    tables = {(0, 1): pcv_table(az, el, v)}
    bore = np.array([0.0, 0.0, -1.0])
    rng = np.random.default_rng(1)
    los = rng.normal(size=(12, 3))
    los[:, 2] = -np.abs(los[:, 2]) - 0.2                 # in front of the antenna
    los /= np.linalg.norm(los, axis=1, keepdims=True)
    corr, has = epoch_correction_m(tables, los, R_antenna_from_body(bore)[None], 2)
    a_rad, e_rad = azimuth_elevation_antenna(los, np.eye(3), bore)
    np.testing.assert_allclose(corr[0, :, 1] * 1e3, lookup_mm(tables[(0, 1)], np.degrees(a_rad), np.degrees(e_rad)),
                               atol=1e-9)
    assert np.all(corr[0, :, 0] == 0.0) and has.tolist() == [[False, True]]


# ----------------------------------------------------------------------------- the filter with maps
PCV_PASS = {**CLEAN, "pcv": True, "pcv_peak_to_peak_mm": 40.0, "duration_s": 400.0}


@pytest.fixture(scope="module")
def pcv_pass(tmp_path_factory) -> Path:
    return _simulate(tmp_path_factory, "pcv", "earth-pointing", 11, PCV_PASS)


def true_maps(d: Path) -> dict:
    """The simulator's differential PCV of every baseline/frequency (exact: parallel antenna frames)."""
    out = {}
    for p in sorted((d / "truth" / "pcv").glob("*.json")):
        doc = json.loads(p.read_text())
        assert doc["parallel_frames"]
        out[(doc["pair"][0], doc["pair"][1], doc["frequency"])] = {
            k: doc[k] for k in ("platform", "pair", "frequency", "azimuth_deg", "elevation_deg", "values_mm")}
    return out


def test_true_maps_remove_the_attitude_bias(pcv_pass):
    from gnssatt.attitude.truth import attitude_errors_deg
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings

    inputs = load_inputs(set_files(pcv_pass))
    maps = true_maps(pcv_pass)
    assert len(maps) == 4
    out = {}
    for name, st in (("raw", AttitudeSettings()), ("maps", AttitudeSettings.preset("seed000", calibration={"pcv_maps": maps}))):
        sol = process(inputs, st)
        ang, de = attitude_errors_deg(pcv_pass, sol)
        f = sol.att_fixed
        assert f.mean() > 0.9 and ang[f].max() < 3.0, name
        out[name] = (de[f].mean(axis=0), np.median(ang[f]))
    bias_raw, bias_map = out["raw"][0], out["maps"][0]
    # 40 mm p-p PCV per antenna on ~1 m baselines: a bias of about a degree without the maps ...
    assert np.max(np.abs(bias_raw)) > 0.5, bias_raw
    # ... removed with them: every axis within 0.15 deg, the bias vector cut by >= 80 %
    assert np.max(np.abs(bias_map)) < 0.15, bias_map
    assert np.linalg.norm(bias_map) < 0.2 * np.linalg.norm(bias_raw), (bias_raw, bias_map)
    assert out["maps"][1] < 0.5 * out["raw"][1]


def _ctx(tmp_path, files, store: dict):
    def blob(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)

    s = InputSet(id="set-1", name="sim", files=[InputFile(n, k, p, {}) for n, k, p in files], summary={})
    ctx = JobContext(job_id="job-1", attempt=1, sets=[s], workdir=tmp_path, _store_blob=blob)
    ctx._load_pcv_map = store.get
    return ctx


def test_job_config_resolves_maps_from_the_store(tmp_path, pcv_pass):
    from worker.pipelines.attitude import run

    maps = true_maps(pcv_pass)
    store = {f"map-{i}": {**doc, "values_mm": doc["values_mm"]} for i, doc in enumerate(maps.values())}
    ids = sorted(store)
    ctx = _ctx(tmp_path / "a", set_files(pcv_pass), store)
    run(ctx, AttitudeConfig(pcv_map_ids=ids))
    summary = json.loads((tmp_path / "a" / "products" / "summary.json").read_text())
    assert summary["pcv_map_ids"] == ids
    ctx0 = _ctx(tmp_path / "b", set_files(pcv_pass), store)
    run(ctx0, AttitudeConfig())
    summary0 = json.loads((tmp_path / "b" / "products" / "summary.json").read_text())
    # the reference attitude (2 arcsec) sees the bias go away
    b_map = np.abs([summary["reference"]["fixed"][k]["bias_deg"] for k in ("yaw", "pitch", "roll")])
    b_raw = np.abs([summary0["reference"]["fixed"][k]["bias_deg"] for k in ("yaw", "pitch", "roll")])
    assert b_map.max() < 0.15 and b_raw.max() > 0.5, (b_map, b_raw)
    # unknown ids and maps of other pairs are refused with the field named
    with pytest.raises(JobInputError) as e:
        run(_ctx(tmp_path / "c", set_files(pcv_pass), store), AttitudeConfig(pcv_map_ids=["nope"]))
    assert e.value.field == "config.pcv_map_ids"
    bad = {**store["map-0"], "pair": ["GPS-0", "GPS-1"]}
    with pytest.raises(JobInputError, match="not a baseline"):
        run(_ctx(tmp_path / "d", set_files(pcv_pass), {"x": bad}), AttitudeConfig(pcv_map_ids=["x"]))
    with pytest.raises(ValueError, match="two PCV maps"):
        maps_for_settings([("a", store["map-0"]), ("b", store["map-0"])], [("GPS-2", "GPS-0"), ("GPS-2", "GPS-1")])


def test_empty_bins_exclude_or_keep(pcv_pass):
    """A map with a hole: with "exclude" the phases in it leave the solution once fixed (reason pcv_empty), with
    "keep" they stay in, uncorrected."""
    from gnssatt.attitude.filter import REASONS
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings

    maps = true_maps(pcv_pass)
    holed = {}
    for k, doc in maps.items():
        el = np.asarray(doc["elevation_deg"])
        holed[k] = {**doc, "values_mm": [[None if e < 10.0 else v for v in row] for e, row in zip(el, doc["values_mm"])]}
    inputs = load_inputs(set_files(pcv_pass))
    code = {v: k for k, v in REASONS.items()}["pcv_empty"]
    n_empty = {}
    for mode in ("exclude", "keep"):
        sol = process(inputs, AttitudeSettings.preset("seed000", calibration={"pcv_maps": holed, "pcv_empty_bins": mode}))
        n_empty[mode] = int(np.sum(sol.fr.residuals["reason"] == code))
        assert sol.att_fixed.mean() > 0.9
    assert n_empty["exclude"] > 100 and n_empty["keep"] == 0, n_empty
