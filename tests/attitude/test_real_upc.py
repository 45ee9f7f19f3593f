"""Real data, one long baseline: upc1_upc2_38m_barcelona_2010 as a two-antenna terrestrial platform (issue 6).

Oracles:
- the set's README (gAGE/UPC tutorial reference coordinates, the header APPROX POSITIONs): UPC1 -> UPC2 ENU
  (-27.4171, -26.2340, -0.0306) m, length 37.946 m, azimuth 226.26 deg, elevation -0.05 deg;
- RTKLIB 2.4.3 b34 on the same files (bench.rtklib_runner, GPS L1+L2 kinematic, base at the UPC1 reference):
  issue 6 quotes 226.271 +- 0.002 deg over the hour. RTKLIB's length is 37.930 m (10 min: 37.9288 m), 16 mm short
  of the reference vector, and its azimuth 0.008 deg off it, so the reference coordinates are not quite the
  phase-centre baseline of these files (unknown antennas, no ANTEX type): RTKLIB is the tighter oracle.

The first 10 minutes (600 epochs at 1 Hz) keep the test fast; bench/bench_attitude_rtklib.py runs the hour.
"""
from __future__ import annotations

import dataclasses
import gzip
import json
import shutil

import numpy as np
import pytest

from bench.real_sets import UPC, UPC_ENU_M, UPC_PLATFORM, upc_files
from tests.conftest import real_set, require_module
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import AttitudeSettings

N_EPOCHS = 600                                   # 10 minutes at 1 Hz from 2010-03-18 05:00:00 GPST
ENU_M = UPC_ENU_M                                # README, UPC1 -> UPC2 at UPC1
LENGTH_M = float(np.linalg.norm(ENU_M))          # 37.946 m
AZIMUTH_DEG = 226.263                            # atan2(E, N) of the README vector
ELEVATION_DEG = float(np.degrees(np.arctan2(ENU_M[2], np.hypot(ENU_M[0], ENU_M[1]))))   # -0.046 deg
UPC1_ECEF_M = ("4789013.0077", "176610.1555", "4195034.8091")

def _first_epochs(obs, n: int):
    """The RinexObs restricted to its first n epochs (every per-epoch array)."""
    return dataclasses.replace(obs, time=obs.time[:n], epoch_flag=obs.epoch_flag[:n],
                               clock_offset_s=obs.clock_offset_s[:n], values=obs.values[:n], lli=obs.lli[:n],
                               ssi=obs.ssi[:n], events=[])


@pytest.fixture(scope="module")
def upc(tmp_path_factory):
    d = real_set(UPC)
    plat = tmp_path_factory.mktemp("upc") / "platform.json"
    plat.write_text(json.dumps(UPC_PLATFORM))
    inputs = load_inputs(upc_files(d, plat))
    inputs.obs = {a: _first_epochs(o, N_EPOCHS) for a, o in inputs.obs.items()}
    return process(inputs, AttitudeSettings.preset("seed000", mode="kinematic"))


@pytest.fixture(scope="module")
def rtklib_upc(tmp_path_factory):
    require_module("pyrtklib", "RTKLIB 2.4.3 b34 bindings")
    from bench.rtklib_runner import options_for, run_postpos

    d = real_set(UPC)
    tmp = tmp_path_factory.mktemp("upc_rtklib")
    plain = {}
    for name in ("UPC10770.11o", "UPC20770.11o"):       # RTKLIB would shell out to gzip: hand it plain files
        with gzip.open(d / f"{name}.gz") as src, open(tmp / name, "wb") as dst:
            shutil.copyfileobj(src, dst)
        plain[name] = tmp / name
    opts = options_for("kinematic", **{"ant2-postype": "xyz", "ant2-pos1": UPC1_ECEF_M[0],
                                       "ant2-pos2": UPC1_ECEF_M[1], "ant2-pos3": UPC1_ECEF_M[2]})
    # 2010-03-18 05:00:00 GPST = week 1575, 363600 s; the first 600 epochs end at 363600 + 599 s
    return run_postpos(plain["UPC20770.11o"], plain["UPC10770.11o"], d / "brdc0770.11n", opts, tmp / "upc.pos",
                       end=(1575, 363600.0 + N_EPOCHS - 1))


def test_upc_every_epoch_fixed_from_the_first_and_never_wrongly(upc):
    bt = upc.baseline_table
    assert bt["epoch"].size == N_EPOCHS
    assert bt["fixed"].all()
    assert upc.summary["baselines"][0]["time_to_first_fix_s"] == 0.0
    # a wrong integer moves a DD by 19 or 24 cm, the baseline by more than the 3 cm length validation
    assert np.all(np.abs(bt["length_m"] - LENGTH_M) < 0.03)
    assert np.all(np.abs(bt["azimuth_deg"] - AZIMUTH_DEG) < 0.05)


def test_upc_azimuth_at_the_reference(upc):
    b = upc.summary["baselines"][0]
    az = upc.baseline_table["azimuth_deg"]
    # measured: 226.2722 deg median (RTKLIB's hour: 226.271), scatter 0.0018 deg (RTKLIB 0.002)
    assert abs(b["median_azimuth_deg"] - AZIMUTH_DEG) < 0.05
    assert np.std(az) < 0.005
    assert abs(b["median_elevation_deg"] - ELEVATION_DEG) < 0.1


def test_upc_at_rtklib_level_on_the_same_files(upc, rtklib_upc):
    r = rtklib_upc
    assert r.fixed.all() and r.q.size == N_EPOCHS
    b = upc.summary["baselines"][0]
    # measured (10 min): gnssatt 226.2722 deg / 37.9305 m / -0.067 deg, RTKLIB 226.2717 / 37.9288 / -0.065
    assert abs(b["median_azimuth_deg"] - np.median(r.azimuth_deg())) < 0.003
    assert abs(b["median_length_m"] - np.median(r.length_m())) < 0.003
    assert abs(b["median_elevation_deg"] - np.median(r.elevation_deg())) < 0.02
    assert np.std(upc.baseline_table["azimuth_deg"]) <= 1.5 * np.std(r.azimuth_deg())


@pytest.mark.xfail(reason="length 37.9305 m measured vs the README's 37.946 m (16 mm short); RTKLIB 2.4.3 b34 on the "
                          "same files is as short (37.9288 m over these 10 min, 37.9297 m over the hour), so the "
                          "reference coordinates are not the phase-centre baseline of these files (docs/attitude.md, Known "
                          "limits); strict: a pass means the length or the reference changed, look again", strict=True)
def test_upc_length_within_3mm_of_the_reference(upc):
    assert abs(upc.summary["baselines"][0]["median_length_m"] - LENGTH_M) < 0.003
