"""RINEX navigation reader: golden tests of each RINEX-QUIRKS "Navigation files" item, RINEX 4 dispatch,
errors with line numbers, ephemeris selection, and value-for-value agreement with georinex on the real files."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from tests.conftest import real_set, require_module
from tests.gnss.test_rinex_nav_builders import (GLO_VALUES, GPS_VALUES, d19, glonass_record_v3,
                                                 kepler_record_v2, kepler_record_v3, nav_header_v2,
                                                 nav_header_v3, nav_header_v4)
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_nav import (KeplerEphemeris, gps_minus_utc_s, read_rinex_nav, select_ephemeris,
                                      summarize_rinex_nav)
from gnssatt.gnss.time import GpsTime

KEPLER_FIELDS = ["sat", "toc", "af0_s", "af1_s_s", "af2_s_s2", "iode", "crs_m", "delta_n_rad_s", "m0_rad",
                 "cuc_rad", "e", "cus_rad", "sqrt_a_sqrt_m", "toe_sow", "cic_rad", "omega0_rad", "cis_rad",
                 "i0_rad", "crc_m", "omega_rad", "omega_dot_rad_s", "idot_rad_s", "week", "health", "tgd_s",
                 "iodc", "transmission_sow", "fit_interval_h", "accuracy_m", "line_no"]


def _b(text: str) -> bytes:
    return text.encode("ascii")


def test_kepler_fields_are_the_agreed_names():
    names = set(KeplerEphemeris.__dataclass_fields__)
    assert set(KEPLER_FIELDS) <= names
    assert {"bgd_e5a_e1_s", "bgd_e5b_e1_s", "data_sources", "tgd2_s"} <= names


def test_v3_gps_record_values_and_units():
    nav = read_rinex_nav(_b(nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00")), name="t.nav")
    k = nav.kepler["G"]
    assert k.sat.tolist() == ["G05"]
    assert k.toc.iso(0) == ["2024-06-24T10:00:00"]
    assert k.af0_s[0] == GPS_VALUES[0] and k.sqrt_a_sqrt_m[0] == GPS_VALUES[10]
    assert k.toe_sow[0] == 122400.0 and k.week[0] == 2320 and k.iode[0] == 72 and k.iodc[0] == 72
    assert k.transmission_sow[0] == 115218.0 and k.fit_interval_h[0] == 4.0 and k.line_no[0] == 7
    assert nav.klobuchar_alpha[0] == pytest.approx(1.8626e-08) and nav.klobuchar_beta[3] == -2.6214e+05
    assert nav.leap_seconds == 18


def test_quirk_d_exponents_and_fields_running_into_each_other():
    """RINEX-QUIRKS nav: 'D-exponent numbers (1.234D-05) and fields that run into each other without spaces'."""
    vals = list(GPS_VALUES)
    vals[0:3] = [-1.774230040610e-04, -1.364242052659e-12, -2.0e-20]  # three negatives: no blank between them
    text = nav_header_v2() + kepler_record_v2(5, "24  6 24 10  0  0.0", vals, exp_letter="D")
    assert "D-04-1.364242052659D-12-2.000000000000D-20" in text
    k = read_rinex_nav(_b(text), name="t.24n").kepler["G"]
    assert (k.af0_s[0], k.af1_s_s[0], k.af2_s_s2[0]) == (vals[0], vals[1], vals[2])
    assert k.crs_m[0] == -98.21875 and k.sat[0] == "G05"


def test_quirk_extra_spare_words_are_ignored_and_counted():
    """RINEX-QUIRKS nav: 'converters carry extra spare words per record'."""
    plain = read_rinex_nav(_b(nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00")), name="a")
    text = nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00", extra_lines=1) + \
        kepler_record_v3("G07", "2024 06 24 12 00 00", extra_lines=1)
    nav = read_rinex_nav(_b(text), name="b")
    k = nav.kepler["G"]
    assert k.sat.tolist() == ["G05", "G07"] and k.line_no.tolist() == [7, 16]
    assert k.m0_rad[0] == plain.kepler["G"].m0_rad[0]
    w = [w for w in nav.warnings if w.code == "extra-spare-lines"]
    assert len(w) == 1 and "2 times" in w[0].message


def test_quirk_glonass_epochs_are_utc():
    """RINEX-QUIRKS nav: 'GLONASS ephemeris times are UTC, not GPS time'."""
    text = nav_header_v3() + glonass_record_v3("R01", "2024 06 24 08 15 00")
    g = read_rinex_nav(_b(text), name="g.nav").glonass
    assert g.toc.iso(0) == ["2024-06-24T08:15:18"]  # UTC + 18 s
    assert g.leap_s.tolist() == [18]
    np.testing.assert_array_equal(g.position_m[0], np.array([GLO_VALUES[3], GLO_VALUES[7], GLO_VALUES[11]]) * 1e3)
    np.testing.assert_array_equal(g.velocity_m_s[0], np.array([GLO_VALUES[4], GLO_VALUES[8], GLO_VALUES[12]]) * 1e3)
    assert g.tau_n_s[0] == -GLO_VALUES[0] and g.frequency_number[0] == 1 and g.health[0] == 0


def test_leap_seconds_table_steps():
    t = GpsTime.from_calendar([2005, 2006, 2016, 2017], [12, 1, 12, 1], [31, 1, 31, 1], [23, 0, 23, 0])
    assert gps_minus_utc_s(t.s).tolist() == [13, 14, 17, 18]


def test_quirk_same_toe_records_selection_is_deterministic():
    """RINEX-QUIRKS nav: 'several records for one satellite with the same toe: choose by toe, health and the
    latest transmission time, deterministically'."""
    def rec(epoch, iode, trans, health=0.0, toe=122400.0):
        v = list(GPS_VALUES)
        v[3], v[26], v[27], v[24], v[11] = iode, iode, trans, health, toe
        return kepler_record_v3("G05", epoch, v)
    text = nav_header_v3() + rec("2024 06 24 10 00 00", 72, 115218.0) + \
        rec("2024 06 24 10 00 00", 73, 116000.0) + rec("2024 06 24 10 00 00", 74, 117000.0, health=1.0) + \
        rec("2024 06 24 12 00 00", 80, 122000.0, toe=129600.0)
    k = read_rinex_nav(_b(text), name="dup.nav").kepler["G"]
    assert len(k) == 4  # all kept
    t = GpsTime.from_week_sow(2320, 121500.0)  # before the 12:00 data set (IODE 80) was sent at 122000
    assert select_ephemeris(k, "G05", t) == 1  # same toe: healthy, latest transmission
    assert select_ephemeris(k, "G05", t, allow_unhealthy=True) == 2
    # Nearest toe wins; beyond 2 h from every toe (4 h fit interval) nothing qualifies.
    assert select_ephemeris(k, "G05", GpsTime.from_week_sow(2320, 129600.0 - 1000.0)) == 3
    assert select_ephemeris(k, "G05", GpsTime.from_week_sow(2320, 129600.0 + 7300.0)) == -1
    # Once IODE 80 has been sent (122000) a receiver holds it, although IODE 73's toe is nearer at 122400.
    many = select_ephemeris(k, "G05", GpsTime.from_week_sow(2320, np.array([121999.0, 122400.0, 126100.0, 0.0])))
    assert many.tolist() == [1, 3, 3, -1]
    assert select_ephemeris(k, "G07", t) == -1
    # Same answer whatever the file order (determinism).
    text2 = nav_header_v3() + rec("2024 06 24 10 00 00", 73, 116000.0) + rec("2024 06 24 10 00 00", 72, 115218.0)
    k2 = read_rinex_nav(_b(text2), name="dup2.nav").kepler["G"]
    assert k2.iode[select_ephemeris(k2, "G05", t)] == 73


