"""Golden tests of the RINEX observation reader: every 'Observation files' item of RINEX-QUIRKS.md, errors, API.

Inputs are small files written here (through gnssatt's writer, then edited as text) or real files of
../shared/data/real (skipped with a reason when absent).
"""
from __future__ import annotations

import gzip

import hatanaka
import numpy as np
import pytest

from tests.conftest import real_set
from tests.gnss.test_rinex_obs_helpers import replace_header_line, small_obs
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_obs import read_rinex_obs, rinex3_code, summarize_rinex_obs
from gnssatt.gnss.io.rinex_obs_write import ObsWriteHeader, rinex_obs_bytes


V2_SATS = ("G01", "G05", "R07")


def _text(obs=None, version=3.04, **kw) -> str:
    return rinex_obs_bytes(obs if obs is not None else small_obs(), version, ObsWriteHeader(**kw)).decode()


def _read(text: str, name="t.rnx"):
    return read_rinex_obs(text.encode(), name=name)


def _codes(obs):
    return [w.code for w in obs.warnings]


def _lines(text):
    return text.split("\n")


def _body_start(lines):
    return next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1


# --- values, blanks, indicators -------------------------------------------------------------------

@pytest.mark.parametrize("version", [2.11, 3.04, 4.01])
def test_written_values_come_back_exactly(version):
    src = small_obs(sats=("G01", "G05", "G09"), codes=("C1C", "L1C", "D1C", "S1C", "C2W", "L2W"))
    obs = _read(_text(src, version))
    assert obs.sats == ["G01", "G05", "G09"]
    for k3 in src.codes:
        got = obs.get(k3, "G")
        want = src.values[:, :, src.codes.index(k3)]
        np.testing.assert_array_equal(got, want)
    assert obs.header.version == version


def test_blank_field_is_nan_and_zero_is_zero():
    obs = _read(_text())
    k = obs.codes.index("C1C")
    assert np.isnan(obs.values[1, 0, k])
    assert obs.ssi[1, 0, k] == -1
    kd = obs.codes.index("D1C")
    assert obs.values[2, 1, kd] == 0.0 and not np.signbit(obs.values[2, 1, kd])


def test_lli_and_ssi_digits_are_kept():
    src = small_obs()
    obs = _read(_text(src))
    k = obs.codes.index("L1C")
    np.testing.assert_array_equal(obs.lli[:, :, k], src.lli[:, :, src.codes.index("L1C")])
    np.testing.assert_array_equal(obs.ssi[:, :, k], src.ssi[:, :, src.codes.index("L1C")])
    assert set(np.unique(obs.lli[:, :, k])) <= {-1, 1} and (obs.lli[:, :, k] == 1).any()


def test_hand_written_record_exact_digits():
    text = _text(small_obs(n_epochs=1, sats=("G01",), codes=("C1C", "L1C", "D1C", "S1C")))
    lines = _lines(text)
    b = _body_start(lines)
    lines[b + 1] = ("G01" + f"{'20000000.123':>14}7 " + f"{'-123456789.001':>14}11" + f"{'-0.000':>14} 5"
                    + " " * 15)
    obs = _read("\n".join(lines))
    v = obs.values[0, 0]
    assert v[0] == float("20000000.123") and obs.lli[0, 0, 0] == 7 and obs.ssi[0, 0, 0] == -1
    assert v[1] == float("-123456789.001") and obs.lli[0, 0, 1] == 1 and obs.ssi[0, 0, 1] == 1
    assert v[2] == float("-0.000") and np.signbit(v[2]) and obs.ssi[0, 0, 2] == 5
    assert np.isnan(v[3])


# --- comments, events ------------------------------------------------------------------------------

