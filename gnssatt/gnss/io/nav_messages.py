"""Navigation records that are not Keplerian or GLONASS ephemerides: SBAS state vectors and the RINEX 4 messages
(CNAV/CNV1-3/L1NV/... ephemerides, STO, EOP, ION), read into typed records by gnssatt.gnss.io.rinex_nav.

Implements:
- SBAS: RINEX 3.05 Table A16 / RINEX 4.01 Table A24 (epoch line: aGf0 s, aGf1 s/s, transmission time in GPS
  seconds of week; three orbit lines: X/Y/Z km, velocity km/s, acceleration km/s^2, then health, URA, IODN).
  The SBAS epoch is GPS time (RINEX 3.05 sec. 8.1.4); positions are WGS-84 ECEF.
- RINEX 4.01 sec. 5.3-5.6 (Tables A31-A35): STO (epoch, time-offset label, SBAS id, UTC id; t_tm, A0, A1, A2),
  EOP (xp, dxp/dt, d2xp/dt2; yp ...; t_tm, dUT1, ...), ION (Klobuchar LNAV/D1D2, NeQuick-G IFNV, BDGIM CNVX).
  These and the ephemeris types the project does not evaluate (CNAV, CNV1-3, L1NV, L1OC, L3OC, ...) are kept as
  `NavMessage`: every number of every line in file order (blank = NaN), with RINEX 4.01 names for STO/EOP/ION.

Neglects: evaluating CNAV-type ephemerides (kept, not used by the ephemeris layer).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["SbasEphemeris", "NavMessage", "MESSAGE_FIELDS", "build_sbas", "sbas_records_in_metres"]

#: RINEX 4.01 field names of the STO/EOP/ION messages, in file order (after the epoch), per (kind, type);
#: '' marks a blank (spare) field. Tables A32 (STO), A33 (EOP), A34-A35 (ION).
MESSAGE_FIELDS: dict[tuple[str, str], tuple[str, ...]] = {
    ("STO", ""): ("t_tm_sow", "a0_s", "a1_s_s", "a2_s_s2"),
    ("EOP", ""): ("xp_arcsec", "dxp_arcsec_day", "d2xp_arcsec_day2", "", "yp_arcsec", "dyp_arcsec_day",
                  "d2yp_arcsec_day2", "t_tm_sow", "dut1_s", "ddut1_s_day", "d2dut1_s_day2"),
    ("ION", "LNAV"): ("alpha0_s", "alpha1_s_sc", "alpha2_s_sc2", "alpha3_s_sc3", "beta0_s", "beta1_s_sc",
                      "beta2_s_sc2", "beta3_s_sc3", "region_code"),
    ("ION", "D1D2"): ("alpha0_s", "alpha1_s_sc", "alpha2_s_sc2", "alpha3_s_sc3", "beta0_s", "beta1_s_sc",
                      "beta2_s_sc2", "beta3_s_sc3", "region_code"),
    ("ION", "IFNV"): ("ai0_sfu", "ai1_sfu_deg", "ai2_sfu_deg2", "disturbance_flags"),
    ("ION", "CNVX"): ("alpha1_tecu", "alpha2_tecu", "alpha3_tecu", "alpha4_tecu", "alpha5_tecu", "alpha6_tecu",
                      "alpha7_tecu", "alpha8_tecu", "alpha9_tecu"),
}



def int_column(v: np.ndarray, col: int, fill: int = -1) -> np.ndarray:
    """Column ``col`` of the record values ``v`` (n, m) as int64; ``fill`` where blank (NaN) or beyond 2**53
    (RINEX 3.05 sec. 6.12: integer quantities written as floating-point numbers)."""
    x = v[:, col]
    bad = ~np.isfinite(x) | (np.abs(x) > 2**53)
    return np.where(bad, fill, np.round(np.where(bad, 0, x))).astype(np.int64)

@dataclass
class NavMessage:
    """One RINEX 4 record kept as read: `kind` ('EPH', 'STO', 'EOP', 'ION'), `sat` ('G26'), `msg_type` ('CNAV',
    'LNAV', ...), `epoch` (the epoch as written, in the transmitting system's time scale; `GpsTime` holds the
    calendar value), `label` (STO: time-offset code 'GPUT', SBAS id and UTC id as written; '' otherwise),
    `values` (every number after the epoch, file order, NaN where blank), `line_no` (the '>' line, 1-based)."""

    kind: str
    sat: str
    msg_type: str
    epoch: GpsTime
    values: np.ndarray
    line_no: int
    label: str = ""

    def named(self) -> dict[str, float]:
        """Values by their RINEX 4.01 names (STO/EOP/ION); {} for types without a name table (ephemerides)."""
        names = MESSAGE_FIELDS.get((self.kind, self.msg_type)) or MESSAGE_FIELDS.get((self.kind, ""))
        if self.kind == "ION" and (self.kind, self.msg_type) not in MESSAGE_FIELDS:
            names = None
        if not names:
            return {}
        return {n: float(v) for n, v in zip(names, self.values) if n}


@dataclass
class SbasEphemeris:
    """SBAS broadcast state vectors (WGS-84 ECEF), one element per record, file order.

    - `toc`: epoch (GPS time). `af0_s`, `af1_s_s`: clock offset aGf0 and drift aGf1; dt_sv(t) = af0 + af1 (t - toc).
    - `transmission_sow`: transmission time of message, GPS seconds of week.
    - `position_m`, `velocity_m_s`, `acceleration_m_s2`: (n, 3), from km, km/s, km/s^2 in the file.
    - `health` (0 = OK), `ura_m` (accuracy code as written), `iodn`. `line_no`: the epoch line, 1-based.
    """

    sat: np.ndarray
    toc: GpsTime
    af0_s: np.ndarray
    af1_s_s: np.ndarray
    transmission_sow: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    health: np.ndarray
    ura_m: np.ndarray
    iodn: np.ndarray
    line_no: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __len__(self) -> int:
        return len(self.sat)

    def position_at(self, index: int, t: GpsTime) -> np.ndarray:
        """ECEF position (m) of record `index` at `t` by the second-order expansion the SBAS MOPS (RTCA DO-229
        sec. A.4.4.11) defines for GEO navigation messages: r + v dt + a dt^2 / 2."""
        dt = float(t - self.toc[index])
        return self.position_m[index] + self.velocity_m_s[index] * dt + 0.5 * self.acceleration_m_s2[index] * dt**2


# A position word beyond this many "km" from the geocentre can only be metres: the GEO radius is 42,164 km, and the
# RINEX 2.10 document's own GEO example (Table A18) writes metres where its Table A17 says km.
SBAS_MAX_RADIUS_KM = 1.0e6


def sbas_records_in_metres(rows) -> np.ndarray:
    """(n,) bool: records whose position words are metres, not the km RINEX Table A16/A17 prescribes."""
    out = np.zeros(len(rows), dtype=bool)
    for r, (_sat, _parts, vals, _ln) in enumerate(rows):
        if len(vals) >= 12:
            out[r] = np.linalg.norm([vals[3], vals[7], vals[11]]) > SBAS_MAX_RADIUS_KM
    return out


def build_sbas(rows) -> SbasEphemeris:
    """SbasEphemeris from (sat, calendar parts, 15 values, line) rows (rinex_nav's record rows).

    Position, velocity and acceleration words are km, km/s, km/s^2 (RINEX 2.11 Table A16, 3.05 Table A16); a record
    whose position is unambiguously metres (`sbas_records_in_metres`) is taken as written in metres."""
    n = len(rows)
    v = np.full((n, 15), np.nan)
    cal = np.zeros((n, 6))
    for r, (_sat, parts, vals, _ln) in enumerate(rows):
        m = min(len(vals), 15)
        v[r, :m] = vals[:m]
        cal[r] = parts
    toc = GpsTime.from_calendar(cal[:, 0].astype(np.int64), cal[:, 1].astype(np.int64), cal[:, 2].astype(np.int64),
                                cal[:, 3].astype(np.int64), cal[:, 4].astype(np.int64), cal[:, 5])

    ints = partial(int_column, v)

    km = np.where(sbas_records_in_metres(rows), 1.0, 1000.0)[:, None]
    return SbasEphemeris(
        sat=np.array([r[0] for r in rows], dtype=np.str_), toc=toc, af0_s=v[:, 0].copy(), af1_s_s=v[:, 1].copy(),
        transmission_sow=v[:, 2].copy(), position_m=v[:, [3, 7, 11]] * km, velocity_m_s=v[:, [4, 8, 12]] * km,
        acceleration_m_s2=v[:, [5, 9, 13]] * km, health=ints(6), ura_m=v[:, 10].copy(), iodn=ints(14),
        line_no=np.array([r[3] for r in rows], dtype=np.int64))
