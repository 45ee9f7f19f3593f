"""Write GPS LNAV (and GLONASS) broadcast records as a RINEX 3.04 navigation file.

Implements: RINEX 3.04 (IGS/RTCM-SC104, 2015), sec. 5.4 and Tables A5 (header) / A6 (GPS navigation
message record): SV/EPOCH/SV CLK `A1,I2.2,1X,I4,5(1X,I2.2),3D19.12`, BROADCAST ORBIT 1-7 `4X,4D19.12`;
exponent letter 'E' (RINEX 3 allows D or E). Week number is continuous (not mod 1024), toe and the
transmission time are seconds of that week. GLONASS records: Table A10 (epoch t_b in UTC, -tau_n, +gamma_n,
message frame time in seconds of the UTC week; BROADCAST ORBIT 1-3: X, Y, Z (km), velocities (km/s), lunisolar
accelerations (km/s^2), health, frequency number, age of operational information).
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Sequence

from gnssatt.gnss.time import GpsTime


def _d19(x: float) -> str:
    """One D19.12 field: '-1.234567890123E-04' (19 characters)."""
    return f"{float(x):19.12E}"


def _hdr(text: str, label: str) -> str:
    return f"{text:<60.60}{label:<20.20}\n"


def _epoch_text(t: GpsTime) -> str:
    y, mo, d, hh, mi, ss = (int(v) for v in t.calendar())
    return f"{y:4d} {mo:02d} {d:02d} {hh:02d} {mi:02d} {ss:02d}"


def format_gps_record(rec) -> str:
    """The 8 lines of one GPS record; `rec` has the KeplerEphemeris / BroadcastRecord field names."""
    lines = [
        f"{rec.sat:3s} {_epoch_text(rec.toc)}" + "".join(_d19(v) for v in (rec.af0_s, rec.af1_s_s, rec.af2_s_s2)),
    ]
    rows = [
        (rec.iode, rec.crs_m, rec.delta_n_rad_s, rec.m0_rad),
        (rec.cuc_rad, rec.e, rec.cus_rad, rec.sqrt_a_sqrt_m),
        (rec.toe_sow, rec.cic_rad, rec.omega0_rad, rec.cis_rad),
        (rec.i0_rad, rec.crc_m, rec.omega_rad, rec.omega_dot_rad_s),
        (rec.idot_rad_s, getattr(rec, "codes_on_l2", 1), rec.week, getattr(rec, "l2p_flag", 0)),
        (rec.accuracy_m, rec.health, rec.tgd_s, rec.iodc),
    ]
    for row in rows:
        lines.append("    " + "".join(_d19(v) for v in row))
    lines.append("    " + _d19(rec.transmission_sow) + _d19(rec.fit_interval_h))
    return "\n".join(lines) + "\n"


def format_glonass_record(rec) -> str:
    """The 4 lines of one GLONASS record (RINEX 3.04 Table A10); `rec` has the sim GlonassRecord field names."""
    km = 1000.0
    r, v, a = rec.position_m / km, rec.velocity_m_s / km, rec.acceleration_m_s2 / km
    lines = [f"{rec.sat:3s} {_epoch_text(rec.epoch_utc)}"
             + "".join(_d19(x) for x in (-rec.tau_n_s, rec.gamma_n, rec.message_frame_time_s))]
    for i, extra in enumerate((rec.health, rec.frequency_number, rec.age_days)):
        lines.append("    " + "".join(_d19(x) for x in (r[i], v[i], a[i], extra)))
    return "\n".join(lines) + "\n"


def write_rinex_nav_gps(path: str | Path, records: Sequence, *, program: str = "gnssatt-sim",
                        run_by: str = "gnssatt", date_text: str = "20000101 000000 GPS",
                        iono_alpha: Iterable[float] | None = None, iono_beta: Iterable[float] | None = None,
                        leap_seconds: int | None = None, comments: Iterable[str] = (),
                        glonass_records: Sequence = ()) -> Path:
    """Write RINEX 3.04 GPS navigation file `path` holding `records` (and `glonass_records`: a mixed file, or a
    GLONASS one when `records` is empty); returns the path.

    Args:
        records: objects with the KeplerEphemeris field names (sat 'Gnn', toc GpsTime, af0_s, ...).
        date_text: the 'PGM / RUN BY / DATE' date field (pass a fixed text for byte-identical output).
        iono_alpha, iono_beta: Klobuchar coefficients (GPSA/GPSB IONOSPHERIC CORR) if given.
        leap_seconds: GPS-UTC for the LEAP SECONDS line if given.
    """
    path = Path(path)
    system = "G: GPS" if not glonass_records else ("M: MIXED" if records else "R: GLONASS")
    out = [_hdr(f"{'3.04':>9s}{'':11s}{'N: GNSS NAV DATA':<20s}{system:<20s}", "RINEX VERSION / TYPE"),
           _hdr(f"{program:<20.20}{run_by:<20.20}{date_text:<20.20}", "PGM / RUN BY / DATE")]
    for c in comments:
        out.append(_hdr(c, "COMMENT"))
    if iono_alpha is not None:
        out.append(_hdr("GPSA " + "".join(f"{v:12.4E}" for v in iono_alpha), "IONOSPHERIC CORR"))
    if iono_beta is not None:
        out.append(_hdr("GPSB " + "".join(f"{v:12.4E}" for v in iono_beta), "IONOSPHERIC CORR"))
    if leap_seconds is not None:
        out.append(_hdr(f"{leap_seconds:6d}", "LEAP SECONDS"))
    out.append(_hdr("", "END OF HEADER"))
    out.extend(format_gps_record(r) for r in records)
    out.extend(format_glonass_record(r) for r in glonass_records)
    path.write_text("".join(out), encoding="ascii")
    return path
