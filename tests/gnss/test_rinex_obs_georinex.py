"""The reader against georinex, value for value (observables, LLI, SSI, epochs), and against float() of the text.

georinex reads ~0.26 MB/s, so each real file is cut to its first epochs (~120 kB, written to tmp_path);
the full-file comparison is in bench/bench_rinex_obs.py. Round trips through gnssatt's writer (2.11, 3.04,
4.01) are read back by georinex too, so the writer is checked by an outside reader.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import real_set
from bench.georinex_check import compare_with_georinex, load_georinex
from tests.gnss.test_rinex_obs_helpers import cut_rinex, small_obs
from gnssatt.gnss.io.rinex_obs import read_rinex_obs
from gnssatt.gnss.io.rinex_obs_write import rinex_obs_bytes

REAL_OBS = [
    ("static_1m_mosaicx5_nagoya_2024", "base.obs"),
    ("static_1m_mosaicx5_nagoya_2024", "rover.obs"),
    ("qzss_l1s_geonet3034_sept_2021", "3034265G.21O"),
    ("qzss_l1s_geonet3034_sept_2021", "SEPT265G.21O"),
    ("upc1_upc2_38m_barcelona_2010", "UPC10770.11o.gz"),
    ("upc1_upc2_38m_barcelona_2010", "UPC20770.11o.gz"),
    ("leo_grace_a_2007080", "graa0800.07o.gz"),
    ("geonet_0759_3040_3km_2005", "07590920.05o"),
    ("geonet_0759_3040_3km_2005", "30400920.05o"),
]
CUT_BYTES = 120_000


def _cut(tmp_path, set_name, file_name):
    data = cut_rinex(real_set(set_name) / file_name, CUT_BYTES)
    path = tmp_path / file_name.removesuffix(".gz")
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("set_name, file_name", REAL_OBS, ids=[f for _, f in REAL_OBS])
def test_value_for_value_against_georinex(tmp_path, set_name, file_name):
    path = _cut(tmp_path, set_name, file_name)
    obs = read_rinex_obs(path)
    assert len(obs.time) >= 5
    n = compare_with_georinex(obs, load_georinex(path))
    assert n > 1000


def _float_reference(text: str, obs) -> dict:
    """(epoch, sat, code) -> float(field) by a slow independent walk of the text (RINEX 2 and 3)."""
    lines = text.splitlines()
    i = next(k for k, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    out, ep = {}, -1
    if obs.header.version >= 3:
        for ln in lines[i:]:
            if ln.startswith(">"):
                ep += int(ln[31]) <= 1
                continue
            if ln[60:67] == "COMMENT":
                continue
            sat = ln[:3].replace(" ", "0")
            types = obs.header.obs_types[sat[0]]
            for k, code in enumerate(types):
                f = ln[3 + 16 * k:17 + 16 * k]
                if f.strip():
                    out[(ep, sat, code)] = float(f)
        return out
    types = obs.codes
    lps = 1 + (len(types) - 1) // 5
    while i < len(lines):
        ln = lines[i]
        if ln[60:67] == "COMMENT" or not ln.strip():
            i += 1
            continue
        flag, n = int(ln[28]), int(ln[29:32])
        if 2 <= flag <= 5:
            i += 1 + n
            continue
        sats = ln[32:68]
        for c in range((n - 1) // 12):
            sats += lines[i + 1 + c][32:68]
        i += 1 + (n - 1) // 12
        ep += 1
        for s in range(n):
            sat = sats[3 * s:3 * s + 3]
            sat = (sat[0] if sat[0] != " " else "G") + sat[1:].replace(" ", "0")
            rec = "".join(lines[i + j][:80].ljust(80) for j in range(lps))
            i += lps
            for k, code in enumerate(types):
                f = rec[(k // 5) * 80 + (k % 5) * 16:][:14]
                if f.strip():
                    out[(ep, sat, code)] = float(f)
    return out


@pytest.mark.parametrize("set_name, file_name", REAL_OBS, ids=[f for _, f in REAL_OBS])
def test_bit_identical_to_float_of_the_text(tmp_path, set_name, file_name):
    path = _cut(tmp_path, set_name, file_name)
    obs = read_rinex_obs(path)
    ref = _float_reference(path.read_text("latin-1"), obs)
    sat_i = {s: j for j, s in enumerate(obs.sats)}
    got = np.array([obs.values[e, sat_i[s], obs.codes.index(c)] for (e, s, c) in ref])
    want = np.array(list(ref.values()))
    assert np.array_equal(got.view(np.int64), want.view(np.int64))  # bit for bit, sign of zero included
    assert len(ref) == np.count_nonzero(~np.isnan(obs.values))


@pytest.mark.parametrize("version", [2.11, 3.04, 4.01])
def test_writer_round_trip_read_by_georinex(tmp_path, version):
    if version < 3:
        src = read_rinex_obs(_cut(tmp_path, "upc1_upc2_38m_barcelona_2010", "UPC10770.11o.gz"))
    else:
        src = read_rinex_obs(_cut(tmp_path, "static_1m_mosaicx5_nagoya_2024", "rover.obs"))
    path = tmp_path / f"rt_{version}.rnx"
    path.write_bytes(rinex_obs_bytes(src, version))
    back = read_rinex_obs(path)
    assert back.sats == src.sats and back.codes == src.codes
    np.testing.assert_array_equal(back.values, src.values)
    np.testing.assert_array_equal(back.lli, src.lli)
    np.testing.assert_array_equal(back.ssi, src.ssi)
    assert np.array_equal(back.time.s, src.time.s) and np.array_equal(back.time.frac, src.time.frac)
    if version >= 4:
        # georinex 1.16 refuses RINEX 4 ("unknown RINEX"); the 4.01 observation records are those of 3.05, so
        # georinex reads the same bytes with the version field set to 3.05
        data = path.read_bytes()
        assert data.startswith(b"     4.01")
        path = tmp_path / "rt_as_305.rnx"
        path.write_bytes(b"     3.05" + data[9:])
    compare_with_georinex(back, load_georinex(path))


def test_writer_rinex3_codes_to_rinex2(tmp_path):
    src = small_obs(sats=("G01", "G05", "G07"), codes=("C1C", "L1C", "C1W", "C2W", "L2W", "S1C"))
    path = tmp_path / "v2.rnx"
    path.write_bytes(rinex_obs_bytes(src, 2.11))
    back = read_rinex_obs(path)
    assert back.codes == ["C1", "L1", "P1", "P2", "L2", "S1"]
    for k, c3 in enumerate(src.codes):
        if c3 in ("C1W", "C2W", "L2W"):
            np.testing.assert_array_equal(back.get(c3, "G")[:, :2], src.values[:, :2, k])
    compare_with_georinex(back, load_georinex(path))