def test_rinex4_dispatch_keeps_other_records_as_messages():
    eph = kepler_record_v3("G05", "2024 06 24 10 00 00")
    cnav_body = eph + "    " + d19(1.0) * 2 + "\n"  # a 9-line CNAV-like record: must not be read as LNAV
    text = (nav_header_v4() + "> EPH G05 LNAV\n" + eph + "> EPH G05 CNAV\n" + cnav_body +
            "> STO G01 LNAV\n" + "    2024 06 24 10 00 00 GPUT\n" + "    " + d19(1.0) * 3 + "\n" +
            "> ION G01 LNAV\n" + "    2024 06 24 10 00 00" + d19(1e-8) * 3 + "\n" + "> EOP G01 CNVX\n" +
            "    2024 06 24 10 00 00" + d19(0.1) * 3 + "\n" + "> EPH R01 FDMA\n" +
            glonass_record_v3("R01", "2024 06 24 08 15 00") + "> EPH E11 INAV\n" +
            kepler_record_v3("E11", "2024 06 24 10 00 00"))
    nav = read_rinex_nav(_b(text), name="v4.rnx")
    assert nav.kepler["G"].sat.tolist() == ["G05"] and nav.kepler["G"].line_no.tolist() == [6]
    assert nav.kepler["E"].sat.tolist() == ["E11"] and len(nav.glonass) == 1
    # the CNAV record is kept as read, never taken for LNAV; STO/ION/EOP become NavMessages
    assert nav.skipped == {} and [(m.kind, m.msg_type) for m in nav.messages] == [
        ("EPH", "CNAV"), ("STO", "LNAV"), ("ION", "LNAV"), ("EOP", "CNVX")]
    assert nav.messages[0].values.size == 3 + 4 * 8 and nav.messages[1].label == "GPUT"
    assert nav.messages[2].named()["alpha0_s"] == 1e-8
    bad = text.replace("> EPH E11 INAV\nE11", "> EPH E11 INAV\nE12")
    with pytest.raises(ParseError, match="satellite E11"):
        read_rinex_nav(_b(bad), name="v4.rnx")