def test_comment_lines_inside_data_do_not_shift_epochs_v3():
    src = small_obs()
    clean = _read(_text(src))
    lines = _lines(_text(src))
    b = _body_start(lines)
    comment = f"{'receiver restarted':<60}COMMENT"
    lines.insert(b + 3, comment)  # inside the records of epoch 0
    lines.insert(b + 1, comment)  # between the epoch line and its first record
    obs = _read("\n".join(lines))
    np.testing.assert_array_equal(obs.values, clean.values)


def test_comment_lines_inside_data_do_not_shift_epochs_v2():
    src = small_obs(sats=("G01", "G05", "G09"), codes=("C1C", "L1C", "C2W", "L2W", "D1C", "S1C", "S2W"))
    text = _text(src, 2.11)
    clean = _read(text)
    lines = _lines(text)
    b = _body_start(lines)
    comment = f"{'a comment':<60}COMMENT"
    lines.insert(b + 2, comment)  # between the two lines of a satellite record
    lines.insert(b, comment)
    obs = _read("\n".join(lines))
    np.testing.assert_array_equal(obs.values, clean.values)


def _with_events_v3(text):
    lines = _lines(text)
    b = _body_start(lines)
    ep = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    ins = {
        ep[1]: ["> 2024 06 24 08 20  0.5000000  2  0"],  # start moving
        ep[2]: [">" + " " * 30 + "4  2",  # header splice without date
                f"{'SPLICE':<60}COMMENT", f"{'ANT2':<60}MARKER NAME"],
        ep[3]: ["> 2024 06 24 08 20  2.2500000  5  0",  # external event
                "> 2024 06 24 08 20  2.5000000  4  1", f"{'with date':<60}COMMENT"],
        ep[4]: ["> 2024 06 24 08 20  3.0000000  6  1",  # cycle-slip record, observation layout
                "G01  20000000.000 1"],
    }
    out = []
    for i, ln in enumerate(lines):
        out.extend(ins.get(i, []))
        out.append(ln)
    return "\n".join(out), b


def test_event_flags_2_to_6_are_events_not_observations():
    src = small_obs()
    clean = _read(_text(src))
    text, b = _with_events_v3(_text(src))
    obs = _read(text)
    np.testing.assert_array_equal(obs.values, clean.values)
    assert len(obs.time) == 5
    assert [e.flag for e in obs.events] == [2, 4, 5, 4, 6]
    splice = obs.events[1]
    assert splice.time is None and splice.records[1].startswith("ANT2")
    assert obs.events[0].time.iso(7) == "2024-06-24T08:20:00.5000000"
    lines = text.split("\n")
    for e in obs.events:
        assert lines[e.line_no - 1][29:36].strip().startswith(str(e.flag))
    assert "header-changed-in-data" in _codes(obs)


def test_event_flag_3_new_site_is_reported():
    text = _text()
    lines = _lines(text)
    ep = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    lines[ep[2]:ep[2]] = ["> 2024 06 24 08 20  1.5000000  3  1", f"{'SITE2':<60}MARKER NAME"]
    obs = _read("\n".join(lines))
    assert [e.flag for e in obs.events] == [3]
    assert "new-site-occupation" in _codes(obs)


def test_event_flags_v2_with_and_without_date():
    text = _text(small_obs(sats=("G01", "G05")), 2.11)
    lines = _lines(text)
    b = _body_start(lines)
    lines[b:b] = ["                            4  1", f"{'SPLICE':<60}COMMENT"]
    ep2 = next(i for i, ln in enumerate(lines) if ln.startswith(" 24  6 24  8 20  2.0"))
    lines[ep2:ep2] = [" 24  6 24  8 20  1.5000000  5  0"]
    obs = _read("\n".join(lines))
    assert [e.flag for e in obs.events] == [4, 5]
    assert obs.events[0].time is None and obs.events[1].time.iso(1) == "2024-06-24T08:20:01.5"
    assert len(obs.time) == 5


def test_real_flag4_splices_without_date():
    path = real_set("geonet_0759_3040_3km_2005") / "07590920.05o"
    obs = read_rinex_obs(path)
    assert [e.flag for e in obs.events] == [4, 4, 4]
    assert all(e.time is None and "SPLICE" in e.records[0] for e in obs.events)
    assert [e.line_no for e in obs.events] == [855, 1058, 1090]
    assert len(obs.time) == 120


