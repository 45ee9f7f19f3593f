"""Satellite-id fields with characters str.strip()/str.isdigit() accept but int() refuses (found by fuzzing the
clock reader): every reader's normaliser keeps them as text instead of raising a bare ValueError."""
from __future__ import annotations

import pytest

from gnssatt.gnss.io.rinex_clock import _norm_sat
from gnssatt.gnss.io.rinex_nav import _sat_norm


@pytest.mark.parametrize("norm", [_norm_sat, _sat_norm])
def test_odd_satellite_ids_never_raise(norm):
    assert norm("G 1") == "G01" and norm("E11") == "E11"
    for odd in ("G\x1c1", "G\u00b2", "G\u0661", "R\x1d 3"):   # control char, superscript 2, Arabic-Indic 1
        assert norm(odd) == odd.strip()