def test_galileo_and_beidou_words():
    v = list(GPS_VALUES)
    v[20], v[25], v[26] = 517.0, -1.6e-09, -2.3e-09  # data sources (bit 9: E5b/E1 clock), BGDs
    e = kepler_record_v3("E04", "2024 06 24 08 00 00", v)
    c = list(GPS_VALUES)
    c[21], c[25], c[26], c[28] = 964.0, -4.9e-09, -1.0e-08, 0.0
    cb = kepler_record_v3("C01", "2024 06 24 08 00 00", c)
    nav = read_rinex_nav(_b(nav_header_v3() + e + cb), name="m.nav")
    ke, kc = nav.kepler["E"], nav.kepler["C"]
    assert ke.data_sources[0] == 517 and ke.tgd_s[0] == -2.3e-09 and ke.bgd_e5a_e1_s[0] == -1.6e-09
    assert ke.iodc[0] == -1 and np.isnan(ke.fit_interval_h[0])
    assert kc.week[0] == 964 and kc.tgd_s[0] == -4.9e-09 and kc.tgd2_s[0] == -1.0e-08 and kc.time_system == "BDT"
    assert (kc.toc_gpst() - kc.toc)[0] == 14.0
    assert (kc.toe_gpst() - GpsTime.from_week_sow(964 + 1356, GPS_VALUES[11]))[0] == 14.0


