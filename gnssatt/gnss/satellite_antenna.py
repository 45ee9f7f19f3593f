"""GNSS satellite antenna phase-centre offsets (PCO) for orbits of the centre of mass (SP3), in ECEF.

An SP3 orbit (IGS, CODE, ...) is that of the satellite's centre of mass (CoM); the clocks of the same product are
estimated for signals that leave the antenna phase centre (APC) given by the ANTEX file the analysis centre used.
A user of such an orbit adds the PCO, rotated from the satellite body frame to ECEF by the nominal attitude:

    r_apc = r_com + R(ex, ey, ez) pco_xyz

Nominal (yaw-steering) body frame of a GPS satellite (IGS convention, as in RTKLIB `satantoff`, Kouba 2009):
    ez = -r / |r|                     (towards the Earth's centre)
    ey = (ez x e_sun) / |ez x e_sun|  (e_sun: unit vector from the satellite to the Sun; solar panel axis)
    ex = ey x ez                      (in the plane of Earth, satellite and Sun, on the Sun's side)

Offsets: either an ANTEX file (`SatelliteAntennaOffsets.from_antex`, any era and system, the ionosphere-free
combination of the two frequencies of the product) or the built-in table `IGS05_GPS_PCO` below: the igs05.atx
values of the GPS satellites operated while the IGS used igs05.atx (GPS weeks 1400-1631, 2006-11-05 to
2011-04-16), which are the values the IGS/CODE products of those weeks (frame IGS05) were computed with.

Source of the table: igs05.atx, "IGS05_1627" (compiled by R. Schmid, TUM; satellite-specific z-offsets, block
x/y offsets from the manufacturers; Schmid et al. 2007, J Geod 81(12):781-798, doi:10.1007/s00190-007-0148-y),
as distributed with RTKLIB 2.4.2 (`data/igs05.atx`). Its change log lists no z-offset change after week 1402 for
any satellite of the table except SVN 62 (week 1602); the values are transcribed here, not the file. In igs05.atx
L1 and L2 carry the same offset (the ionosphere-free value), so the table holds one vector per satellite.

Implements: IGS ANTEX 1.4 satellite conventions (Rothacher & Schmid 2010); nominal yaw-steering attitude
(Bar-Sever 1996, "A new model for GPS yaw attitude", J Geod 70:714-723; Kouba 2009, GPS Solut 13:1-12, eq. 1);
low-precision Sun from ERFA `epv00` (geocentric Sun = - heliocentric Earth, ICRS ~ GCRF), rotated to ECEF by
`gnssatt.gnss.frames.R_ecef_from_gcrf` with zero EOP.
Neglects: the nadir-dependent phase-centre variations (igs05: |PCV| <= 12 mm, none for the ionosphere-free code
beyond that), the yaw manoeuvres of eclipsing satellites (noon/midnight turns, shadow crossings: they rotate only
the x/y offset, 0.28 m for Block IIA, whose projection on a line of sight within 14.5 deg of nadir is < 7 cm),
light time and aberration in the Sun direction (arcseconds), polar motion in the Sun's ECEF direction.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.time import GpsTime

__all__ = ["IGS05_GPS_PCO", "IGS05_ERA", "SatelliteAntennaOffsets", "satellite_body_axes_ecef",
           "sun_position_ecef_m", "default_offsets_for_sp3"]

AU_M = 149597870700.0  # IAU 2012 resolution B2 (exact)

#: igs05.atx GPS satellite PCOs: (PRN, SVN, block, valid from (inclusive, GPS date), valid until (exclusive; None =
#: open), (x, y, z) mm in the satellite body frame). Every satellite whose validity overlaps IGS05_ERA.
IGS05_GPS_PCO: tuple[tuple[str, str, str, str, str | None, tuple[float, float, float]], ...] = (
    ("G01", "G032", "IIA", "1992-11-22", "2008-10-17", (279.0, 0.0, 2201.0)),
    ("G01", "G037", "IIA", "2008-10-23", "2009-01-07", (279.0, 0.0, 2220.0)),
    ("G01", "G049", "IIR-M", "2009-03-24", None, (0.0, 0.0, 700.0)),
    ("G02", "G061", "IIR-B", "2004-11-06", None, (0.0, 0.0, 614.0)),
    ("G03", "G033", "IIA", "1996-03-28", None, (279.0, 0.0, 2619.0)),
    ("G04", "G034", "IIA", "1993-10-26", None, (279.0, 0.0, 2279.0)),
    ("G05", "G035", "IIA", "1993-08-30", "2009-06-09", (279.0, 0.0, 2463.0)),
    ("G05", "G050", "IIR-M", "2009-08-17", None, (0.0, 0.0, 700.0)),
    ("G06", "G036", "IIA", "1994-03-10", None, (279.0, 0.0, 2676.0)),
    ("G07", "G037", "IIA", "1993-05-13", "2008-01-15", (279.0, 0.0, 2220.0)),
    ("G07", "G048", "IIR-M", "2008-03-15", None, (0.0, 0.0, 700.0)),
    ("G08", "G038", "IIA", "1997-11-06", None, (279.0, 0.0, 2405.0)),
    ("G09", "G039", "IIA", "1993-06-26", None, (279.0, 0.0, 2340.0)),
    ("G10", "G040", "IIA", "1996-07-16", None, (279.0, 0.0, 2389.0)),
    ("G11", "G046", "IIR-A", "1999-10-07", None, (0.0, 0.0, 971.0)),
    ("G12", "G058", "IIR-M", "2006-11-17", None, (0.0, 0.0, 700.0)),
    ("G13", "G043", "IIR-A", "1997-07-23", None, (0.0, 0.0, 1203.0)),
    ("G14", "G041", "IIR-A", "2000-11-10", None, (0.0, 0.0, 1178.0)),
    ("G15", "G015", "II", "1990-10-01", "2007-03-15", (279.0, 0.0, 2312.0)),
    ("G15", "G055", "IIR-M", "2007-10-17", None, (0.0, 0.0, 700.0)),
    ("G16", "G056", "IIR-A", "2003-01-29", None, (0.0, 0.0, 1307.0)),
    ("G17", "G053", "IIR-M", "2005-09-26", None, (0.0, 0.0, 645.0)),
    ("G18", "G054", "IIR-A", "2001-01-30", None, (0.0, 0.0, 1133.0)),
    ("G19", "G059", "IIR-B", "2004-03-20", None, (0.0, 0.0, 668.0)),
    ("G20", "G051", "IIR-A", "2000-05-11", None, (0.0, 0.0, 1154.0)),
    ("G21", "G045", "IIR-A", "2003-03-31", None, (0.0, 0.0, 1300.0)),
    ("G22", "G047", "IIR-B", "2003-12-21", None, (0.0, 0.0, 792.0)),
    ("G23", "G060", "IIR-B", "2004-06-23", None, (0.0, 0.0, 602.0)),
    ("G24", "G024", "IIA", "1991-07-04", None, (279.0, 0.0, 2455.0)),
    ("G25", "G025", "IIA", "1992-02-23", "2010-02-09", (279.0, 0.0, 2295.0)),
    ("G25", "G035", "IIA", "2010-02-09", "2010-05-28", (279.0, 0.0, 2463.0)),
    ("G25", "G062", "IIF", "2010-05-28", None, (394.0, 0.0, 1407.0)),
    ("G26", "G026", "IIA", "1992-07-07", None, (279.0, 0.0, 2307.0)),
    ("G27", "G027", "IIA", "1992-09-09", None, (279.0, 0.0, 2472.0)),
    ("G28", "G044", "IIR-A", "2000-07-16", None, (0.0, 0.0, 911.0)),
    ("G29", "G029", "IIA", "1992-12-18", "2007-10-24", (279.0, 0.0, 2352.0)),
    ("G29", "G057", "IIR-M", "2007-12-20", None, (0.0, 0.0, 700.0)),
    ("G30", "G030", "IIA", "1996-09-12", None, (279.0, 0.0, 2466.0)),
    ("G31", "G052", "IIR-M", "2006-09-25", None, (0.0, 0.0, 750.0)),
    ("G32", "G023", "IIA", "2006-12-02", None, (279.0, 0.0, 2575.0)),
)
#: GPS dates [from, until) during which IGS products used igs05.atx (the IGS switched to it at GPS week 1400 and to
#: igs08.atx at week 1632): the table's values are the right ones for SP3/clock products of these weeks only.
IGS05_ERA = ("2006-11-05", "2011-04-17")
#: SP3 coordinate-system labels of products computed with igs05.atx.
IGS05_FRAMES = ("IGS05", "IGb05")


def _date(text: str) -> GpsTime:
    y, m, d = (int(x) for x in text.split("-"))
    return GpsTime.from_calendar(y, m, d)


def sun_position_ecef_m(t: GpsTime) -> np.ndarray:
    """(n, 3) geocentric position of the Sun in ECEF (m) at GPS times t (n,) or scalar, to ~1e-5 rad.

    Implements: ERFA epv00 (heliocentric Earth, BCRS ~ GCRF, TDB ~ TT) negated, then ECEF <- GCRF by IAU
    2006/2000A with zero EOP (gnssatt.gnss.frames). Neglects: light time (8 min: 20") and aberration (20"),
    polar motion (< 1e-6 rad) and UT1 - UTC (|UT1 - UTC| < 0.9 s: < 7e-5 rad of Earth rotation).
    """
    import erfa

    from gnssatt.gnss.frames import R_ecef_from_gcrf

    tt = GpsTime(np.atleast_1d(t.s), np.atleast_1d(t.frac))
    tt1, tt2 = tt.to_jd_tt()
    pvh, _ = erfa.epv00(tt1, tt2)
    sun_gcrf_m = -np.asarray(pvh["p"]) * AU_M  # structured (p, v) array of pyerfa, AU
    R = R_ecef_from_gcrf(tt)
    return np.einsum("nij,nj->ni", R, sun_gcrf_m)


def satellite_body_axes_ecef(r_sat_ecef_m, r_sun_ecef_m) -> np.ndarray:
    """(n, 3, 3) rows ex, ey, ez of the nominal yaw-steering body frame in ECEF, for satellites (n, 3) and Sun (n, 3).

    Implements: IGS convention (Kouba 2009 eq. 1; RTKLIB satantoff): ez = -r/|r|, ey = ez x e_sun normalised,
    ex = ey x ez. NaN where the Sun is along ez (the yaw is undefined; the caller keeps the z offset only).
    """
    r = np.asarray(r_sat_ecef_m, dtype=np.float64)
    ez = -r / np.linalg.norm(r, axis=-1, keepdims=True)
    es = np.asarray(r_sun_ecef_m, dtype=np.float64) - r
    es = es / np.linalg.norm(es, axis=-1, keepdims=True)
    ey = np.cross(ez, es)
    ny = np.linalg.norm(ey, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        ey = np.where(ny > 1e-12, ey / ny, np.nan)
    ex = np.cross(ey, ez)
    return np.stack([ex, ey, ez], axis=-2)


@dataclass(frozen=True)
class _Entry:
    sat: str
    svn: str
    block: str
    valid_from: GpsTime
    valid_until: GpsTime | None
    pco_xyz_m: np.ndarray


class SatelliteAntennaOffsets:
    """Satellite PCOs by satellite and time; `offset_ecef_m(sats, t, r_sat_ecef_m)` rotates them to ECEF.

    Build with `SatelliteAntennaOffsets.igs05()` (built-in table) or `.from_antex(patterns, frequencies)`.
    Satellites or times without an entry get a zero offset and `covered` False (the caller decides: the orbit
    stays that of the centre of mass there).
    """

    def __init__(self, entries: list[_Entry], source: str):
        self.entries = list(entries)
        self.source = source
        self._by_sat: dict[str, list[_Entry]] = {}
        for e in self.entries:
            self._by_sat.setdefault(e.sat, []).append(e)

    @classmethod
    def igs05(cls) -> "SatelliteAntennaOffsets":
        """The built-in igs05.atx GPS table (IGS05_GPS_PCO)."""
        entries = [_Entry(prn, svn, block, _date(vf), _date(vu) if vu else None, np.asarray(xyz) * 1e-3)
                   for prn, svn, block, vf, vu, xyz in IGS05_GPS_PCO]
        return cls(entries, "igs05.atx (built-in GPS table, gnssatt.gnss.satellite_antenna.IGS05_GPS_PCO)")

    @classmethod
    def from_antex(cls, patterns, frequencies: dict[str, tuple[str, str]] | None = None,
                   source: str = "ANTEX") -> "SatelliteAntennaOffsets":
        """Offsets of the satellite antennas in ANTEX `patterns` (gnssatt.gnss.io.antex.read_antex).

        frequencies: per system letter, the two ANTEX frequency codes whose ionosphere-free combination the
        product's clocks refer to; default GPS ('G01', 'G02'), Galileo ('E01', 'E05'), QZSS ('J01', 'J02'),
        BeiDou ('C02', 'C07'), GLONASS ('R01', 'R02'). PCO_IF = (f1^2 PCO_1 - f2^2 PCO_2) / (f1^2 - f2^2); a
        single listed frequency is used as it is.
        """
        from gnssatt.gnss.signals import antex_frequency_hz

        pairs = {"G": ("G01", "G02"), "E": ("E01", "E05"), "J": ("J01", "J02"), "C": ("C02", "C07"),
                 "R": ("R01", "R02")}
        if frequencies:
            pairs.update(frequencies)
        entries = []
        for p in patterns:
            sat = (p.serial or "").strip()
            if len(sat) != 3 or not sat[1:].isdigit() or sat[0] not in pairs:
                continue  # receiver antennas carry no PRN in the serial field
            f = {fp.code: np.asarray(fp.neu_mm, dtype=np.float64) * 1e-3 for fp in p.frequencies}
            a, b = pairs[sat[0]]
            if a in f and b in f:
                fa, fb = antex_frequency_hz(a), antex_frequency_hz(b)
                pco = (fa ** 2 * f[a] - fb ** 2 * f[b]) / (fa ** 2 - fb ** 2)
            elif a in f:
                pco = f[a]
            else:
                continue
            vf = p.valid_from if p.valid_from is not None else GpsTime(np.int64(-10 ** 12), 0.0)
            entries.append(_Entry(sat, (p.svn_code or "").strip(), p.antenna_type, vf, p.valid_until, pco))
        return cls(entries, source)

    def pco_body_m(self, sats, t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
        """((n, 3) body-frame PCO in m, (n,) covered) for satellites `sats` (n,) at times t ((n,) or scalar)."""
        sats = np.atleast_1d(np.asarray(sats)).astype(str)
        n = len(sats)
        ts = np.broadcast_to(np.atleast_1d(t.s), (n,))
        tf = np.broadcast_to(np.atleast_1d(t.frac), (n,))
        out = np.zeros((n, 3))
        covered = np.zeros(n, dtype=bool)
        for sat in np.unique(sats):
            m = np.flatnonzero(sats == sat)
            for e in self._by_sat.get(str(sat), ()):
                after = (ts[m] - e.valid_from.s) + (tf[m] - e.valid_from.frac) >= 0.0
                before = True if e.valid_until is None else ((ts[m] - e.valid_until.s)
                                                             + (tf[m] - e.valid_until.frac) < 0.0)
                hit = m[after & before & ~covered[m]]
                out[hit] = e.pco_xyz_m
                covered[hit] = True
        return out, covered

    def offset_ecef_m(self, sats, t: GpsTime, r_sat_ecef_m) -> tuple[np.ndarray, np.ndarray]:
        """((n, 3) APC - CoM in ECEF (m), (n,) covered) for satellites at CoM positions r_sat_ecef_m (n, 3).

        The Sun is evaluated on a 300 s grid over the span of t and interpolated linearly (the Sun turns 1.25 deg
        in ECEF in 300 s: chord error < 1e-4 rad, i.e. < 0.03 mm on a 0.28 m x offset).
        """
        r = np.asarray(r_sat_ecef_m, dtype=np.float64).reshape(-1, 3)
        pco, covered = self.pco_body_m(sats, t)
        out = np.zeros_like(r)
        if not covered.any():
            return out, covered
        n = len(r)
        tt = GpsTime(np.broadcast_to(np.atleast_1d(t.s), (n,)).copy(),
                     np.broadcast_to(np.atleast_1d(t.frac), (n,)).copy())
        r_sun = _sun_interpolated(tt)
        axes = satellite_body_axes_ecef(r, r_sun)  # (n, 3, 3) rows ex, ey, ez
        xy_ok = np.all(np.isfinite(axes[:, :2]), axis=(1, 2))
        axes[~xy_ok, :2] = 0.0  # Sun along ez: keep the z offset only
        off = np.einsum("ni,nij->nj", pco, axes)
        out[covered] = off[covered]
        out[~np.all(np.isfinite(r), axis=1)] = np.nan
        return out, covered


_SUN_STEP_S = 300.0


def _sun_interpolated(t: GpsTime) -> np.ndarray:
    """(n, 3) Sun in ECEF (m) at times t (n,), linear between nodes every _SUN_STEP_S."""
    t0 = GpsTime(np.min(t.s), 0.0)
    x = t - t0
    x = np.where(np.isfinite(x), x, 0.0)
    k0 = int(np.floor(np.min(x) / _SUN_STEP_S))
    k1 = int(np.floor(np.max(x) / _SUN_STEP_S)) + 1
    nodes_s = _SUN_STEP_S * np.arange(k0, k1 + 1, dtype=np.float64)
    sun = sun_position_ecef_m(t0 + nodes_s)
    i = np.clip(np.floor(x / _SUN_STEP_S).astype(np.int64) - k0, 0, len(nodes_s) - 2)
    w = ((x - nodes_s[i]) / _SUN_STEP_S)[:, None]
    return (1.0 - w) * sun[i] + w * sun[i + 1]


def default_offsets_for_sp3(sp3) -> SatelliteAntennaOffsets | None:
    """The built-in igs05 table when the SP3 declares an IGS05 frame (products of igs05.atx), else None."""
    frame = str(getattr(sp3, "coordinate_system", "") or "").strip()
    return SatelliteAntennaOffsets.igs05() if frame in IGS05_FRAMES else None
