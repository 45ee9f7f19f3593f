"""Fuzzing the RINEX clock reader on a small text: only ParseError, bounded time."""
from __future__ import annotations

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from tests.gnss.test_rinex_clock import clock_text
from tests.gnss.test_rinex_nav_fuzz import mutated
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_clock import read_rinex_clock, summarize_rinex_clock

RECS = [("AS", "G01", 0.0, [1.5e-4, 2.0e-11]), ("AS", "E11", 0.0, [-3.25e-5, 1.0e-11, 1e-12, 1e-13]),
        ("AR", "WSRT00NLD", 0.0, [1.25e-7, 8.8e-11]), ("AS", "G01", 30.0, [1.6e-4])]
BASE_3 = clock_text("3.04", RECS)
BASE_2 = clock_text("2.00", [(k, n[:4], s, v) for k, n, s, v in RECS])


@settings(max_examples=200, deadline=1000, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mutated(BASE_3), mutated(BASE_2)))
@example(BASE_3.replace(b"G01", b"G\x1c1", 1))   # a control character inside a satellite id (found by fuzzing)
@example(BASE_3.replace(b"G01", "G\u00b2".encode("latin-1", "replace"), 1))
def test_fuzz_clock_only_parse_error(data):
    try:
        c = read_rinex_clock(data, name="fuzz.clk")
    except ParseError:
        return
    assert c.clock_s.shape == (len(c.time), len(c.sats))
    summarize_rinex_clock(data, name="fuzz.clk")
