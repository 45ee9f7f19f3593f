"""Small real files held in the repository (tests/data/third_party, provenance in its PROVENANCE.md) for versions
the shared third-party corpus lacks: read, with every value equal to an independent whitespace re-read of the raw
lines, and, where RTKLIB reads the format, equal to RTKLIB's values too."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnssatt.gnss.io.antex import read_antex
from gnssatt.gnss.io.nav_messages import SBAS_MAX_RADIUS_KM, sbas_records_in_metres
from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from tests.conftest import require_module

DATA = Path(__file__).resolve().parents[1] / "data" / "third_party"
ANTEX_13 = DATA / "igs05_1585_cut.atx"
SBAS_V2 = DATA / "rinex210_table_a18.00h"
GEO_RADIUS_M = 42_164_000.0   # geostationary orbit radius


def _raw_antex_blocks(text: str) -> list[dict]:
    """Independent re-read (whitespace split, no columns): per antenna its type, DAZI and per frequency the
    NORTH/EAST/UP numbers, the NOAZI row and the azimuth rows (ANTEX 1.3, sec. 'ANTEX format description')."""
    ants: list[dict] = []
    cur = freq = None
    for ln in text.splitlines():
        label = ln[60:].strip()
        if label == "START OF ANTENNA":
            cur = {"freqs": []}
            ants.append(cur)
        elif label == "TYPE / SERIAL NO":
            cur["type"] = ln[:20].strip()
        elif label == "DAZI":
            cur["dazi"] = float(ln[:60])
        elif label == "START OF FREQUENCY":
            freq = {"code": ln[3:6], "neu": None, "noazi": None, "rows": []}
            cur["freqs"].append(freq)
        elif label == "NORTH / EAST / UP":
            freq["neu"] = [float(v) for v in ln[:60].split()]
        elif label == "END OF FREQUENCY":
            freq = None
        elif freq is not None and ln.startswith("   NOAZI"):
            freq["noazi"] = [float(v) for v in ln[8:].split()]
        elif freq is not None and ln[:8].strip():   # an azimuth row (its numbers run past column 60)
            freq["rows"].append([float(v) for v in ln.split()[1:]])
    return ants


def test_antex_13_reads_with_values_of_the_raw_lines():
    """IGS igs05.atx in ANTEX 1.3 (3 satellite antennas, 1 receiver antenna with azimuth rows): no warning, and
    offsets, NOAZI rows and the 73 x 19 azimuth grid equal the raw numbers exactly."""
    warns: list = []
    pats = read_antex(ANTEX_13, warnings=warns)
    assert warns == []
    raw = _raw_antex_blocks(ANTEX_13.read_text())
    assert [p.antenna_type for p in pats] == [a["type"] for a in raw] and len(pats) == 4
    n = 0
    for p, a in zip(pats, raw):
        assert p.dazi_deg == a["dazi"] and len(p.frequencies) == len(a["freqs"])
        for f, rf in zip(p.frequencies, a["freqs"]):
            assert f.code == rf["code"]
            np.testing.assert_array_equal(f.neu_mm, rf["neu"])
            np.testing.assert_array_equal(f.noazi_mm, rf["noazi"])
            if rf["rows"]:
                np.testing.assert_array_equal(f.pcv_mm, rf["rows"])
            else:
                assert f.pcv_mm is None
            n += 3 + len(rf["noazi"]) + sum(len(r) for r in rf["rows"])
    assert pats[3].antenna_type == "AOAD/M_B        NONE" and pats[3].frequencies[0].pcv_mm.shape == (73, 19)
    assert n > 2900


def test_antex_13_agrees_with_rtklib():
    """RTKLIB's readpcv (ANTEX 1.3 is its documented version): offsets and the NOAZI row in metres equal ours
    within 1e-12 m (RTKLIB multiplies mm by 1e-3 in its own expression)."""
    rk = require_module("pyrtklib", "RTKLIB reference reader")
    pcvs = rk.pcvs_t()
    assert rk.readpcv(str(ANTEX_13), pcvs) == 1 and pcvs.n == 4
    pats = read_antex(ANTEX_13)
    for i, p in enumerate(pats):
        c = pcvs.pcv[i]
        for k in range(2):   # RTKLIB keeps L1 and L2 of these files
            f = p.frequencies[k]
            # RTKLIB stores a receiver antenna's offset as east, north, up (a satellite's as x, y, z)
            off_mm = f.neu_mm[[1, 0, 2]] if i == 3 else f.neu_mm
            np.testing.assert_allclose([c.off[(k, a)] for a in range(3)], off_mm * 1e-3, rtol=0, atol=1e-12)
            n_zen = len(f.noazi_mm)
            np.testing.assert_allclose([c.var[(k, z)] for z in range(n_zen)], f.noazi_mm * 1e-3, rtol=0,
                                       atol=1e-12)


def _raw_v2_sbas_words(text: str) -> list[list[float]]:
    """Independent re-read of a RINEX 2 GEO navigation file: per record the 3 clock words of the epoch line (after
    its 22 characters of PRN and epoch) and the 12 words of its three orbit lines, by splitting on blanks."""
    body = text.split("END OF HEADER", 1)[1].splitlines()[1:]
    recs = []
    for k in range(0, len(body), 4):
        words = body[k][22:].split() + " ".join(body[k + 1:k + 4]).split()
        recs.append([float(w.replace("D", "E")) for w in words])
    return recs


def test_rinex_2_sbas_navigation_reads_with_the_metres_quirk():
    """The RINEX 2.10 document's GEO example (Table A18, AOR-E = S20): 4 records, read with one warning, the
    positions that its writer put in metres (its Table A17 says km) read as metres, so the satellite lies on the
    geostationary radius (within 100 km); every word equals the raw re-read."""
    nav = read_rinex_nav(SBAS_V2)
    assert [w.code for w in nav.warnings] == ["sbas-position-in-metres"] and nav.kepler == {}
    s = nav.sbas
    assert list(s.sat) == ["S20"] * 4 and s.toc[0].iso(0).startswith("2000-01-13T14:46:24")
    radius_m = np.linalg.norm(s.position_m, axis=1)
    assert np.all(np.abs(radius_m - GEO_RADIUS_M) < 100e3)
    raw = np.array(_raw_v2_sbas_words(SBAS_V2.read_text()))
    np.testing.assert_array_equal(np.c_[s.af0_s, s.af1_s_s, s.transmission_sow], raw[:, 0:3])
    np.testing.assert_array_equal(s.position_m, raw[:, [3, 7, 11]])
    np.testing.assert_array_equal(s.velocity_m_s, raw[:, [4, 8, 12]])
    np.testing.assert_array_equal(s.acceleration_m_s2, raw[:, [5, 9, 13]])
    np.testing.assert_array_equal(np.c_[s.health, s.ura_m, s.iodn], raw[:, [6, 10, 14]])


def test_rinex_2_sbas_words_agree_with_rtklib():
    """RTKLIB's readrnx reads the same records and words; it scales every position word by 1000 (km), so its
    positions are ours x 1000 (1e-15 relative: one multiplication) and its velocities and accelerations too."""
    rk = require_module("pyrtklib", "RTKLIB reference reader")
    obs, rnav, sta = rk.obs_t(), rk.nav_t(), rk.sta_t()
    assert rk.readrnx(str(SBAS_V2), 1, "", obs, rnav, sta) == 1 and rnav.ns == 4
    s = read_rinex_nav(SBAS_V2).sbas
    gps0_unix_s = 315964800   # 1980-01-06 in Unix seconds (RTKLIB's gtime_t is Unix time in GPST)
    for i in range(4):
        e = rnav.seph[i]
        assert e.t0.time + e.t0.sec == s.toc.s[i] + gps0_unix_s and (e.af0, e.af1) == (s.af0_s[i], s.af1_s_s[i])
        for theirs, ours in ((e.pos, s.position_m), (e.vel, s.velocity_m_s), (e.acc, s.acceleration_m_s2)):
            np.testing.assert_allclose(list(theirs), ours[i] * 1000.0, rtol=1e-15, atol=0)


def test_sbas_unit_rule_keeps_km_records_as_km():
    """A record in km (every real GEO position word < 1e5 km) is not taken as metres; only a position beyond
    SBAS_MAX_RADIUS_KM, which no Earth satellite has, is."""
    geo_km = [0.0, 0.0, 0.0, 40613.1, 0, 0, 0, -11245.4, 0, 0, 0, 78.2, 0, 0, 0]
    geo_m = [v * 1000.0 if k in (3, 7, 11) else v for k, v in enumerate(geo_km)]
    rows = [("S20", None, geo_km, 1), ("S20", None, geo_m, 5)]
    assert sbas_records_in_metres(rows).tolist() == [False, True]
    assert GEO_RADIUS_M / 1000.0 < SBAS_MAX_RADIUS_KM < GEO_RADIUS_M
