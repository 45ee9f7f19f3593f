"""Quirks of real files that the readers read with a structured warning instead of refusing them
(docs/reader_policy.md), each on the third-party file where it was found and, where cheap, on a minimal edit of a
valid file so the test does not depend on one file. Broken variants next to each quirk still raise ParseError."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.gnss.io.antex import read_antex
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_clock import read_rinex_clock
from tests.corpus.third_party import third_party_file

GEORUST = "georust+rinex/test_resources/"


def _codes(warnings) -> set[str]:
    return {w.code for w in warnings}


# --- ANTEX ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("rel, n_declared, n_blocks", [
    (GEORUST + "ATX/V1/ROULAR25.24__LEIT_2020_09_24.atx", 26, 2),
    (GEORUST + "ATX/V1/TROSAR25.R4__LEIT_2020_09_23.atx", 26, 3),
])
def test_antex_frequency_count_disagreeing_with_blocks(rel, n_declared, n_blocks):
    warns: list = []
    (ant,) = read_antex(third_party_file(rel), warnings=warns)
    assert len(ant.frequencies) == n_blocks
    (w,) = warns
    assert w.code == "frequency-count-mismatch" and f"says {n_declared}" in w.message


def test_antex_dazi_without_azimuth_rows_uses_noazi():
    """RTKLIB's gnssant_ext.atx: DAZI 5.0 but only NOAZI rows in some antennas (73 rows implied)."""
    path = third_party_file("rtklibexplorer+RTKLIB/data/ant/gnssant_ext.atx")
    warns: list = []
    pats = read_antex(path, warnings=warns)
    assert "azimuth-rows-missing" in _codes(warns)
    no_rows = [f for p in pats if p.dazi_deg > 0 for f in p.frequencies if f.pcv_mm is None]
    assert no_rows and all(len(f.noazi_mm) == 19 for f in no_rows)   # ZEN1/ZEN2/DZEN 0/90/5
    # the NOAZI row is the raw line's numbers (line 337 of the file: ANN_MB_00_C G01)
    line = path.read_text().splitlines()[336]
    assert line.startswith("   NOAZI")
    raw = [float(line[8 + 8 * k:16 + 8 * k]) for k in range(19)]
    ann = next(p for p in pats if p.antenna_type.startswith("ANN_MB_00_C"))
    np.testing.assert_array_equal(ann.frequencies[0].noazi_mm, raw)


def test_antex_partial_azimuth_rows_still_refused():
    """Some but not all azimuth rows is ambiguous (which sector is missing?): an error, not a quirk."""
    path = third_party_file("tomojitakasu+RTKLIB/data/igs05.atx")
    lines = path.read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("   355.0"))
    with pytest.raises(ParseError, match="azimuth rows"):
        read_antex("".join(lines[:k] + lines[k + 2:]).encode(), name="cut.atx")


def test_antex_missing_end_of_antenna_closed_at_next_start():
    warns: list = []
    pats = read_antex(third_party_file(GEORUST + "ATX/V1/igs14_small.atx.gz"), warnings=warns)
    assert "missing-end-of-antenna" in _codes(warns)
    assert len(pats) == 6 and {p.antenna_type.split()[0] for p in pats} >= {"BLOCK", "EML_REACH_RS2", "GALILEO-2"}


# --- RINEX clock -----------------------------------------------------------------------------------------

def test_rinex_clock_304_wide_first_line():
    """RINEX clock 3.04 labels in columns 66-85, A9 clock names (COD's MGEX product): values as the raw line says;
    the 3.04 example file also puts its second value one column right: read by tokens with a warning, never cut."""
    cod = read_rinex_clock(third_party_file("Stanford-NavLab+gnss_lib_py/data/unit_test/clk/"
                                            "COD0MGXFIN_20211180000_01D_30S_CLK.CLK"))
    assert cod.version == 3.04 and cod.warnings == [] and len(cod.time) > 0
    # 'AS E01       2021 04 28 19 30  0.000000  2   -0.109666757011E-02  0.188030325505E-10'
    e01 = cod.sats.index("E01")
    assert cod.clock_s[0, e01] == -0.109666757011e-02 and cod.sigma_s[0, e01] == 0.188030325505e-10
    path = third_party_file(GEORUST + "CLK/V3/example1.txt")
    clk = read_rinex_clock(path)
    assert clk.version == 3.04 and _codes(clk.warnings) == {"misplaced-values"}
    assert "AREQ00USA" in [r.decode().strip() if isinstance(r, bytes) else str(r).strip()
                           for r in clk.receivers]
    g16 = clk.sats.index("G16")
    # 'AS G16       1994 07 14 20 59  0.000000  2   -0.123456789012E+00  -0.123456789012E-01'
    assert clk.clock_s[0, g16] == -0.123456789012 and clk.sigma_s[0, g16] == -0.0123456789012