def test_obs_types_change_inside_data_is_refused():
    lines = _lines(_text())
    ep = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    lines[ep[1]:ep[1]] = ["> 2024 06 24 08 20  0.5000000  4  1", f"{'G    1 C1C':<60}SYS / # / OBS TYPES"]
    with pytest.raises(ParseError, match="observation types"):
        _read("\n".join(lines))


# --- observation types and long lines ----------------------------------------------------------------

def test_more_than_13_types_v3_continuation_and_long_lines():
    codes = ("C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W", "C2L", "L2L", "D2L", "S2L",
             "C5Q", "L5Q", "D5Q", "S5Q", "C1W")
    src = small_obs(sats=("G01", "G05"), codes=codes)
    text = _text(src)
    assert sum("SYS / # / OBS TYPES" in ln for ln in text.split("\n")) == 2
    assert max(len(ln) for ln in text.split("\n")) > 80
    obs = _read(text)
    assert obs.header.obs_types["G"] == list(codes)
    np.testing.assert_array_equal(obs.get("C1W"), src.values[:, :, -1])


def test_more_than_9_types_v2_continuation():
    codes = ("C1C", "L1C", "D1C", "S1C", "C2W", "L2W", "D2W", "S2W", "C5X", "L5X", "C1W")
    src = small_obs(sats=("G01", "G05", "G07"), codes=codes)
    text = _text(src, 2.11)
    lines = text.split("\n")
    assert sum("# / TYPES OF OBSERV" in ln for ln in lines) == 2
    assert all(len(ln) <= 80 for ln in lines)
    obs = _read(text)
    assert len(obs.codes) == 11 and obs.codes[0] == "C1"
    for c3 in codes:
        np.testing.assert_array_equal(obs.get(c3, "G"), src.values[:, :, codes.index(c3)])


def test_more_than_12_satellites_v2_epoch_continuation():
    sats = tuple(f"G{i:02d}" for i in range(1, 16))
    src = small_obs(sats=sats, codes=("C1C", "L1C"))
    text = _text(src, 2.11)
    obs = _read(text)
    assert obs.sats == list(sats)
    np.testing.assert_array_equal(obs.get("C1C"), src.values[:, :, 0])


def test_septentrio_x1_first_real_file():
    obs = read_rinex_obs(real_set("static_1m_mosaicx5_nagoya_2024") / "base.obs")
    assert obs.codes[0] == "X1"
    assert all(v[0] == "X1" for v in obs.header.obs_types.values())
    assert len(obs.header.obs_types["G"]) == 17  # a 13+4 continuation
    # X1 (receiver channel) is a small integer; C1C a pseudorange
    x1 = obs.values[:, :, 0]
    assert np.nanmax(x1) < 100 and np.nanmin(obs.get("C1C", "G")) > 1.9e7


def test_x1_first_written_file():
    src = small_obs(sats=("E11", "G01"), codes=("X1", "C1C", "L1C"))
    src.values[:, :, 0] = np.arange(2)[None, :] + 3.0
    obs = _read(_text(src))
    assert obs.codes == ["X1", "C1C", "L1C"]
    np.testing.assert_array_equal(obs.values[:, :, 0], src.values[:, :, 0])


# --- time tags --------------------------------------------------------------------------------------

@pytest.mark.parametrize("sec_text, iso", [("59.9990000", "2024-06-24T08:20:59.9990000"),
                                            ("15.1880000", "2024-06-24T08:20:15.1880000"),
                                            ("59.9999999", "2024-06-24T08:20:59.9999999")])
