"""PCV maps: CONVENTIONS JSON and the ANTEX-style text survive a round trip unchanged; bad maps are refused."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.pcv_map import PcvMap, parse_pcv_map, read_pcv_antex, write_pcv_antex


def make_map(seed=1, daz=2.5, del_=1.0, freq="L1", empty=0.2):
    rng = np.random.default_rng(seed)
    az = np.arange(daz / 2, 360, daz)
    el = np.arange(del_ / 2, 90, del_)
    v = np.round(rng.normal(0, 10, (len(el), len(az))), 4)
    v[rng.random(v.shape) < empty] = np.nan
    c = np.where(np.isnan(v), rng.integers(0, 5, v.shape), rng.integers(5, 500, v.shape))
    s = np.round(rng.random(v.shape), 4)
    s[np.isnan(v)] = np.nan
    return PcvMap("CASSIOPE-like", "GPS-2", "GPS-0", freq, az, el, v, c, s)


def test_json_round_trip_keeps_nulls():
    m = make_map()
    doc = m.to_json()
    assert doc["values_mm"][0].count(None) == int(np.isnan(m.values_mm[0]).sum())
    assert parse_pcv_map(doc).equals(m)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10**6), daz=st.sampled_from([2.5, 5.0, 10.0, 22.5]), del_=st.sampled_from([1.0, 2.0, 5.0]),
       freq=st.sampled_from(["L1", "L2", "L5"]), empty=st.floats(0, 1))
def test_antex_style_round_trip_is_exact(seed, daz, del_, freq, empty):
    maps = [make_map(seed, daz, del_, freq, empty), make_map(seed + 1, daz, del_, "L2", empty)]
    back = read_pcv_antex(write_pcv_antex(maps))
    assert len(back) == 2 and all(a.equals(b) for a, b in zip(maps, back))


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d.update(pair=["A", "A"]), "pair"),
    (lambda d: d.update(frequency="L9"), "frequency"),
    (lambda d: d["values_mm"].pop(), "values_mm"),
    (lambda d: d["values_mm"][0].__setitem__(0, "x"), "values_mm"),
    (lambda d: d.update(azimuth_deg=list(reversed(d["azimuth_deg"]))), "azimuth_deg"),
    (lambda d: d["count"][0].__setitem__(0, -1), "count"),
])
def test_bad_maps_are_refused_naming_the_field(mutate, field):
    doc = make_map().to_json()
    mutate(doc)
    with pytest.raises(ParseError) as err:
        parse_pcv_map(doc)
    assert field in str(err.value)


def test_damaged_antex_names_the_line():
    text = write_pcv_antex([make_map()]).splitlines()
    text[20] = text[20][:8] + "   garbage" + text[20][18:]
    with pytest.raises(ParseError) as err:
        read_pcv_antex("\n".join(text))
    assert err.value.line_no == 21
