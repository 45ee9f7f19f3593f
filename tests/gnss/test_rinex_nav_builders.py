"""Builders (no tests here) of small synthetic RINEX navigation texts for the reader tests (no real data copied).

Values are arbitrary but plausible; every field is written in the format's fixed columns so that tests can
mutate exactly one thing (an exponent letter, a missing space, an extra line, ...).
"""
from __future__ import annotations


def d19(x: float, exp_letter: str = "E") -> str:
    """Fortran D19.12 text of x (19 characters), e.g. ' 1.234567890123E-05'."""
    return f"{x:19.12E}".replace("E", exp_letter)


def header_line(content: str, label: str) -> str:
    return f"{content:<60s}{label:<20s}"


GPS_VALUES = [  # af0, af1, af2, then BROADCAST ORBIT 1..7 (4 each, line 7 has 2)
    -1.774230040610e-04, -1.364242052659e-12, 0.0,
    72.0, -98.21875, 4.293035965037e-09, 1.714815412488,
    -5.291774868965e-06, 5.927642923780e-03, 1.830980181694e-06, 5.153635631561e+03,
    122400.0, 3.352761268616e-08, 2.520897825810, -5.774199962616e-08,
    9.719266524177e-01, 353.625, 1.273307347665, -8.275344701323e-09,
    -2.610823036973e-10, 1.0, 2320.0, 0.0,
    2.0, 0.0, -1.071020960808e-08, 72.0,
    115218.0, 4.0,
]


def kepler_record_v3(sat: str, epoch: str, values=GPS_VALUES, exp_letter: str = "E", extra_lines: int = 0) -> str:
    """A RINEX 3 Keplerian record: 'G05 2024 06 24 10 00 00' + 3 values, then 7 BROADCAST ORBIT lines."""
    v = [d19(x, exp_letter) for x in values]
    lines = [f"{sat} {epoch}" + "".join(v[0:3])]
    rest = v[3:]
    for k in range(0, len(rest), 4):
        lines.append("    " + "".join(rest[k:k + 4]))
    for _ in range(extra_lines):
        lines.append("    " + d19(0.0, exp_letter) * 4)
    return "\n".join(lines) + "\n"


def kepler_record_v2(prn: int, epoch: str, values=GPS_VALUES, exp_letter: str = "D") -> str:
    """A RINEX 2 GPS record: ' 5 24  6 24 10  0  0.0' + 3 values, then 7 lines of 3X,4D19.12."""
    v = [d19(x, exp_letter) for x in values]
    lines = [f"{prn:2d} {epoch}" + "".join(v[0:3])]
    rest = v[3:]
    for k in range(0, len(rest), 4):
        lines.append("   " + "".join(rest[k:k + 4]))
    return "\n".join(lines) + "\n"


GLO_VALUES = [  # -tau_n, gamma_n, tk; X, Xdot, Xacc, health; Y, Ydot, Yacc, k; Z, Zdot, Zacc, E
    8.934084326029e-05, 9.094947017729e-13, 115200.0,
    -13736.88769531, -1.554378509521, 9.313225746155e-10, 0.0,
    -3309.23828125, -2.458472251892, 1.862645149231e-09, 1.0,
    21242.41259766, -1.386628150940, -1.862645149231e-09, 0.0,
]


def glonass_record_v3(sat: str, epoch: str, values=GLO_VALUES) -> str:
    v = [d19(x) for x in values]
    lines = [f"{sat} {epoch}" + "".join(v[0:3])]
    rest = v[3:]
    for k in range(0, len(rest), 4):
        lines.append("    " + "".join(rest[k:k + 4]))
    return "\n".join(lines) + "\n"


def nav_header_v3(system: str = "M", version: str = "3.04", leap: int | None = 18) -> str:
    lines = [header_line(f"{version:>9s}           N: GNSS NAV DATA    {system}: MIXED", "RINEX VERSION / TYPE"),
             header_line("gnssatt-test                            20240624 104231 UTC", "PGM / RUN BY / DATE"),
             header_line("GPSA   1.8626E-08  2.2352E-08 -1.1921E-07 -5.9605E-08", "IONOSPHERIC CORR"),
             header_line("GPSB   1.2902E+05  1.6384E+05 -1.9661E+05 -2.6214E+05", "IONOSPHERIC CORR")]
    if leap is not None:
        lines.append(header_line(f"{leap:6d}", "LEAP SECONDS"))
    lines.append(header_line("", "END OF HEADER"))
    return "\n".join(lines) + "\n"


def nav_header_v2(leap: int = 14) -> str:
    lines = [header_line("     2.10           N: GPS NAV DATA", "RINEX VERSION / TYPE"),
             header_line("gnssatt-test", "PGM / RUN BY / DATE"),
             header_line("    0.1118D-07  0.7451D-08 -0.5960D-07 -0.5960D-07", "ION ALPHA"),
             header_line("    0.9011D+05  0.1638D+05 -0.1966D+06 -0.6554D+05", "ION BETA"),
             header_line(f"{leap:6d}", "LEAP SECONDS"),
             header_line("", "END OF HEADER")]
    return "\n".join(lines) + "\n"


def nav_header_v4() -> str:
    lines = [header_line("     4.01           N: GNSS NAV DATA    M: MIXED", "RINEX VERSION / TYPE"),
             header_line("gnssatt-test                            20240624 104231 UTC", "PGM / RUN BY / DATE"),
             header_line("    18", "LEAP SECONDS"),
             header_line("", "END OF HEADER")]
    return "\n".join(lines) + "\n"
