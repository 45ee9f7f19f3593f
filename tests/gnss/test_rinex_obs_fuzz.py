"""Fuzzing the RINEX observation reader: on mutated files only ParseError escapes, in bounded time and memory.

Seeds: small files written by gnssatt's writer (RINEX 2.11, 3.04 with events and comments) and, when
../shared is present, the first epochs of a real RINEX 3 and a real RINEX 2 file. Mutations: byte flips,
truncation, line deletion / duplication / swap, random garbage spliced in, digits changed in epoch lines.
"""
from __future__ import annotations

import tracemalloc

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import REAL_DATA_DIR
from tests.gnss.test_rinex_obs_helpers import cut_rinex, small_obs
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_obs import read_rinex_obs, summarize_rinex_obs
from gnssatt.gnss.io.rinex_obs_write import rinex_obs_bytes

#: Per-example peak of Python/numpy allocations (tracemalloc). The seeds are < 30 kB, so a reader that needs
#: more than this on a mutated seed has let a count from the file size an allocation.
PEAK_BYTES = 64 * 1024**2


def _seeds() -> list[bytes]:
    seeds = [rinex_obs_bytes(small_obs(n_epochs=6), 3.04),  # G, R, E; then GPS-only RINEX 2 with 2-line records
             rinex_obs_bytes(small_obs(n_epochs=6, sats=("G01", "G05", "G12"),
                                       codes=("C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "S2W")), 2.11)]
    lines = seeds[0].decode().split("\n")
    ep = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    lines[ep[2]:ep[2]] = [">" + " " * 30 + "4  1", f"{'splice':<60}COMMENT"]
    seeds.append("\n".join(lines).encode())
    real3 = REAL_DATA_DIR / "static_1m_mosaicx5_nagoya_2024" / "rover.obs"
    real2 = REAL_DATA_DIR / "geonet_0759_3040_3km_2005" / "07590920.05o"
    for p in (real3, real2):
        if p.is_file():
            seeds.append(cut_rinex(p, 20_000))
    return seeds


SEEDS = _seeds()


@st.composite
def mutated(draw):
    data = bytearray(draw(st.sampled_from(SEEDS)))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "truncate", "del_line", "dup_line", "swap_lines", "garbage",
                                   "digit"]))
        lines = bytes(data).split(b"\n")
        if op == "flip" and data:
            i = draw(st.integers(0, len(data) - 1))
            data[i] = draw(st.integers(0, 255))
        elif op == "truncate":
            data = data[:draw(st.integers(0, len(data)))]
        elif op == "garbage":
            i = draw(st.integers(0, len(data)))
            data[i:i] = draw(st.binary(min_size=1, max_size=200))
        elif op == "digit" and data:
            i = draw(st.integers(0, len(data) - 1))
            if chr(data[i]).isdigit() or data[i] == 32:
                data[i] = ord(draw(st.sampled_from("0123456789 -.9")))
        elif len(lines) > 2:
            i = draw(st.integers(0, len(lines) - 2))
            if op == "del_line":
                del lines[i]
            elif op == "dup_line":
                lines.insert(i, lines[i])
            else:
                lines[i], lines[i + 1] = lines[i + 1], lines[i]
            data = bytearray(b"\n".join(lines))
    return bytes(data)


@settings(max_examples=300, deadline=2000, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(mutated())
def test_only_parse_error_escapes(data):
    tracemalloc.start()
    try:
        try:
            obs = read_rinex_obs(data, name="fuzz.rnx")
        except ParseError as err:
            assert err.path == "fuzz.rnx" and str(err)
            return
        # what was accepted is self-consistent
        n_ep, n_sat, n_code = obs.values.shape
        assert len(obs.time) == n_ep == len(obs.epoch_flag) == len(obs.clock_offset_s)
        assert len(obs.sats) == n_sat and len(obs.codes) == n_code
        assert obs.lli.shape == obs.ssi.shape == obs.values.shape
        assert sorted(obs.sats) == obs.sats
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    assert peak < PEAK_BYTES


@pytest.mark.parametrize("seed", range(len(SEEDS)))
def test_seeds_themselves_parse(seed):
    s = summarize_rinex_obs(SEEDS[seed], name="seed.rnx")
    assert s["n_epochs"] >= 2