def test_rinex_clock_labels_in_66_85_refused_before_304():
    text = third_party_file(GEORUST + "CLK/V3/example1.txt").read_bytes().replace(b"3.04     ", b"3.02     ", 1)
    with pytest.raises(ParseError, match="only from RINEX clock 3.04"):
        read_rinex_clock(text, name="x.clk")


def test_rinex_clock_304_identified_by_the_upload_sniffer():
    from gnssatt.gnss.io.sniff import identify

    kind, summary = identify(third_party_file(GEORUST + "CLK/V3/example2.txt"), "example2.txt")
    assert kind == "rinex_clock" and summary["version"] == 3.04


# --- SP3 ---------------------------------------------------------------------------------------------------

def _raw_p(path, sat: str, k: int = 0) -> tuple[float, float, float, float]:
    """x, y, z (km) and clock (us) of the k-th 'P' record of `sat`, re-read from the raw line (3F14.6, F14.6)."""
    import gzip

    data = path.read_bytes()
    text = (gzip.decompress(data) if data[:2] == b"\x1f\x8b" else data).decode("latin-1")
    recs = [ln for ln in text.splitlines() if ln.startswith("P") and
            (ln[1:4] == sat or (ln[1] == " " and sat == f"G{int(ln[2:4]):02d}"))]
    ln = recs[k]
    return tuple(float(ln[4 + 14 * i:18 + 14 * i]) for i in range(4))


def test_sp3c_satellite_missing_from_plus_lines():
    from gnssatt.gnss.io.sp3 import read_sp3

    path = third_party_file("SGL-UT+gnsstk-data/test_input_SP3c_mgex3.sp3")
    sp3 = read_sp3(path)
    assert {"unlisted-satellite", "listed-without-records"} <= _codes(sp3.warnings)
    assert "C07" in sp3.sats and "C02" not in sp3.sats   # C02 listed, C07 in the body: never swapped
    x, y, z, c = _raw_p(path, "C07")
    j = sp3.sats.index("C07")
    np.testing.assert_array_equal(sp3.position_ecef_m[0, j], np.array([x, y, z]) * 1000.0)
    assert sp3.clock_s[0, j] == c * 1e-6


def test_sp3d_listed_satellites_without_records_dropped():
    from gnssatt.gnss.io.sp3 import read_sp3

    path = third_party_file(GEORUST + "SP3/sp3d.txt")
    sp3 = read_sp3(path)
    (w,) = [w for w in sp3.warnings if w.code == "listed-without-records"]
    assert w.line_no == 3 and "C02" in w.message
    body_sats = {ln[1:4] for ln in path.read_text().splitlines() if ln.startswith("P")}
    assert set(sp3.sats) == body_sats and np.isfinite(sp3.position_ecef_m).all(axis=2).any(axis=0).all()


@pytest.mark.parametrize("rel", ["example1.sp3a", "example1.sp3a.gz", "example2.sp3a"])
def test_sp3a_elision_lines_skipped(rel):
    from gnssatt.gnss.io.sp3 import read_sp3

    path = third_party_file("geospace-code+georinex/src/georinex/tests/data/" + rel)
    sp3 = read_sp3(path)
    assert "elision-line" in _codes(sp3.warnings) and sp3.version == "a" and len(sp3.time) == 3
    x, y, z, c = _raw_p(path, "G31", 2)
    np.testing.assert_array_equal(sp3.position_ecef_m[2, sp3.sats.index("G31")], np.array([x, y, z]) * 1000.0)


def test_oldest_sp3_without_version_letter():
    from gnssatt.gnss.io.sp3 import read_sp3

    path = third_party_file(GEORUST + "SP3/sio06492.sp3")
    sp3 = read_sp3(path)
    assert "no-version-letter" in _codes(sp3.warnings) and sp3.version == "a" and len(sp3.sats) == 17
    assert sp3.time[0].iso(0).startswith("1992-06-15T08:37:29")
    x, y, z, c = _raw_p(path, "G02")
    np.testing.assert_array_equal(sp3.position_ecef_m[0, 0], np.array([x, y, z]) * 1000.0)
    assert c == 999999.999999 and np.isnan(sp3.clock_s[0, 0])          # the 'bad or absent' clock


def test_sp3_leading_blank_line_keeps_line_numbers():
    from gnssatt.gnss.io.sp3 import read_sp3

    path = third_party_file("geospace-code+georinex/src/georinex/tests/data/igs19362.sp3c")
    sp3 = read_sp3(path)
    assert {"leading-blank-lines", "blank-line"} <= _codes(sp3.warnings) and len(sp3.sats) == 32
    raw = path.read_bytes()
    k = raw.index(b"\nPG01") + 1
    with pytest.raises(ParseError) as info:   # an error still names the line of the file, blank line counted
        read_sp3(raw[:k] + b"PG0x" + raw[k + 4:], name="b.sp3")
    assert info.value.line_no == raw[:k].count(b"\n") + 1


