"""Fuzzing the SP3 reader and interpolator on small texts: only ParseError, bounded time."""
from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.gnss.test_rinex_nav_fuzz import mutated
from tests.gnss.test_sp3 import sp3_text
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.sp3 import read_sp3, summarize_sp3
from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3

BASE_D = sp3_text(["G01", "G02", "E11", "R05"], 4, velocity=True, bad={(1, "G01", "clk")})
BASE_C = sp3_text(["G01", "G02"], 3, version="c")


@settings(max_examples=200, deadline=1000, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mutated(BASE_D), mutated(BASE_C)))
def test_fuzz_sp3_only_parse_error(data):
    try:
        sp3 = read_sp3(data, name="fuzz.sp3")
    except ParseError:
        return
    assert sp3.position_ecef_m.shape == (len(sp3.time), len(sp3.sats), 3)
    summarize_sp3(data, name="fuzz.sp3")
    if len(sp3.time):
        pos, clk = interpolate_sp3(sp3, sp3.sats, sp3.time[0] + np.array([0.0, 450.0]))
        assert pos.shape == (2, len(sp3.sats), 3)
