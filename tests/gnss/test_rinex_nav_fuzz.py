"""Fuzzing the navigation reader on small texts: byte flips, truncations, deleted / duplicated / swapped
lines and inserted garbage must end in a result or a ParseError - never another exception - in bounded time."""
from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.gnss.test_rinex_nav_builders import (GPS_VALUES, glonass_record_v3, kepler_record_v2, kepler_record_v3,
                                                 nav_header_v2, nav_header_v3, nav_header_v4)
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.rinex_nav import read_rinex_nav, select_ephemeris, summarize_rinex_nav
from gnssatt.gnss.time import GpsTime


@st.composite
def mutated(draw, base: bytes, max_mutations: int = 3) -> bytes:
    """`base` after 1..max_mutations random mutations."""
    data = bytearray(base)
    for _ in range(draw(st.integers(1, max_mutations))):
        kind = draw(st.sampled_from(["flip", "truncate", "delete_line", "dup_line", "swap_lines", "garbage"]))
        if not data:
            break
        if kind == "flip":
            i = draw(st.integers(0, len(data) - 1))
            data[i] = draw(st.integers(0, 255))
        elif kind == "truncate":
            del data[draw(st.integers(0, len(data) - 1)):]
        elif kind == "garbage":
            i = draw(st.integers(0, len(data)))
            data[i:i] = draw(st.binary(min_size=1, max_size=40))
        else:
            lines = bytes(data).split(b"\n")
            i = draw(st.integers(0, len(lines) - 1))
            if kind == "delete_line":
                del lines[i]
            elif kind == "dup_line":
                lines.insert(i, lines[i])
            else:
                j = draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            data = bytearray(b"\n".join(lines))
    return bytes(data)


_BDS = list(GPS_VALUES)
_BDS[21] = 964.0  # BDT week
NAV_V3 = (nav_header_v3() + kepler_record_v3("G05", "2024 06 24 10 00 00") +
          kepler_record_v3("E11", "2024 06 24 10 00 00") + glonass_record_v3("R01", "2024 06 24 08 15 00") +
          kepler_record_v3("C01", "2024 06 24 08 00 00", _BDS)).encode()
NAV_V2 = (nav_header_v2() + kepler_record_v2(5, "24  6 24 10  0  0.0") +
          kepler_record_v2(7, "24  6 24 12  0  0.0")).encode()
NAV_V4 = (nav_header_v4() + "> EPH G05 LNAV\n" + kepler_record_v3("G05", "2024 06 24 10 00 00") +
          "> STO G01 LNAV\n    2024 06 24 10 00 00 GPUT\n" + "> EPH R01 FDMA\n" +
          glonass_record_v3("R01", "2024 06 24 08 15 00")).encode()


def _check(data: bytes):
    try:
        nav = read_rinex_nav(data, name="fuzz.nav")
    except ParseError:
        return
    for k in nav.kepler.values():  # whatever was accepted is usable
        select_ephemeris(k, str(k.sat[0]), GpsTime.from_week_sow(2320, 122400.0))
    summarize_rinex_nav(data, name="fuzz.nav")


@settings(max_examples=150, deadline=1000, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mutated(NAV_V3), mutated(NAV_V2), mutated(NAV_V4)))
def test_fuzz_nav_only_parse_error(data):
    _check(data)


def test_unmutated_fuzz_bases_parse():
    for base in (NAV_V3, NAV_V2, NAV_V4):
        nav = read_rinex_nav(base, name="base")
        assert nav.kepler