def test_oldest_sp3_identified_by_the_upload_sniffer():
    from gnssatt.gnss.io.sniff import identify

    kind, summary = identify(third_party_file(GEORUST + "SP3/sio06492.sp3"), "sio06492.sp3")
    assert kind == "sp3" and "no-version-letter" in {w["code"] for w in summary["warnings"]}


# --- RINEX navigation ------------------------------------------------------------------------------------

def _d(text: str) -> float:
    return float(text.replace("D", "E"))


@pytest.mark.parametrize("rel, system, sat, n_records, sqrt_a_text", [
    # teqc's RINEX 2.12 Galileo ('E' in column 21, PRN I2, 3X orbit lines)
    ("geospace-code+georinex/src/georinex/tests/data/ceda2100.18e", "E", "E05", 29, "5.440621961594D+03"),
    # RTKLIB's Galileo 2.x ('L'; version written '2')
    ("tomojitakasu+RTKLIB/util/simobs/sim/brdc0910.09l", "E", "E01", 27, "0.544070739886E+04"),
    # RTKLIB's QZSS 2.12 ('N' with 'J' in column 41; 'J 1' ids, 4X orbit lines)
    ("tomojitakasu+RTKLIB/test/data/tle/brdc3050.12q", "J", "J01", 96, "6.493972862244D+03"),
])
def test_rinex2_galileo_and_qzss_navigation(rel, system, sat, n_records, sqrt_a_text):
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    path = third_party_file(rel)
    nav = read_rinex_nav(path)
    assert "rinex2-extension" in _codes(nav.warnings) and list(nav.kepler) == [system]
    eph = nav.kepler[system]
    # as many records as record-start lines (non-blank columns 1-2 after the header)
    lines = path.read_text().splitlines()
    body = lines[next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1:]
    assert len(eph.sat) == sum(1 for ln in body if ln[:2].strip()) == n_records
    assert eph.sat[0] == sat and eph.sqrt_a_sqrt_m[0] == _d(sqrt_a_text)


def test_beidou_week_not_matching_the_epoch_taken_from_epoch():
    """gnsstk's BDS D1 round-trip file writes week 1 in 2014 (BDT week 435, GPS week 1791): the week of toe
    follows from toc and toe's seconds of week (RTKLIB's adjweek), with a warning; a GPS file is unaffected."""
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    nav = read_rinex_nav(third_party_file("SGL-UT+gnsstk-data/rinnav_BDS_D1_test.14n"))
    (w,) = [w for w in nav.warnings if w.code == "week-from-epoch"]
    assert "e.g. 1)" in w.message and "BDT" in w.message and w.line_no == 11
    eph = nav.kepler["C"]
    # toc 2014-05-10 00:00 BDT = BDT week 435, 518400 s; toe 1245 s of week is nearest in week 436
    assert eph.week[0] == 436 and eph.toe_sow[0] == 1245.0
    gps = read_rinex_nav(third_party_file("tomojitakasu+RTKLIB/test/data/rinex/brdc1820.10n"))
    assert "week-from-epoch" not in _codes(gps.warnings) and set(gps.kepler["G"].week) <= {1590, 1591}


@pytest.mark.parametrize("rel", ["blank1st.10n", "blank3_1st.10n"])
def test_navigation_leading_blank_lines(rel):
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    nav = read_rinex_nav(third_party_file("geospace-code+georinex/src/georinex/tests/data/" + rel))
    (w,) = nav.warnings
    assert w.code == "leading-blank-lines" and w.line_no == 2 and not nav.kepler


def test_navigation_blank_inside_a_number_still_refused():
    """georinex's galileo3.15n writes '. 000000000000D+00' (BGD E5b/E1): a blank inside a number is not a
    misplaced number; refused with file, line and column (georinex returns NaN for it silently)."""
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    with pytest.raises(ParseError) as info:
        read_rinex_nav(third_party_file("geospace-code+georinex/src/georinex/tests/data/galileo3.15n"))
    assert (info.value.line_no, info.value.column) == (29, 62) and "D19.12" in info.value.expected


# --- RINEX observation -----------------------------------------------------------------------------------

GEORINEX = "geospace-code+georinex/src/georinex/tests/data/"