def test_week_written_modulo_1024_is_fixed_and_reported():
    v = list(GPS_VALUES)
    v[21] = 2320 - 2048
    nav = read_rinex_nav(_b(nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00", v)), name="w")
    assert nav.kepler["G"].week[0] == 2320
    assert any(w.code == "week-rollover-fixed" for w in nav.warnings)


@pytest.mark.parametrize("mutate, line, what", [
    (lambda t: t.replace("E-06 5.927", "E-0X 5.927"), 9, "D19.12"),          # garbage in a field
    (lambda t: "\n".join(t.split("\n")[:-3]) + "\n", 13, "BROADCAST ORBIT - 6"),  # truncated record
    (lambda t: t.replace("END OF HEADER", "END OF HEADRR"), None, "END OF HEADER"),
    (lambda t: t.replace("     3.04", "     5.00", 1), 1, "version"),
    (lambda t: t.replace("G05 2024 06 24", "G05 2024 13 24"), 7, "valid epoch"),
])
def test_broken_files_raise_parse_error_with_line(mutate, line, what):
    text = mutate(nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00"))
    with pytest.raises(ParseError) as info:
        read_rinex_nav(_b(text), name="bad.nav")
    assert what in str(info.value)
    if line is not None:
        assert info.value.line_no == line
    assert info.value.path == "bad.nav"


def test_column_shifted_continuation_lines_are_read_and_reported():
    body = kepler_record_v2(5, "24  6 24 10  0  0.0")  # 3X,4D19.12 lines written with 4X (one column late)
    shifted = "\n".join((" " + ln) if ln.startswith("   ") else ln for ln in body.split("\n"))
    nav = read_rinex_nav(_b(nav_header_v2() + shifted), name="s.24n")
    assert nav.kepler["G"].crs_m[0] == -98.21875
    assert any(w.code == "column-shift" for w in nav.warnings)


# --- real files ------------------------------------------------------------------------------------------

def _georinex_load(path):
    georinex = require_module("georinex")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return georinex.load(path)


_GR_MAP = {  # georinex variable -> our field (GPS/QZSS layout)
    "SVclockBias": "af0_s", "SVclockDrift": "af1_s_s", "SVclockDriftRate": "af2_s_s2", "Crs": "crs_m",
    "DeltaN": "delta_n_rad_s", "M0": "m0_rad", "Cuc": "cuc_rad", "Eccentricity": "e", "Cus": "cus_rad",
    "sqrtA": "sqrt_a_sqrt_m", "Toe": "toe_sow", "Cic": "cic_rad", "Omega0": "omega0_rad", "Cis": "cis_rad",
    "Io": "i0_rad", "Crc": "crc_m", "omega": "omega_rad", "OmegaDot": "omega_dot_rad_s", "IDOT": "idot_rad_s",
    "health": "health", "TransTime": "transmission_sow",
}
_GR_SYS = {"G": {"IODE": "iode", "GPSWeek": "week", "TGD": "tgd_s", "IODC": "iodc", "SVacc": "accuracy_m"},
           "J": {"IODE": "iode", "GPSWeek": "week", "TGD": "tgd_s", "IODC": "iodc", "SVacc": "accuracy_m"},
           "E": {"IODnav": "iode", "GALWeek": "week", "SISA": "accuracy_m", "BGDe5a": "bgd_e5a_e1_s",
                 "BGDe5b": "bgd_e5b_e1_s", "DataSrc": "data_sources"},
           "C": {"AODE": "iode", "BDTWeek": "week", "SatH1": "health", "TGD1": "tgd_s", "TGD2": "tgd2_s",
                 "AODC": "iodc", "SVacc": "accuracy_m"}}


def _compare_with_georinex(path):
    nav = read_rinex_nav(path)
    ds = _georinex_load(path)
    times = ds.time.values.astype("datetime64[ms]").astype(np.int64)  # ms since 1970 (as written)
    checked = 0
    for sys, k in nav.kepler.items():
        ours_ms = np.round((k.toc.s + 315964800) * 1000.0 + k.toc.frac * 1000.0).astype(np.int64)
        pairs = list(zip(k.sat.tolist(), ours_ms.tolist()))
        for r, (sat, ms) in enumerate(pairs):
            if pairs.count((sat, ms)) != 1 or sat not in ds.sv.values:
                continue  # georinex keeps one record of duplicated (sat, epoch); ambiguous
            ti = np.flatnonzero(times == ms)
            assert ti.size == 1, f"{sat} {ms}: georinex has no such epoch"
            rec = ds.sel(sv=sat).isel(time=int(ti[0]))
            mapping = dict(_GR_MAP)
            mapping.update(_GR_SYS[sys])
            for gv, ours in mapping.items():
                if gv not in rec:
                    continue
                theirs = float(rec[gv].values)
                mine = float(getattr(k, ours)[r])
                if np.isnan(theirs):
                    continue
                assert mine == theirs, f"{path.name} {sat} line {k.line_no[r]} {gv}: {mine} != {theirs}"
                checked += 1
    if len(nav.glonass):
        g = nav.glonass
        utc = GpsTime(g.toc.s - g.leap_s, g.toc.frac)
        ms_all = np.round((utc.s + 315964800) * 1000.0 + utc.frac * 1000.0).astype(np.int64)
        for r, sat in enumerate(g.sat.tolist()):
            ti = np.flatnonzero(times == ms_all[r])
            rec = ds.sel(sv=sat).isel(time=int(ti[0]))
            np.testing.assert_array_equal(g.position_m[r], [float(rec[c].values) for c in ("X", "Y", "Z")])
            np.testing.assert_array_equal(g.velocity_m_s[r], [float(rec[c].values) for c in ("dX", "dY", "dZ")])
            assert g.tau_n_s[r] == -float(rec["SVclockBias"].values)
            assert g.frequency_number[r] == float(rec["FreqNum"].values)
            checked += 8
    return checked


@pytest.mark.parametrize("set_name, fname", [
    ("static_1m_mosaicx5_nagoya_2024", "base.nav"),
    ("leo_grace_a_2007080", "brdc0800.07n.gz"),
    ("geonet_0759_3040_3km_2005", "07590920.05n"),
])
def test_real_nav_value_for_value_against_georinex(set_name, fname):
    path = real_set(set_name) / fname
    checked = _compare_with_georinex(path)
    assert checked > 1000


def test_real_nav_counts_match_readme():
    nav = read_rinex_nav(real_set("static_1m_mosaicx5_nagoya_2024") / "base.nav")
    assert {s: len(k) for s, k in nav.kepler.items()} == {"G": 13, "E": 67, "C": 32, "J": 3}
    assert len(nav.glonass) == 19 and nav.warnings == []
    q = read_rinex_nav(real_set("qzss_l1s_geonet3034_sept_2021") / "SEPT2650.21P")
    assert {s: len(k) for s, k in q.kepler.items()} == {"G": 49, "J": 19, "E": 253}
    assert sorted(set(q.kepler["J"].sat.tolist())) == ["J01", "J02", "J03", "J07"]
    b = read_rinex_nav(real_set("leo_grace_a_2007080") / "brdc0800.07n.gz")
    assert len(b.kepler["G"]) == 392 and b.leap_seconds == 14
    # The GLONASS record R01 08:15:00 UTC of base.nav is 08:15:18 GPST.
    i = int(np.flatnonzero(nav.glonass.sat == "R01")[0])
    assert nav.glonass.toc[i].iso(0) == "2024-06-24T08:15:18"


def test_real_nav_summary():
    s = summarize_rinex_nav(real_set("upc1_upc2_38m_barcelona_2010") / "brdc0770.11n")
    assert s["version"] == 2.1 and s["systems"] == ["G"] and s["n_records"] == {"G": 194}
    assert s["time_span_gps"][0].startswith("2010-03-17T23:00") and s["time_span_gps"][1].startswith("2010-03-19")
    assert s["has_klobuchar"] and s["leap_seconds"] == 15


def test_rinex2_glonass_file_utc_epochs():
    """RINEX 2 'G' file: epochs in UTC, converted with the leap seconds of the epoch's date (14 s in 2007)."""
    from tests.gnss.test_rinex_nav_builders import header_line
    hdr = "\n".join([header_line("     2.01           G: GLONASS NAV DATA", "RINEX VERSION / TYPE"),
                     header_line("gnssatt-test", "PGM / RUN BY / DATE"),
                     header_line("    14", "LEAP SECONDS"), header_line("", "END OF HEADER")]) + "\n"
    v = [d19(x, "D") for x in GLO_VALUES]
    rec = "\n".join([" 3 07  3 21  0 15  0.0" + "".join(v[0:3])] +
                    ["   " + "".join(v[k:k + 4]) for k in (3, 7, 11)]) + "\n"
    nav = read_rinex_nav(_b(hdr + rec), name="g.07g")
    g = nav.glonass
    assert g.sat.tolist() == ["R03"] and g.toc.iso(0) == ["2007-03-21T00:15:14"] and g.leap_s.tolist() == [14]
    assert g.position_m[0, 2] == GLO_VALUES[11] * 1e3 and nav.kepler == {}
    wrong = hdr.replace("    14", "    13")
    nav2 = read_rinex_nav(_b(wrong + rec), name="g.07g")
    assert nav2.glonass.toc.iso(0) == ["2007-03-21T00:15:14"]
    assert any(w.code == "leap-seconds-mismatch" for w in nav2.warnings)
