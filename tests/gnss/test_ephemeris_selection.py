"""Ephemeris selection on real broadcast data: the upload a receiver holds, not merely the nearest toe."""
from __future__ import annotations

import numpy as np

from tests.conftest import real_set
from gnssatt.gnss.io.rinex_nav import read_rinex_nav, select_ephemeris
from gnssatt.gnss.io.sp3 import read_sp3
from gnssatt.gnss.orbits.broadcast import kepler_position_ecef
from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3
from gnssatt.gnss.time import GpsTime


def test_fresh_upload_beats_an_older_data_set_with_a_nearer_toe():
    d = real_set("leo_grace_a_2007080")
    k = read_rinex_nav(d / "brdc0800.07n.gz").kepler["G"]
    t = GpsTime.from_calendar(2007, 3, 21, 14, 0, 0)
    idx = select_ephemeris(k, "G02", t)
    assert int(k.iode[idx]) == 58  # sent 12:40:48 with toe 13:59:44; IODE 32 (toe 14:00, sent 12:11:48) is stale
    r, _, _, _ = kepler_position_ecef(k, np.array([idx]), t)
    sp3 = read_sp3(d / "cod14193.sp3.gz")
    r_ref, _ = interpolate_sp3(sp3, ["G02"], t)
    assert np.linalg.norm(r[0] - r_ref[0, 0]) < 2.0  # metres; the stale set is 16 m off


def test_before_any_upload_falls_back_to_nearest_toe():
    d = real_set("leo_grace_a_2007080")
    k = read_rinex_nav(d / "brdc0800.07n.gz").kepler["G"]
    t = GpsTime.from_calendar(2007, 3, 21, 1, 0, 0)  # the day's first G02 record was sent at 01:23:48
    idx = select_ephemeris(k, "G02", t)
    assert idx >= 0 and k.toe_gpst()[idx].iso() == "2007-03-21T02:00:00.000"
