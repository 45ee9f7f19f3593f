"""A GLONASS FDMA constellation for the simulator: 24 slots in three planes (or the records of a real navigation
file), one continuous orbit + clock per satellite, and the broadcast records that reproduce it.

Truth orbit: the GLONASS ICD equations of motion in the rotating PZ-90 frame (central term, J2^0, centrifugal and
Coriolis terms, a constant lunisolar acceleration per satellite: zero for the synthetic slots, the record's own for
a navigation file), integrated once over the set's span by RK4 with 5 s steps and served by cubic Hermite
interpolation of (r, v) on a 30 s grid (interpolation error < 0.1 mm). The simulator's own integrator: it shares
the equations, not the code, with gnssatt.gnss.orbits.glonass. A broadcast record at t_b is the truth state at
t_b, so a reader integrating it over +-15 min (ICD 5.1 A.3.1.2, RK4 60 s) reproduces the truth to a few mm.
Clock: dt_sv(t) = a0 + a1 (t - t_ref) in GPS time; a record writes tau_n = -dt_sv(t_b), gamma_n = a1 (ICD 5.1 sec.
3.3.3, relativity inside the broadcast clock). The GLONASS-GPS system time offset is zero (tau_GPS = 0).

Implements: GLONASS ICD edition 5.1 (2008) sec. 3.3.1.4 (frequency channel numbers k), sec. 4.5 Table 4.3 and
Appendix A.3.1.2 (equations of motion, Table 3.2 constants), the nominal orbit (sec. 3.1: three planes 120 deg
apart in right ascension, 8 slots 45 deg apart in argument of latitude, planes shifted by 15 deg, inclination
64.8 deg, period 11 h 15 min 44 s, a = 25 510 km) and the slot-to-channel plan of antipodal pairs (IAC, in use
since 2005: slots i and i+4 of a plane share k).
Neglects: the PZ-90.11 -> WGS 84 difference (truth and broadcast share one frame), satellite antenna offsets.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.orbits.glonass import AE_GLONASS_M, GM_GLONASS_M3_S2, J2_GLONASS, OMEGA_EARTH_GLONASS_RAD_S
from gnssatt.gnss.time import SECONDS_PER_WEEK, GpsTime
from gnssatt.sim.constellation import nearest_healthy_records

__all__ = ["NOMINAL_CHANNELS", "GlonassConstellation", "GlonassRecord", "MixedConstellation", "synthetic_glonass",
           "glonass_from_nav", "RECORD_INTERVAL_S"]

#: slot -> frequency channel number k (antipodal slots share a channel)
NOMINAL_CHANNELS = {1: 1, 2: -4, 3: 5, 4: 6, 5: 1, 6: -4, 7: 5, 8: 6, 9: -2, 10: -7, 11: 0, 12: -1, 13: -2,
                    14: -7, 15: 0, 16: -1, 17: 4, 18: -3, 19: 3, 20: 2, 21: 4, 22: -3, 23: 3, 24: 2}
RECORD_INTERVAL_S = 1800            # t_b every 30 min, at hh:15 and hh:45 UTC (ICD 5.1 sec. 4.4, t_b)
_TB_PHASE_S = 900
_GRID_S = 30.0
_STEP_S = 5.0
# GLONASS ICD 5.1 Table 3.2: definitions, so the project's one copy (the equations are the simulator's own)
_GM, _AE, _J2, _WE = GM_GLONASS_M3_S2, AE_GLONASS_M, J2_GLONASS, OMEGA_EARTH_GLONASS_RAD_S


@dataclass
class GlonassRecord:
    """One GLONASS broadcast record (RINEX 3.04 Table A10): t_b as the UTC calendar (epoch_utc), PZ-90 state."""

    sat: str
    epoch_utc: GpsTime              # t_b expressed as the UTC calendar (GPS time minus leap seconds)
    tau_n_s: float                  # RINEX writes -tau_n
    gamma_n: float
    message_frame_time_s: float     # seconds of the UTC week
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    frequency_number: int
    health: int = 0
    age_days: float = 0.0


def _deriv(y: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """d/dt (r, v) (n, 6) in the rotating PZ-90 frame: GLONASS ICD 5.1 eq. A.3.1.2 with constant acc (n, 3)."""
    r, v = y[:, :3], y[:, 3:]
    r2 = np.sum(r * r, axis=1)
    rn = np.sqrt(r2)
    mu_r3 = _GM / (r2 * rn)
    j = 1.5 * _J2 * _GM * _AE ** 2 / (r2 * r2 * rn)
    z2 = 5.0 * r[:, 2] ** 2 / r2
    out = np.empty_like(y)
    out[:, :3] = v
    out[:, 3] = -mu_r3 * r[:, 0] - j * r[:, 0] * (1.0 - z2) + _WE ** 2 * r[:, 0] + 2 * _WE * v[:, 1] + acc[:, 0]
    out[:, 4] = -mu_r3 * r[:, 1] - j * r[:, 1] * (1.0 - z2) + _WE ** 2 * r[:, 1] - 2 * _WE * v[:, 0] + acc[:, 1]
    out[:, 5] = -mu_r3 * r[:, 2] - j * r[:, 2] * (3.0 - z2) + acc[:, 2]
    return out


def _integrate(y0: np.ndarray, acc: np.ndarray, t_grid: np.ndarray, t0: float) -> np.ndarray:
    """States (m, n, 6) at the ascending times t_grid (s), from y0 (n, 6) at t0 (a node of t_grid): RK4."""
    out = np.empty((t_grid.size, *y0.shape))
    i0 = int(np.argmin(np.abs(t_grid - t0)))
    out[i0] = y0
    for direction in (1, -1):
        y = y0.copy()
        rng = range(i0 + 1, t_grid.size) if direction > 0 else range(i0 - 1, -1, -1)
        prev = t_grid[i0]
        for i in rng:
            n_sub = int(np.ceil(abs(t_grid[i] - prev) / _STEP_S))
            h = (t_grid[i] - prev) / n_sub
            for _ in range(n_sub):
                k1 = _deriv(y, acc)
                k2 = _deriv(y + 0.5 * h * k1, acc)
                k3 = _deriv(y + 0.5 * h * k2, acc)
                k4 = _deriv(y + h * k3, acc)
                y = y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            out[i] = y
            prev = t_grid[i]
    return out


@dataclass
class GlonassConstellation:
    """Continuous GLONASS orbits (ECEF = PZ-90 here) and clocks over a grid of times (s since t_ref)."""

    sats: list[str]
    channels: np.ndarray            # (n,) frequency channel numbers k
    t_ref: GpsTime
    grid_dt_s: np.ndarray           # (m,) s since t_ref, uniform step _GRID_S
    state_grid: np.ndarray          # (m, n, 6) r (m), v (m/s)
    acc_ls_m_s2: np.ndarray         # (n, 3) constant lunisolar acceleration of the truth model
    clk_a0_s: np.ndarray            # (n,) clock at t_ref (s)
    clk_a1_s_s: np.ndarray          # (n,) clock rate (gamma_n)
    tgd: np.ndarray = field(default=None)   # zero: no TGD in the GLONASS code (kept for the simulator's API)

    def __post_init__(self):
        if self.tgd is None:
            self.tgd = np.zeros(len(self.sats))

    @property
    def n(self) -> int:
        return len(self.sats)

    def position_clock(self, dt_s: np.ndarray, sat_idx: np.ndarray | slice = slice(None)):
        """(r_ecef_m (..., n_sel, 3), dt_sv_s (..., n_sel)) at true GPS times t_ref + dt_s (last axis: the
        satellites sat_idx). Cubic Hermite on the integrated (r, v) grid; clock a0 + a1 dt (ICD 5.1 sec. 3.3.3)."""
        dt = np.asarray(dt_s, dtype=np.float64)
        sel = np.arange(self.n)[sat_idx]
        g0 = self.grid_dt_s[0]
        if dt.size and (dt.min() < g0 or dt.max() > self.grid_dt_s[-1]):
            raise ValueError("GLONASS time outside the integrated span")
        u = (dt - g0) / _GRID_S
        i = np.clip(np.floor(u).astype(np.int64), 0, self.grid_dt_s.size - 2)
        s = (u - i)[..., None]
        cols = np.broadcast_to(sel, dt.shape)
        y0, y1 = self.state_grid[i, cols], self.state_grid[i + 1, cols]
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        r = h00 * y0[..., :3] + h10 * _GRID_S * y0[..., 3:] + h01 * y1[..., :3] + h11 * _GRID_S * y1[..., 3:]
        clk = self.clk_a0_s[cols] + self.clk_a1_s_s[cols] * dt
        return r, clk

    def records(self, t_first: GpsTime, t_last: GpsTime, leap_s: int) -> list[GlonassRecord]:
        """Records every 30 min (t_b at hh:15, hh:45 UTC) from the last t_b <= t_first to the first >= t_last,
        in time order, then satellite order. t_b is a node of the state grid (exact truth states)."""
        out = []
        for tb in self._tb_list(t_first, t_last, leap_s):
            k = int(np.argmin(np.abs(self.grid_dt_s - tb)))
            y = self.state_grid[k]
            utc = self.t_ref + (tb - leap_s)
            sow_utc = float(int(utc.s) % SECONDS_PER_WEEK)
            for j, sat in enumerate(self.sats):
                out.append(GlonassRecord(
                    sat=sat, epoch_utc=utc, tau_n_s=-float(self.clk_a0_s[j] + self.clk_a1_s_s[j] * tb),
                    gamma_n=float(self.clk_a1_s_s[j]), message_frame_time_s=(sow_utc - 900.0) % SECONDS_PER_WEEK,
                    position_m=y[j, :3].copy(), velocity_m_s=y[j, 3:].copy(),
                    acceleration_m_s2=self.acc_ls_m_s2[j].copy(), frequency_number=int(self.channels[j])))
        return out

    def _tb_list(self, t_first: GpsTime, t_last: GpsTime, leap_s: int) -> list[float]:
        """t_b (s since t_ref, GPS) of the records covering [t_first, t_last]."""
        utc_ref = int(self.t_ref.s) - leap_s
        first = float(t_first - self.t_ref) + utc_ref - _TB_PHASE_S
        last = float(t_last - self.t_ref) + utc_ref - _TB_PHASE_S
        k0 = int(np.floor(first / RECORD_INTERVAL_S))
        k1 = int(np.ceil(last / RECORD_INTERVAL_S))
        return [float(k * RECORD_INTERVAL_S + _TB_PHASE_S - utc_ref) for k in range(k0, k1 + 1)]


def _grid(t_ref: GpsTime, span_s: tuple[float, float], leap_s: int) -> np.ndarray:
    """Uniform grid (s since t_ref) over span +-35 min, its nodes on the t_b of the records (30 s divides 30 min)."""
    anchor = float((_TB_PHASE_S - (int(t_ref.s) - leap_s)) % RECORD_INTERVAL_S)
    lo = anchor + _GRID_S * np.floor((span_s[0] - 2100.0 - anchor) / _GRID_S)
    hi = anchor + _GRID_S * np.ceil((span_s[1] + 2100.0 - anchor) / _GRID_S)
    return np.arange(lo, hi + 0.5 * _GRID_S, _GRID_S)


def synthetic_glonass(t_ref: GpsTime, span_s: tuple[float, float], leap_s: int,
                      seed: int = 2018) -> GlonassConstellation:
    """The nominal 24-slot GLONASS constellation (R01-R24, channels NOMINAL_CHANNELS) at t_ref.

    Args:
        t_ref: reference epoch (the GPS constellation's, so that one time offset serves both).
        span_s: (min, max) seconds since t_ref the simulation asks for (records and light time included).
        leap_s: GPS - UTC (s): records are on the UTC half hours.
        seed: constellation seed; elements scatter around the nominal slots (e < 0.002, i 64.8 +- 0.3 deg).
    """
    rng = np.random.default_rng(np.random.SeedSequence([seed, 7019]))
    slots = np.arange(1, 25)
    plane = (slots - 1) // 8
    a = 25_510_000.0 + rng.normal(0, 2000.0, 24)
    e = rng.uniform(0.0, 0.002, 24)
    inc = np.radians(64.8 + rng.uniform(-0.3, 0.3, 24))
    raan = np.radians(rng.uniform(0, 360.0) + 120.0 * plane + rng.normal(0, 0.05, 24))
    u = np.radians(rng.uniform(0, 360.0) + 45.0 * ((slots - 1) % 8) + 15.0 * plane + rng.normal(0, 0.5, 24))
    argp = rng.uniform(-np.pi, np.pi, 24)
    y0 = _kepler_state_rotating(a, e, inc, raan, argp, u - argp)
    grid = _grid(t_ref, span_s, leap_s)
    acc = np.zeros((24, 3))
    states = _integrate_from(y0, acc, grid, 0.0)
    return GlonassConstellation(
        sats=[f"R{s:02d}" for s in slots], channels=np.array([NOMINAL_CHANNELS[s] for s in slots]), t_ref=t_ref,
        grid_dt_s=grid, state_grid=states, acc_ls_m_s2=acc, clk_a0_s=rng.uniform(-2e-4, 2e-4, 24),
        clk_a1_s_s=np.round(rng.normal(0, 1.5e-12, 24) / 2 ** -40) * 2 ** -40)


def _integrate_from(y0: np.ndarray, acc: np.ndarray, grid: np.ndarray, t0: float) -> np.ndarray:
    """States on `grid` from y0 at t0, which need not be a node: first carried to the nearest node."""
    k = int(np.argmin(np.abs(grid - t0)))
    y = _integrate(y0, acc, np.array(sorted({t0, float(grid[k])})), t0)
    yk = y[-1] if grid[k] >= t0 else y[0]
    return _integrate(yk, acc, grid, float(grid[k]))


def _kepler_state_rotating(a, e, inc, raan, argp, mean_anom) -> np.ndarray:
    """(n, 6) position/velocity from Kepler elements in the inertial frame that coincides with the rotating frame
    at the reference epoch, expressed in the rotating frame (v_rot = v_in - omega_E x r)."""
    E = mean_anom.copy()
    for _ in range(8):
        E = E - (E - e * np.sin(E) - mean_anom) / (1 - e * np.cos(E))
    nu = np.arctan2(np.sqrt(1 - e * e) * np.sin(E), np.cos(E) - e)
    p = a * (1 - e * e)
    r = p / (1 + e * np.cos(nu))
    u = argp + nu
    cO, sO, ci, si = np.cos(raan), np.sin(raan), np.cos(inc), np.sin(inc)
    cu, su = np.cos(u), np.sin(u)
    pos = r[:, None] * np.stack([cO * cu - sO * su * ci, sO * cu + cO * su * ci, su * si], axis=1)
    h = np.sqrt(_GM * p)
    vr, vt = np.sqrt(_GM / p) * e * np.sin(nu), h / r
    rh = pos / r[:, None]
    th = np.stack([-cO * su - sO * cu * ci, -sO * su + cO * cu * ci, cu * si], axis=1)
    vel = vr[:, None] * rh + vt[:, None] * th
    vel = vel - np.cross(np.array([0.0, 0.0, _WE]), pos)
    return np.concatenate([pos, vel], axis=1)


def glonass_from_nav(nav_path, t0: GpsTime, t_ref: GpsTime, span_s: tuple[float, float],
                     leap_s: int) -> GlonassConstellation:
    """The GLONASS satellites of a real navigation file: per healthy satellite the record whose t_b is nearest t0,
    its state vector and lunisolar acceleration carried over the span by the truth model, its tau_n / gamma_n as
    the clock and its frequency number as k (GLONASS ICD 5.1 A.3.1.2, sec. 3.3.3)."""
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav

    glo = read_rinex_nav(nav_path).glonass
    if glo is None or len(glo) == 0:
        raise ValueError(f"nav_file {nav_path}: no GLONASS records (systems includes R)")
    d = np.abs(np.asarray((glo.toc.s - int(t0.s)), dtype=np.float64) + glo.toc.frac - float(t0.frac))
    chosen = nearest_healthy_records(glo.sat.tolist(), glo.health, d, 3600.0)
    if len(chosen) < 4:
        raise ValueError(f"nav_file {nav_path}: only {len(chosen)} healthy GLONASS satellites within 1 h of "
                         f"{t0.iso()}; choose start_gps inside the file's span")
    sats = sorted(chosen)
    idx = np.array([chosen[s] for s in sats])
    grid = _grid(t_ref, span_s, leap_s)
    states = np.empty((grid.size, len(sats), 6))
    acc = np.asarray(glo.acceleration_m_s2, float)[idx]
    a0 = np.empty(len(sats))
    for j, i in enumerate(idx):
        tb = float(glo.toc[int(i)] - t_ref)
        y0 = np.concatenate([glo.position_m[i], glo.velocity_m_s[i]])[None, :]
        states[:, j:j + 1] = _integrate_from(y0, acc[j:j + 1], grid, tb)
        a0[j] = -float(glo.tau_n_s[i]) - float(glo.gamma_n[i]) * tb
    return GlonassConstellation(sats=sats, channels=np.asarray(glo.frequency_number)[idx].astype(np.int64),
                                t_ref=t_ref, grid_dt_s=grid, state_grid=states, acc_ls_m_s2=acc, clk_a0_s=a0,
                                clk_a1_s_s=np.asarray(glo.gamma_n, float)[idx])


class MixedConstellation:
    """GPS and/or GLONASS satellites behind the one interface the simulator uses (sats, n, t_ref, tgd,
    position_clock), with per-satellite wavelengths and ionospheric factors of the signals "L1" / "L2" (GPS L1/L2,
    GLONASS G1/G2 of each satellite's channel: gnssatt.gnss.signals)."""

    def __init__(self, gps=None, glonass: GlonassConstellation | None = None):
        self.gps, self.glonass = gps, glonass
        self.parts = [c for c in (gps, glonass) if c is not None]
        self.t_ref = self.parts[0].t_ref
        self.sats = [s for c in self.parts for s in c.sats]
        self.tgd = np.concatenate([np.asarray(c.tgd, float) for c in self.parts])
        n_g = gps.n if gps is not None else 0
        self.channels = np.concatenate([np.zeros(n_g, np.int64),
                                        glonass.channels if glonass is not None else np.zeros(0, np.int64)])
        self.is_glonass = np.arange(self.n) >= n_g

    @property
    def n(self) -> int:
        return len(self.sats)

    def position_clock(self, dt_s: np.ndarray, sat_idx: np.ndarray | slice = slice(None)):
        """As Constellation.position_clock, each satellite from its own system's model."""
        dt = np.asarray(dt_s, dtype=np.float64)
        sel = np.arange(self.n)[sat_idx]
        r = np.empty(dt.shape + (3,))
        clk = np.empty(dt.shape)
        start = 0
        for c in self.parts:
            m = (sel >= start) & (sel < start + c.n)
            if m.any():
                r[..., m, :], clk[..., m] = c.position_clock(dt[..., m], sel[m] - start)
            start += c.n
        return r, clk

    def wavelength_m(self, signal: str) -> np.ndarray:
        """(n,) carrier wavelength of "L1" / "L2" per satellite: GPS L1/L2, GLONASS G1/G2 of channel k."""
        from gnssatt.gnss.signals import SIGNALS, glonass_wavelength_m

        band = 1 if signal == "L1" else 2
        return np.where(self.is_glonass, glonass_wavelength_m(band, self.channels), SIGNALS[signal]["wavelength_m"])

    def iono_factor(self, signal: str) -> np.ndarray:
        """(n,) first-order ionospheric delay on `signal` per unit delay on GPS L1: (f_L1 / f)^2."""
        from gnssatt.gnss.signals import FREQ_GPS_L1_HZ, SIGNALS, glonass_frequency_hz

        band = 1 if signal == "L1" else 2
        f = np.where(self.is_glonass, glonass_frequency_hz(band, self.channels), SIGNALS[signal]["freq_hz"])
        return (FREQ_GPS_L1_HZ / f) ** 2