@pytest.mark.parametrize("version", [3.04, 2.11])
def test_epoch_seconds_are_never_rounded(sec_text, iso, version):
    lines = _lines(_text(small_obs(n_epochs=1, sats=V2_SATS), version))
    b = _body_start(lines)
    if version >= 3:
        lines[b] = lines[b][:18] + f"{sec_text:>11}" + lines[b][29:]
    else:
        lines[b] = lines[b][:15] + f"{sec_text:>11}" + lines[b][26:]
    obs = _read("\n".join(lines))
    assert obs.time[0].iso(7) == iso
    whole, frac = sec_text.split(".")
    assert obs.time.frac[0] == int(frac) / 1e7
    assert (obs.time.s[0] - obs.time.s[0] // 60 * 60) == int(whole)


def test_real_time_tags_in_receiver_clock_are_kept():
    obs = read_rinex_obs(real_set("geonet_0759_3040_3km_2005") / "07590920.05o")
    iso = obs.time.iso(7)
    assert "2005-04-02T00:21:30.0020000" in iso and "2005-04-02T00:59:30.0050000" in iso


def test_clock_offset_from_epoch_line():
    src = small_obs(n_epochs=3, sats=V2_SATS)
    src.clock_offset_s = np.array([np.nan, 0.000123456789, -0.5])
    for version, resolution_s in ((3.04, 1e-12), (2.11, 1e-9)):  # F15.12 / F12.9
        obs = _read(_text(src, version))
        assert np.isnan(obs.clock_offset_s[0])
        assert obs.clock_offset_s[1] == pytest.approx(0.000123456789, abs=resolution_s / 2)
        assert obs.clock_offset_s[2] == -0.5


# --- header quirks -> warnings -----------------------------------------------------------------------

def test_header_quirks_are_warnings():
    text = _text()
    text = replace_header_line(text, "MARKER NAME", None)
    text = replace_header_line(text, "INTERVAL", None)
    text = replace_header_line(text, "TIME OF LAST OBS", "  2024     6    24     9     0    0.0000000     GPS")
    text = replace_header_line(text, "GLONASS COD/PHS/BIS", "")
    text = replace_header_line(text, "ANT # / TYPE", f"{'':<20}{'Unknown':<20}")
    obs = _read(text)
    codes = _codes(obs)
    for c in ("missing-marker-name", "missing-interval", "time-of-last-obs-mismatch", "empty-glonass-cod-phs-bis",
              "unknown-antenna"):
        assert c in codes, c
    assert obs.header.marker_name is None and obs.header.interval_s is None
    assert obs.header.time_last.iso(0) == "2024-06-24T09:00:00"
    assert all(w.message for w in obs.warnings)
    s = summarize_rinex_obs(text.encode(), name="t.rnx")
    assert {w["code"] for w in s["warnings"]} >= set(codes)


def test_clean_file_has_no_warnings_and_header_fields():
    obs = _read(_text())
    assert _codes(obs) == []
    h = obs.header
    assert h.marker_name == "ANT1" and h.receiver_type == "TEST RX" and h.antenna_type == "TEST ANT"
    assert h.interval_s == 1.0 and h.time_first.iso(1) == "2024-06-24T08:20:00.0"
    np.testing.assert_allclose(h.approx_position_ecef_m, [-3976219.5082, 3382372.5671, 3652512.9849])
    assert h.glonass_slots == {"R07": 5}
    assert set(h.obs_types) == {"G", "R", "E"}


def test_real_header_quirks():
    obs = read_rinex_obs(real_set("qzss_l1s_geonet3034_sept_2021") / "3034265G.21O")
    assert {"missing-marker-name", "missing-interval", "empty-glonass-cod-phs-bis",
            "time-of-last-obs-mismatch"} <= set(_codes(obs))
    obs = read_rinex_obs(real_set("leo_grace_a_2007080") / "graa0800.07o.gz")
    assert obs.header.approx_position_ecef_m is None and "approx-position-zero" in _codes(obs)


# --- errors ------------------------------------------------------------------------------------------

def _drop_last_epoch(lines: list[str], is_epoch) -> str:
    last = max(i for i, ln in enumerate(lines) if is_epoch(ln))
    return "\n".join(lines[:last]) + "\n", last


@pytest.mark.parametrize("version", [3.04, 2.11])
def test_truncated_last_epoch_is_a_quirk(version):
    """A file cut inside its last epoch (georust's rovn0010.21o): the epochs before it are read exactly as in the
    file without that epoch, and a warning names the epoch line (docs/reader_policy.md)."""
    text = _text(small_obs(sats=V2_SATS), version) if version < 3 else _text()
    lines = text.rstrip("\n").split("\n")
    is_epoch = (lambda ln: ln.startswith(">")) if version >= 3 else (lambda ln: ln[:1] == " " and ln[3:4] == " "
                                                                     and ln[26:29].strip() in ("0", "1")
                                                                     and ln[29:32].strip().isdigit())
    without, last = _drop_last_epoch(lines, is_epoch)
    cut = _read("\n".join(lines[:-1]) + "\n")
    ref = _read(without)
    assert "truncated-last-epoch" in _codes(cut)
    (w,) = [w for w in cut.warnings if w.code == "truncated-last-epoch"]
    assert w.line_no == last + 1
    np.testing.assert_array_equal(cut.values, ref.values)
    assert cut.sats == ref.sats and len(cut.time) == len(ref.time) > 0


def test_wrong_record_count_before_the_last_epoch_is_still_an_error():
    text = _text()
    lines = text.rstrip("\n").split("\n")
    first = next(i for i, ln in enumerate(lines) if ln.startswith(">"))
    lines[first] = lines[first][:32] + f"{int(lines[first][32:35]) + 1:3d}" + lines[first][35:]
    with pytest.raises(ParseError, match="satellite records after this epoch line") as err:
        _read("\n".join(lines) + "\n")
    assert err.value.line_no == first + 1


@pytest.mark.parametrize("n_cut", [5, 7, 21, 26])
def test_cut_in_the_middle_of_a_field_is_an_error(n_cut):
    text = _text()
    with pytest.raises(ParseError, match="F14.3"):
        _read(text[: len(text) - n_cut])


def test_cut_at_a_field_boundary_is_flagged():
    # a record cut exactly between fields reads as blank fields: undetectable from the record, so the
    # missing final newline is reported
    text = _text()
    obs = _read(text[: len(text) - 17])
    assert "no-final-newline" in _codes(obs)
    assert "no-final-newline" not in _codes(_read(text))


@pytest.mark.parametrize("content, match", [
    (b"", "empty"),
    (b"   \n\n", "empty"),
    (bytes(range(256)) * 40, "RINEX VERSION"),
    (b"\x89PNG\r\n\x1a\n" + b"\x00" * 500, "RINEX VERSION"),
], ids=["empty", "blank", "binary", "png"])
def test_garbage_is_parse_error(content, match):
    with pytest.raises(ParseError, match=match):
        read_rinex_obs(content, name="x.rnx")


def test_missing_mandatory_header_lines():
    text = _text()
    with pytest.raises(ParseError, match="RINEX VERSION / TYPE"):
        _read(replace_header_line(text, "RINEX VERSION / TYPE", None))
    with pytest.raises(ParseError, match="END OF HEADER"):
        _read(replace_header_line(text, "END OF HEADER", None))
    no_types = "\n".join(ln for ln in text.split("\n") if "SYS / # / OBS TYPES" not in ln)
    with pytest.raises(ParseError, match="OBS TYPES"):
        _read(no_types)
    no_types2 = "\n".join(ln for ln in _text(small_obs(sats=V2_SATS), 2.11).split("\n") if "TYPES OF OBSERV" not in ln)
    with pytest.raises(ParseError, match="TYPES OF OBSERV"):
        _read(no_types2)


@pytest.mark.parametrize("version_text", ["     3.99", "     2.12", "     1.00", "     5.00", "    three"])
def test_unknown_versions_are_refused_loudly(version_text):
    lines = _lines(_text())
    lines[0] = version_text + lines[0][9:]
    with pytest.raises(ParseError, match="version") as err:
        _read("\n".join(lines))
    assert err.value.line_no == 1


def test_navigation_file_is_refused():
    lines = _lines(_text())
    lines[0] = lines[0][:20] + "N" + lines[0][21:]
    with pytest.raises(ParseError, match="'O'"):
        _read("\n".join(lines))


@pytest.mark.parametrize("field, col", [("  2000000x.123 ", 4), ("  20000 00.123 ", 4), ("  200000001.23 ", 4),
                                        ("  2-000000.123 ", 4), ("  --200000.123 ", 4)])
def test_malformed_field_names_line_and_column(field, col):
    lines = _lines(_text(small_obs(n_epochs=2)))
    b = _body_start(lines)
    lines[b + 2] = lines[b + 2][:3] + field[:14] + lines[b + 2][17:]
    with pytest.raises(ParseError, match="F14.3") as err:
        _read("\n".join(lines))
    assert err.value.line_no == b + 3 and err.value.column == col
    assert "expected" in str(err.value) and lines[b + 2][:20] in err.value.found


def test_bad_lli_character():
    lines = _lines(_text(small_obs(n_epochs=2)))
    b = _body_start(lines)
    lines[b + 1] = lines[b + 1][:17] + "x" + lines[b + 1][18:]
    with pytest.raises(ParseError, match="loss-of-lock") as err:
        _read("\n".join(lines))
    assert err.value.column == 18


def test_bad_satellite_id_and_bad_epoch_line():
    lines = _lines(_text(small_obs(n_epochs=2)))
    b = _body_start(lines)
    bad = list(lines)
    bad[b + 1] = "X01" + bad[b + 1][3:]
    with pytest.raises(ParseError, match="satellite id"):
        _read("\n".join(bad))
    bad = list(lines)
    bad[b] = bad[b][:7] + "13" + bad[b][9:]
    with pytest.raises(ParseError, match="epoch line"):
        _read("\n".join(bad))


def test_records_before_first_epoch_line():
    lines = _lines(_text(small_obs(n_epochs=2)))
    b = _body_start(lines)
    lines.insert(b, lines[b + 1])
    with pytest.raises(ParseError, match="before"):
        _read("\n".join(lines))


# --- compression, API --------------------------------------------------------------------------------

def test_gzip_and_hatanaka_inputs(tmp_path):
    raw = _text().encode()
    ref = read_rinex_obs(raw)
    p = tmp_path / "a.crx.gz"
    p.write_bytes(gzip.compress(hatanaka.rnx2crx(raw)))
    obs = read_rinex_obs(p)
    np.testing.assert_array_equal(obs.values, ref.values)
    assert obs.name == "a.crx.gz"


def test_rinex3_code_table():
    cases = {("G", "C1"): "C1C", ("G", "P1"): "C1W", ("G", "P2"): "C2W", ("G", "L1"): "L1C",
             ("G", "L2"): "L2W", ("G", "D1"): "D1C", ("G", "S1"): "S1C", ("G", "S2"): "S2W", ("G", "D2"): "D2W",
             ("G", "C2"): "C2X", ("G", "L5"): "L5X", ("R", "P1"): "C1P", ("R", "P2"): "C2P", ("R", "L2"): "L2P",
             ("R", "C1"): "C1C", ("R", "C2"): "C2C", ("E", "C1"): "C1X", ("E", "L5"): "L5X", ("E", "L7"): "L7X",
             ("J", "L2"): "L2X", ("S", "C1"): "C1C", ("C", "L7"): "L7X", ("G", "C1C"): "C1C"}
    for (s, c), want in cases.items():
        assert rinex3_code(s, c, 2.11) == want, (s, c)
    for s, c in (("E", "P1"), ("G", "L7"), ("G", "X1"), ("S", "L2")):
        with pytest.raises(ValueError):
            rinex3_code(s, c, 2.11)


def test_get_on_rinex2_file_maps_codes():
    obs = read_rinex_obs(real_set("upc1_upc2_38m_barcelona_2010") / "UPC10770.11o.gz")
    assert obs.codes == ["C1", "L1", "L2", "P2", "P1"]
    np.testing.assert_array_equal(obs.get("C1W"), obs.values[:, :, 4])
    np.testing.assert_array_equal(obs.get("L2W"), obs.values[:, :, 2])
    with pytest.raises(KeyError):
        obs.get("L5Q")


def test_get_masks_other_systems():
    obs = _read(_text())
    g = obs.get("C1C", "G")
    r = obs.get("C1C", "R")
    gm, rm = obs.sat_mask("G"), obs.sat_mask("R")
    assert np.isnan(g[:, ~gm]).all() and np.isnan(r[:, ~rm]).all()
    assert not np.isnan(r[:, rm]).all()


def test_summary_fields():
    s = summarize_rinex_obs(_text().encode(), name="ANT1.rnx")
    assert s["format"] == "RINEX" and s["version"] == 3.04 and s["marker_name"] == "ANT1"
    assert s["time_first"] == "2024-06-24T08:20:00.000" and s["time_last"] == "2024-06-24T08:20:04.000"
    assert s["interval_s"] == 1.0 and s["header_interval_s"] == 1.0 and s["n_epochs"] == 5
    assert s["systems"] == ["E", "G", "R"] and s["satellites"] == ["E11", "G01", "G05", "R07"]
    assert s["signals"]["G"] == ["C1C", "L1C", "D1C", "S1C"] and s["warnings"] == []
    assert s["receiver_type"] == "TEST RX" and s["antenna_type"] == "TEST ANT"
    import json

    json.dumps(s)


def test_summary_of_real_rinex2():
    s = summarize_rinex_obs(real_set("upc1_upc2_38m_barcelona_2010") / "UPC10770.11o.gz")
    assert s["version"] == 2.11 and s["marker_name"] == "UPC1" and s["interval_s"] == 1.0
    assert s["n_epochs"] == 3600 and s["signals"]["G"] == ["C1", "L1", "L2", "P2", "P1"]
    assert s["signals_rinex3"]["G"] == ["C1C", "L1C", "L2W", "C2W", "C1W"]
    assert "time-of-first-obs-mismatch" in {w["code"] for w in s["warnings"]}


def test_writer_is_deterministic(tmp_path):
    from gnssatt.gnss.io.rinex_obs_write import write_rinex_obs

    src = small_obs(n_epochs=20)
    a = write_rinex_obs(tmp_path / "a.rnx", src)
    b = write_rinex_obs(tmp_path / "b.rnx", src)
    assert a == b == (tmp_path / "a.rnx").read_bytes()


def test_slot_rows_of_buffer_is_the_per_line_matrix():
    """The records' slot matrix gathered from the file buffer (the reader's path) equals the per-line ljust one:
    short lines padded with blanks (not the newline or the next line), long lines cut, CRLF kept as text, a last
    line without newline and shorter than the width."""
    from gnssatt.gnss.io.rinex_obs import _slot_rows, _slot_rows_of_buffer, _split_lines

    data = (b"HEADER\nG01  1.000\nG02" + b"9" * 60 + b"\n\nR03 12.5\r\nE04 last")
    lines, starts, lens, buf = _split_lines((data, len(b"HEADER\n"), 1))
    idx = np.array([0, 1, 2, 3, 4, 1])
    for width in (3, 10, 35):
        want = _slot_rows(lines, idx, 13, width)
        got = _slot_rows_of_buffer(buf, starts, lens, idx, 13, width)
        assert got.shape == want.shape and np.array_equal(got, want), width
    assert _slot_rows_of_buffer(buf, starts, lens, np.array([], np.int64), 13, 10).shape == (0, 23)
