"""The upload summary of a RINEX 3 observation file (gnssatt.gnss.io.sniff.scan_rinex_obs) reads an epoch's satellite
records as one block when they are plain and one by one otherwise: both give the same summary, a COMMENT line
among the records is skipped, not counted, a bad satellite id is refused with its own line number, and a file
with a comment in every epoch is read without any nesting of iterators (here 20000 such epochs)."""
from __future__ import annotations

import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.sniff import scan_rinex_obs

HEADER = """\
     3.04           OBSERVATION DATA    G: GPS              RINEX VERSION / TYPE
G    4 C1C L1C C2W L2W                                      SYS / # / OBS TYPES
     1.000                                                  INTERVAL
                                                            END OF HEADER
"""
COMMENT = " a comment among the records".ljust(60) + "COMMENT"


def _rec(prn: int) -> str:
    return f"G{prn:02d}  22268601.366 7 117022286.41617  22268601.366 7 117022286.41617"


def _epoch(second: int, prns: list[int], comment_at: int | None = None) -> list[str]:
    lines = [f"> 2018 06 06 12 {second // 60:2d} {second % 60:2d}.0000000  0{len(prns):3d}"] + [_rec(p) for p in prns]
    if comment_at is not None:
        lines.insert(1 + comment_at, COMMENT)
    return lines


def _scan(lines: list[str]) -> dict:
    return scan_rinex_obs(iter(HEADER.splitlines() + lines), "x.rnx")


def test_a_comment_among_the_records_is_skipped_and_the_summary_is_the_plain_one():
    plain = [ln for s in range(6) for ln in _epoch(s, [3, 7, 12])]
    commented = [ln for s in range(6) for ln in _epoch(s, [3, 7, 12], comment_at=1 if s % 2 else None)]
    a, b = _scan(plain), _scan(commented)
    assert a["n_epochs"] == b["n_epochs"] == 6 and a["satellites"] == b["satellites"] == ["G03", "G07", "G12"]
    assert a["time_first"] == b["time_first"] and a["time_last"] == b["time_last"] and a["warnings"] == b["warnings"]


@pytest.mark.parametrize("comment", [False, True])
def test_a_bad_satellite_id_is_refused_with_its_line(comment):
    lines = [ln for s in range(3) for ln in _epoch(s, [3, 7], comment_at=0 if comment else None)]
    bad_epoch = _epoch(3, [3, 7])
    bad_epoch[2] = "7G1" + bad_epoch[2][3:]
    lines += bad_epoch
    with pytest.raises(ParseError) as err:
        _scan(lines)
    header_lines = len(HEADER.splitlines())
    assert err.value.line_no == header_lines + len(lines) and "G01" in str(err.value)


def test_a_truncated_last_epoch_is_dropped_with_a_warning():
    lines = [ln for s in range(4) for ln in _epoch(s, [3, 7, 12])][:-1]
    out = _scan(lines)
    assert out["n_epochs"] == 3 and "truncated-last-epoch" in [w["code"] for w in out["warnings"]]


def test_a_comment_in_every_epoch_reads_without_nesting():
    lines = [ln for s in range(20000) for ln in _epoch(s % 3600, [3, 7], comment_at=1)]
    out = _scan(lines)
    assert out["n_epochs"] == 20000 and out["satellites"] == ["G03", "G07"]
