"""Fuzzing the ANTEX reader on a small text: only ParseError, bounded time."""
from __future__ import annotations

from hypothesis import HealthCheck, given, settings

from tests.gnss.test_antex import sample_text
from tests.gnss.test_rinex_nav_fuzz import mutated
from gnssatt.gnss.io.antex import read_antex, summarize_antex, write_antex
from gnssatt.gnss.io.errors import ParseError

BASE = sample_text().encode()


@settings(max_examples=200, deadline=1000, suppress_health_check=[HealthCheck.too_slow])
@given(mutated(BASE))
def test_fuzz_antex_only_parse_error(data):
    try:
        pats = read_antex(data, name="fuzz.atx")
    except ParseError:
        return
    summarize_antex(data, name="fuzz.atx")
    try:
        text = write_antex(pats)
    except ValueError:
        return  # a field grown past its column by the mutation cannot be written back; refused, not truncated
    assert read_antex(text.encode("latin-1"), name="w.atx") == pats
