"""One interface for "where is satellite s, and what is its clock, at GPS time t": broadcast or precise.

`SatelliteEphemeris` is the protocol every consumer (positioning, alignment, the attitude filter) calls:

    state(sats, t_emission) -> SatState(r_ecef_m (n, 3), v_ecef_m_s (n, 3), clock_s (n,), valid (n,) bool)

with `sats` (n,) satellite ids ('G05') and `t_emission` a GpsTime (n,) or scalar: the signal emission time in GPS
time. `SatState` unpacks as that 4-tuple and also carries `clock_rate_s_s` (n,) for Doppler models.
`group_delay_s(sats, t)` gives the group delay a single-frequency (L1 C/A, E1, B1I) user subtracts from `clock_s`.

The clock convention is that of the ionosphere-free reference signal pair (GPS/QZSS L1/L2 P(Y), Galileo E1/E5x,
BeiDou B3I), which both the broadcast clock polynomial (before T_GD) and the IGS precise clocks refer to: a
dual-frequency ionosphere-free user takes `clock_s` as it is; an L1-only user takes `clock_s - group_delay_s`.
`clock_s` includes the relativistic eccentricity correction (IGS clock products exclude it: `PreciseEphemeris`
adds -2 r.v/c^2 so both providers mean the same thing). Positions are in the ECEF frame of the product, and of
the satellite antenna phase centre (APC) that the clocks refer to: the broadcast orbit is of the APC already; an
SP3 orbit is of the centre of mass (CoM), and `PreciseEphemeris` adds the satellite antenna offset
(gnssatt.gnss.satellite_antenna: built-in igs05.atx GPS values for IGS05 products, or a user's ANTEX) rotated by
the nominal yaw-steering attitude. Without it each satellite's range is long by its z offset (0.6-2.7 m for the
GPS blocks of 2007): on GRACE-A 2007-03-21 the per-satellite mean code residuals split by block, IIA -0.4 to
-0.9 m and IIR +0.2 to +1.0 m, and fall within +-0.3 m (most within 0.1 m) with the offsets.

Implements: IS-GPS-200N sec. 20.3.3.3.3.1-2 (clock, T_GD), 20.3.3.4.3 (orbit) via gnssatt.gnss.orbits.broadcast;
record choice per satellite and time by gnssatt.gnss.io.rinex_nav.select_ephemeris (health, fit interval,
nearest toe, latest transmission); SP3 Lagrange interpolation via gnssatt.gnss.orbits.sp3_interp; RINEX clock
linear interpolation; IERS Conventions (2010) eq. 10.10 (periodic relativistic clock term -2 r.v / c^2).
GLONASS: broadcast state vectors integrated per GLONASS ICD 5.1 A.3.1.2 (gnssatt.gnss.orbits.glonass).
Neglects: satellite antenna offsets
of SP3 products outside the igs05 era without a user ANTEX, and the satellite phase-centre variations (< 13 mm;
see gnssatt.gnss.satellite_antenna), the GGTO/BDT broadcast offsets beyond the fixed 14 s.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.orbits.broadcast import kepler_position_ecef
from gnssatt.gnss.time import GpsTime

__all__ = ["SatState", "SatelliteEphemeris", "BroadcastEphemeris", "PreciseEphemeris", "relativity_clock_s"]

#: Largest gap between two clock samples still interpolated across: 2.5 x the file's clock interval (a 30 s
#: clock file tolerates one missing sample; a satellite clock over 75 s stays within ~1 ns when linear).
CLOCK_GAP_FACTOR = 2.5


@dataclass(frozen=True)
class SatState:
    """Satellite states at emission times; unpacks as (r_ecef_m, v_ecef_m_s, clock_s, valid).

    r_ecef_m, v_ecef_m_s: (n, 3) position (m) and Earth-fixed velocity (m/s) in the product's ECEF frame.
    clock_s: (n,) satellite clock offset dt_sv (s): the satellite's time is t + dt_sv, so a pseudorange model
        subtracts c dt_sv; ionosphere-free reference, relativistic eccentricity term included.
    valid: (n,) bool; rows that are not valid hold NaN.
    clock_rate_s_s: (n,) d(dt_sv)/dt (s/s).
    """

    r_ecef_m: np.ndarray
    v_ecef_m_s: np.ndarray
    clock_s: np.ndarray
    valid: np.ndarray
    clock_rate_s_s: np.ndarray

    def __iter__(self):
        return iter((self.r_ecef_m, self.v_ecef_m_s, self.clock_s, self.valid))

    def __len__(self) -> int:
        return 4

    def __getitem__(self, i):
        """Tuple-like access, so a SatState is a `sat_state` result for gnssatt.gnss.geometry."""
        return (self.r_ecef_m, self.v_ecef_m_s, self.clock_s, self.valid)[i]


@runtime_checkable
class SatelliteEphemeris(Protocol):
    """Anything that gives satellite position/velocity/clock at GPS emission times (see module docstring)."""

    def state(self, sats, t_emission: GpsTime) -> SatState: ...

    def group_delay_s(self, sats, t: GpsTime) -> np.ndarray: ...


def relativity_clock_s(r_ecef_m, v_ecef_m_s) -> np.ndarray:
    """Periodic relativistic clock correction -2 (r . v) / c^2 (s), shape (...,), of states (..., 3).

    Implements: IERS Conventions (2010) eq. 10.10; IS-GPS-200 sec. 20.3.3.3.3.1 (equal to F e sqrt(A) sin E for
    a Keplerian orbit). r . v is frame-independent between ECEF and inertial only up to (omega x r) . r = 0, so
    the Earth-fixed velocity gives the same value.
    """
    r = np.asarray(r_ecef_m, dtype=np.float64)
    v = np.asarray(v_ecef_m_s, dtype=np.float64)
    return -2.0 * np.einsum("...i,...i->...", r, v) / (C_M_S * C_M_S)


def _pairs(sats, t: GpsTime) -> tuple[np.ndarray, GpsTime]:
    sats = np.atleast_1d(np.asarray(sats)).astype(str)
    ts = GpsTime(np.broadcast_to(np.atleast_1d(t.s), sats.shape).copy(),
                 np.broadcast_to(np.atleast_1d(t.frac), sats.shape).copy())
    return sats, ts


def _empty_state(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return (np.full((n, 3), np.nan), np.full((n, 3), np.nan), np.full(n, np.nan), np.zeros(n, dtype=bool),
            np.full(n, np.nan))


class BroadcastEphemeris:
    """Satellite states from a RINEX navigation file (`NavData`): GPS, QZSS, Galileo, BeiDou Keplerian records.

    Record choice per (satellite, time), among the healthy records (unless `allow_unhealthy`) whose toe lies within
    the fit interval (or `max_age_s`) of t: the record transmitted last at or before t, i.e. the data set (IODE)
    a receiver tracking the satellite would hold; ties -> nearest toe. Where no eligible record was transmitted
    by t (start of a daily file, transmission times absent), the nearest toe (`rinex_nav.select_ephemeris`).
    This matters at an upload: on 2007-03-21 G02 carried a stale upload whose toe-14:00 record is 16 m off while
    the fresh upload's toe-13:59:44 record, transmitted 29 min later, is 0.3 m off; "nearest toe" picks the stale
    one. GLONASS: the healthy record with the nearest t_b within MAX_AGE_S['R'] (30 min), its state vector
    integrated (gnssatt.gnss.orbits.glonass). Satellites without a usable record come back invalid.
    """

    def __init__(self, nav, *, max_age_s: float | None = None, allow_unhealthy: bool = False):
        self.nav = nav
        self.kepler = dict(getattr(nav, "kepler", {}) or {})
        glo = getattr(nav, "glonass", None)
        self.glonass = glo if glo is not None and len(glo) else None
        self.max_age_s = max_age_s
        self.allow_unhealthy = allow_unhealthy

    def select(self, sats, t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
        """(system letter (n,), record index into nav.kepler[system] (n,), -1 where none) per (sat, time)."""
        sats, ts = _pairs(sats, t)
        systems = np.array([s[:1] for s in sats]) if sats.size else np.array([], dtype=str)
        idx = np.full(sats.shape, -1, dtype=np.int64)
        for sat in np.unique(sats):
            m = sats == sat
            if sat[:1] == "R" and self.glonass is not None:
                from gnssatt.gnss.io.rinex_nav import MAX_AGE_S
                from gnssatt.gnss.orbits.glonass import select_glonass

                age = MAX_AGE_S["R"] if self.max_age_s is None else float(self.max_age_s)
                idx[m] = select_glonass(self.glonass, str(sat), ts[m], age, self.allow_unhealthy)
                continue
            eph = self.kepler.get(sat[:1])
            if eph is None:
                continue
            idx[m] = _select_as_receiver(eph, str(sat), ts[m], self.max_age_s, self.allow_unhealthy)
        return systems, idx

    def state(self, sats, t_emission: GpsTime) -> SatState:
        """SatState of satellites `sats` (n,) at GPS emission times `t_emission` ((n,) or scalar).

        Implements: IS-GPS-200N Table 20-IV and sec. 20.3.3.3.3.1 (clock polynomial + relativistic term, no T_GD:
        the L1/L2 ionosphere-free reference), and the Galileo/BeiDou equivalents (gnssatt.gnss.orbits.broadcast).
        """
        sats, ts = _pairs(sats, t_emission)
        r, v, clk, ok, rate = _empty_state(len(sats))
        systems, idx = self.select(sats, ts)
        for sysl in np.unique(systems[idx >= 0]) if np.any(idx >= 0) else []:
            m = (systems == sysl) & (idx >= 0)
            if sysl == "R":
                from gnssatt.gnss.orbits.glonass import glonass_state_ecef

                r[m], v[m], clk[m], rate[m] = glonass_state_ecef(self.glonass, idx[m], ts[m])
                continue
            rr, vv, cc, cr = kepler_position_ecef(self.kepler[sysl], idx[m], ts[m], apply_tgd=False)
            r[m], v[m], clk[m], rate[m] = rr, vv, cc, cr
        ok = np.isfinite(clk) & np.all(np.isfinite(r), axis=-1)
        return SatState(r, v, clk, ok, rate)

    def group_delay_s(self, sats, t: GpsTime) -> np.ndarray:
        """Group delay (s) an L1 C/A (GPS, QZSS), E1 (Galileo: BGD E1/E5a) or B1I (BeiDou: T_GD1) user subtracts.

        NaN where no record qualifies; 0 where the record leaves it blank.
        Implements: IS-GPS-200N sec. 20.3.3.3.3.2; Galileo OS SIS ICD 5.1.5; BDS ICD B1I 5.2.4.11.
        """
        sats, ts = _pairs(sats, t)
        out = np.full(len(sats), np.nan)
        systems, idx = self.select(sats, ts)
        for sysl in np.unique(systems[idx >= 0]) if np.any(idx >= 0) else []:
            m = (systems == sysl) & (idx >= 0)
            if sysl == "R":           # GLONASS: tau_n refers to the L1 C/A user (ICD 5.1 sec. 3.3.3); the L2 user
                out[m] = 0.0          # adds Delta tau_n, not modelled
                continue
            tgd = np.asarray(self.kepler[sysl].tgd_s, dtype=np.float64)[idx[m]]
            out[m] = np.where(np.isfinite(tgd), tgd, 0.0)
        return out


def _select_as_receiver(eph, sat: str, t: GpsTime, max_age_s: float | None, allow_unhealthy: bool) -> np.ndarray:
    """Record index (n,) per time: the eligible record transmitted last at or before t, else the nearest toe.

    Eligible: records of `sat`, healthy unless allow_unhealthy, |t - toe| <= max age (max_age_s, else the
    rinex_nav rule: half the curve-fit interval for GPS/QZSS, at least MAX_AGE_S; MAX_AGE_S for E/C).
    Implements: IS-GPS-200N sec. 20.3.4.4-20.3.4.5 (fit interval, toe at its centre), and the receiver's rule of
    using the most recently received data set (sec. 20.3.4.1: a new IODE supersedes the old one at cut-over).
    """
    from gnssatt.gnss.io.rinex_nav import MAX_AGE_S, healthy_records, select_ephemeris

    nearest = np.atleast_1d(select_ephemeris(eph, sat, t, max_age_s=max_age_s, allow_unhealthy=allow_unhealthy))
    cand = np.flatnonzero(np.asarray(eph.sat) == sat)
    if not allow_unhealthy:
        cand = cand[healthy_records(eph, cand)]
    if cand.size == 0:
        return nearest
    sub = eph.take(cand)
    toe, trans = sub.toe_gpst(), sub.transmission_gpst()
    if max_age_s is not None:
        max_age = np.full(len(cand), float(max_age_s))
    elif eph.system in ("G", "J"):
        fit = np.asarray(sub.fit_interval_h, dtype=np.float64)
        max_age = np.maximum(np.where(np.isfinite(fit) & (fit > 0), fit, 4.0) * 1800.0, MAX_AGE_S[eph.system])
    else:
        max_age = np.full(len(cand), MAX_AGE_S.get(eph.system, 7200.0))
    dt_toe = (t.s[:, None] - toe.s[None, :]).astype(np.float64) + (t.frac[:, None] - toe.frac[None, :])
    dt_tr = (t.s[:, None] - trans.s[None, :]).astype(np.float64) + (t.frac[:, None] - trans.frac[None, :])
    trans_ok = np.isfinite(np.asarray(sub.transmission_sow, dtype=np.float64))[None, :]
    eligible = (np.abs(dt_toe) <= max_age[None, :]) & trans_ok & (dt_tr >= 0.0)
    # Most recent transmission first (smallest t - t_trans), then nearest toe.
    key = np.where(eligible, dt_tr + 1e-6 * np.minimum(np.abs(dt_toe), 1e5) / 1e5, np.inf)
    best = np.argmin(key, axis=1)
    have = np.isfinite(key[np.arange(len(t)), best])
    return np.where(have, cand[best], nearest)


class PreciseEphemeris:
    """Satellite states from an SP3 orbit (Lagrange, default 10 points) and a RINEX clock file (linear).

    Without `clk` the SP3 clock column is used (linear between SP3 epochs: at 15 min this is decimetre- to
    metre-level, fine for orbits, poor for clocks). `nav` (optional NavData) provides the group delays of
    single-frequency users; without it `group_delay_s` is 0 (an L1-only user then keeps the T_GD error, a few m).
    Clocks get the relativistic term -2 r.v/c^2 added (IGS products exclude it; see module docstring).

    `antenna_offsets` moves the SP3 centre of mass to the satellite antenna phase centre (APC), which the
    product's clocks refer to (gnssatt.gnss.satellite_antenna): "auto" (default) applies the built-in igs05.atx
    GPS table when the SP3 declares the IGS05 frame (the products computed with igs05.atx) and nothing otherwise;
    None keeps the centre of mass; a `SatelliteAntennaOffsets` (e.g. `.from_antex(read_antex(path))`) is used
    as given. Satellites it does not cover stay at the centre of mass. `antenna_offsets` (attribute) is the
    model in use or None. Velocities stay those of the centre of mass (the offset turns with the orbit at
    ~0.4 mm/s).
    """

    def __init__(self, sp3, clk=None, *, nav=None, n_points: int = 10, antenna_offsets="auto"):
        from gnssatt.gnss.satellite_antenna import default_offsets_for_sp3

        self.sp3 = sp3
        self.clk = clk
        self.n_points = int(n_points)
        if isinstance(antenna_offsets, str):
            if antenna_offsets != "auto":
                raise ValueError(f"antenna_offsets must be 'auto', None or a SatelliteAntennaOffsets, "
                                 f"not {antenna_offsets!r}")
            antenna_offsets = default_offsets_for_sp3(sp3)
        self.antenna_offsets = antenna_offsets
        self._broadcast = BroadcastEphemeris(nav) if nav is not None else None
        if clk is not None:
            self._clk_time, self._clk_sats, self._clk_s = clk.time, list(clk.sats), np.asarray(clk.clock_s)
        else:
            self._clk_time, self._clk_sats, self._clk_s = sp3.time, list(sp3.sats), np.asarray(sp3.clock_s)
        steps = np.diff(self._clk_time - self._clk_time[0]) if len(self._clk_time) > 1 else np.array([0.0])
        self._clk_interval_s = float(np.median(steps)) if steps.size else 0.0

    def _clock(self, sat: str, t: GpsTime) -> tuple[np.ndarray, np.ndarray]:
        """(clock_s, clock_rate_s_s) of one satellite at times t (n,), linear between bracketing samples."""
        n = len(t)
        if sat not in self._clk_sats or len(self._clk_time) < 2:
            return np.full(n, np.nan), np.full(n, np.nan)
        col = self._clk_s[:, self._clk_sats.index(sat)]
        x = self._clk_time - self._clk_time[0]
        tt = t - self._clk_time[0]
        i = np.clip(np.searchsorted(x, tt, side="right") - 1, 0, len(x) - 2)
        step = x[i + 1] - x[i]
        frac = (tt - x[i]) / step
        c0, c1 = col[i], col[i + 1]
        ok = (tt >= x[0]) & (tt <= x[-1]) & (step <= CLOCK_GAP_FACTOR * self._clk_interval_s)
        clock = np.where(ok, (1.0 - frac) * c0 + frac * c1, np.nan)  # NaN samples propagate
        rate = np.where(ok, (c1 - c0) / step, np.nan)
        return clock, rate

    def state(self, sats, t_emission: GpsTime) -> SatState:
        """SatState of satellites `sats` (n,) at GPS emission times `t_emission` ((n,) or scalar).

        Implements: Lagrange interpolation of the SP3 positions (Schenewerk 2003) and its derivative; linear
        interpolation of the clocks; plus the relativistic term -2 r.v/c^2 (IERS Conventions 2010 eq. 10.10);
        plus the satellite antenna offset in the nominal yaw-steering frame when `antenna_offsets` is set.
        """
        from gnssatt.gnss.orbits.sp3_interp import interpolate_sp3, interpolate_sp3_velocity

        sats, ts = _pairs(sats, t_emission)
        r, v, clk, ok, rate = _empty_state(len(sats))
        for sat in np.unique(sats):
            m = np.flatnonzero(sats == sat)
            tm = ts[m]
            pos, _ = interpolate_sp3(self.sp3, [str(sat)], tm, n_points=self.n_points)
            vel = interpolate_sp3_velocity(self.sp3, [str(sat)], tm, n_points=self.n_points)
            c, cr = self._clock(str(sat), tm)
            r[m], v[m] = pos[:, 0], vel[:, 0]
            clk[m], rate[m] = c, cr
        clk = clk + relativity_clock_s(r, v)  # of the centre of mass, as the IGS convention defines it
        if self.antenna_offsets is not None and len(sats):
            off, covered = self.antenna_offsets.offset_ecef_m(sats, ts, r)
            r = np.where(covered[:, None], r + off, r)
        ok = np.isfinite(clk) & np.all(np.isfinite(r), axis=-1) & np.all(np.isfinite(v), axis=-1)
        r[~ok], v[~ok] = np.nan, np.nan
        clk[~ok], rate[~ok] = np.nan, np.nan
        return SatState(r, v, clk, ok, rate)

    def group_delay_s(self, sats, t: GpsTime) -> np.ndarray:
        """Single-frequency group delay (s) from the broadcast records of `nav` when given, else 0."""
        sats, ts = _pairs(sats, t)
        if self._broadcast is None:
            return np.zeros(len(sats))
        return self._broadcast.group_delay_s(sats, ts)