def test_rinex211_truncated_last_epoch_reads_the_epochs_before():
    """georust's rovn0010.21o ends 1 line into the records of its 7th epoch (20 satellites x 3 lines announced)."""
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    path = third_party_file(GEORUST + "OBS/V2/rovn0010.21o")
    obs = read_rinex_obs(path)
    (w,) = [w for w in obs.warnings if w.code == "truncated-last-epoch"]
    assert w.line_no == 512
    assert len(obs.time) == sum(1 for ln in path.read_text().splitlines()
                                if ln.startswith(" 21 01 01")) - 1 == 5
    # the last whole epoch's first record, re-read from the raw line (F14.3 in columns 1-14)
    lines = path.read_text().splitlines()
    k = max(i for i, ln in enumerate(lines[:511]) if ln.startswith(" 21 01 01"))
    first_sat = lines[k][32:35].replace(" ", "0")
    n = int(lines[k][29:32])
    assert obs.values[-1, obs.sats.index(first_sat), 0] == float(lines[k + 1 + (n - 1) // 12][0:14])


@pytest.mark.parametrize("rel", ["demo.10o", "demo3.10o", "rinex2onesat.10o"])
def test_approx_position_off_its_columns(rel):
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    obs = read_rinex_obs(third_party_file(GEORINEX + rel))
    assert {"approx-position-misplaced", "antenna-delta-misplaced"} <= _codes(obs.warnings)
    # '   4789028.4701    176610.0133   4195017.0310' (each number one column right of its F14.4 field)
    np.testing.assert_array_equal(obs.header.approx_position_ecef_m, [4789028.4701, 176610.0133, 4195017.0310])
    np.testing.assert_array_equal(obs.header.antenna_delta_hen_m, [0.9030, 0.0, 0.0])


def test_approx_position_in_columns_has_no_warning_and_garbage_is_refused():
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    raw = third_party_file(GEORINEX + "demo.10o").read_bytes()
    old = b"   4789028.4701    176610.0133   4195017.0310"
    fixed = raw.replace(old, b"%14.4f%14.4f%14.4f" % (4789028.4701, 176610.0133, 4195017.0310) + b"   ", 1)
    assert fixed != raw
    obs = read_rinex_obs(fixed, name="fixed.10o")
    assert "approx-position-misplaced" not in _codes(obs.warnings)
    np.testing.assert_array_equal(obs.header.approx_position_ecef_m, [4789028.4701, 176610.0133, 4195017.0310])
    with pytest.raises(ParseError, match="three F14.4 numbers") as info:
        read_rinex_obs(raw.replace(b"176610.0133", b"176610.01x3", 1), name="bad.10o")
    assert info.value.line_no == 13


def test_rinex2_type_count_smaller_than_the_list():
    """georinex's wrong_obs2_count.10o: '# / TYPES OF OBSERV' says 6 and lists 7; the body has 7 fields."""
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    path = third_party_file(GEORINEX + "wrong_obs2_count.10o")
    obs = read_rinex_obs(path)
    assert "obs-type-count-mismatch" in _codes(obs.warnings)
    assert obs.header.obs_types["G"] == ["L1", "L2", "P1", "P2", "C1", "S1", "S2"]
    # G13's S2 is the 7th field: second record line, columns 17-30 ('        62.000          80.000')
    assert obs.values[0, obs.sats.index("G13"), obs.codes.index("S2")] == 80.0


@pytest.mark.parametrize("rel", ["blank1st.10o", "blank3_1st.10o"])
def test_observation_leading_blank_lines(rel):
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    obs = read_rinex_obs(third_party_file(GEORINEX + rel))
    assert {"leading-blank-lines", "no-epochs"} <= _codes(obs.warnings)
    (w,) = [w for w in obs.warnings if w.code == "leading-blank-lines"]
    assert w.line_no == 2


@pytest.mark.parametrize("rel, code", [
    (GEORUST + "OBS/V2/rovn0010.21o", "truncated-last-epoch"),
    (GEORINEX + "demo.10o", "approx-position-misplaced"),
    (GEORINEX + "wrong_obs2_count.10o", "obs-type-count-mismatch"),
    (GEORINEX + "blank1st.10n", "leading-blank-lines"),
    (GEORINEX + "igs19362.sp3c", "leading-blank-lines"),
    (GEORINEX + "ceda2100.18e", "rinex2-extension"),
])
def test_quirks_reach_the_upload_summary(rel, code):
    """The upload sniffer (the set's summary) reports the same quirk codes as the full readers."""
    from gnssatt.gnss.io.sniff import identify

    kind, summary = identify(third_party_file(rel), rel.rsplit("/", 1)[1])
    assert code in {w["code"] for w in summary["warnings"]}
    if kind == "rinex_obs" and code == "truncated-last-epoch":
        assert summary["n_epochs"] == 5


def test_blank_inside_epoch_seconds_is_refused():
    """georinex's badtime.10o writes '0 .0000000' as the seconds of its first epoch: a blank inside a number is
    an error (docs/reader_policy.md), not read as 0 s (gnssatt did before) nor dropped silently (georinex)."""
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    with pytest.raises(ParseError) as info:
        read_rinex_obs(third_party_file(GEORINEX + "badtime.10o"))
    assert info.value.line_no == 5 and "epoch line" in info.value.expected
