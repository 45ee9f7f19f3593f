"""Bring the observations of several receivers to common GPS epochs, and find their 1 ms clock jumps.

A receiver samples when its own clock reads the epoch T (the RINEX time tag); the true GPS time of that sample is
t = T - dt_r, with dt_r its clock offset (up to +-1 ms for receivers that let the clock run and jump by 1 ms, or
tags like 59.999 s). Two receivers on one platform therefore sample at GPS times up to a millisecond apart, in
which a LEO-GNSS range changes by up to ~8 m. This module moves every observation to the nominal GPS epoch
t0 = round(t / interval) * interval, so single differences between receivers contain no such geometry.

Derivation. For satellite s and a receiver with clock offset dt_r(T) the code observed at tag T is
    P(T) = rho_s(t) - c dt_s(t - tau) + c dt_r(T) + I + Tr + e,           t = T - dt_r(T),
with rho_s(t) the geometric range for reception at GPS time t (light time tau, Sagnac) and dt_s the satellite
clock at emission. Define the geometry term G_s(t) = rho_s(t) - c dt_s(t - tau_s(t)). The aligned observation is
what the same receiver, with the same clock reading error, would have measured had it sampled at t0:
    P_al(t0) = P(T) + G_s(t0) - G_s(t)          (code, m)
    L_al(t0) = L(T) + (G_s(t0) - G_s(t)) / lambda (phase, cycles; lambda of the signal)
    D_al(t0) = D(T) - (dG_s/dt(t0) - dG_s/dt(t)) / lambda   (Doppler, Hz)
G_s is evaluated exactly at both times (light-time iteration with Sagnac, gnssatt.gnss.geometry, and the
ephemeris' satellite clock), with the receiver at r(t) (SPP position) and r(t0) = r(t) + v (t0 - t) (SPP
velocity), not linearised, so offsets of milliseconds (or more) are handled alike.
What stays in the aligned observation: c dt_r(T), the receiver clock term, the same for every satellite of one
receiver (and, in phase, the phase clock, which differs from the code clock by whole milliseconds when a receiver
jumps its code clock only). The attitude filter estimates a differential clock per epoch, so these are harmless
there. What goes: the satellite-dependent change of range and satellite clock over t0 - t.
Error budget of the shift (t0 - t <= 1 ms): receiver velocity error dv gives e.dv (t0 - t) (0.1 m/s -> 0.1 mm);
clock error d(dt_r) gives range rate x d(dt_r) (8 km/s x 10 ns = 0.08 mm); position error dr gives (dr/rho)|v_s|
(t0 - t) (10 m -> 4e-6 m); the atmosphere is not shifted (its rate x 1 ms < 0.1 mm). The tests measure it.

Clock jumps. Between consecutive epochs the SPP clock changes by drift x dt; a change that departs from that by
k x 1 ms (|k| >= 1, within 20 us) is a jump. Whether the phase jumped too is read from the code-minus-phase of
every satellite tracked across the step: it moves by c k 1 ms (299.8 km) when only the code clock jumped, and by
the ionosphere's change (cm) when both did. Each jump is a `ClockJumpEvent`; `repair_clock_jumps=True` removes
the whole milliseconds from code (and from phase where it jumped: f x 1 ms cycles, an integer for every GPS/Galileo
frequency) so the kept clock is continuous.

Implements: the observation equations of RINEX 3.04 sec. 5.2 (time tags in receiver time; observables as measured,
"RCV CLOCK OFFS APPL" 0); light time and Sagnac of IS-GPS-200N 20.3.3.4.3.4; the 1 ms clock-steering behaviour
described in RINEX-QUIRKS ("Receiver clock jumps of exactly 1 ms", "Epoch times at 59.999 s").
Neglects: files with "RCV CLOCK OFFS APPL 1" (their tags are already corrected; they are treated like any other,
which is right as long as the SPP clock is then ~0), the receiver acceleration over t0 - t (LEO 9 m/s^2 x
(1 ms)^2 / 2 = 5e-6 m), the atmosphere's change over t0 - t, GLONASS (no ephemeris: its rows stay unshifted and
are flagged in `shifted`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.geometry import emission_time_and_position
from gnssatt.gnss.signals import FREQ_BY_SYSTEM_BAND_HZ, glonass_frequency_hz
from gnssatt.gnss.time import GpsTime

__all__ = ["ClockJumpEvent", "AlignedReceiver", "AlignedObs", "align_to_gps_epochs", "detect_clock_jumps",
           "geometry_term_m"]

MS_S = 1e-3
#: A clock step is a jump when it departs from drift x dt by k ms within this tolerance (s): SPP clock noise is
#: ~10 ns, drift predictions errs by < 1 us over a second; 20 us leaves room and excludes anything but whole ms.
JUMP_TOLERANCE_S = 20e-6
#: Code-minus-phase step (m) above which the phase did not follow a code clock jump: half of c x 1 ms.
PHASE_JUMP_TEST_M = 0.5 * C_M_S * MS_S


@dataclass
class ClockJumpEvent:
    """A receiver clock jump between epoch index-1 and index (indices into that receiver's file epochs)."""

    receiver: str
    index: int
    time_tag: GpsTime
    jump_s: float            # whole milliseconds, signed (clock offset after minus before, minus the drift)
    in_phase: bool | None    # True: phase jumped with the code; False: code only; None: no satellite to tell
    repaired: bool = False

    def to_dict(self) -> dict:
        return {"receiver": self.receiver, "index": self.index, "time_gps": self.time_tag.iso(3),
                "jump_s": self.jump_s, "in_phase": self.in_phase, "repaired": self.repaired}


@dataclass
class AlignedReceiver:
    """One receiver's observations on the common epoch grid of an `AlignedObs` (n epochs, m = len(sats)).

    codes: this receiver's observation codes (as in its RinexObs); values (n, m, n_codes) aligned observations
    (NaN where absent); lli, ssi (n, m, n_codes) int8 as in the file (-1 absent); present (n,) bool: the receiver
    has an epoch there; time_tag: GpsTime (n,) its own tag (the grid epoch where absent); shift_s (n,) t0 - t,
    seconds the observations were moved (NaN where absent); clock_s (n,) receiver clock offset kept in the
    observations (after repair, if any); position_ecef_m, velocity_ecef_m_s (n, 3) at t0; shifted (n, m) bool:
    the geometry correction was applied (False where the satellite has no ephemeris).
    """

    name: str
    codes: list[str]
    values: np.ndarray
    lli: np.ndarray
    ssi: np.ndarray
    present: np.ndarray
    time_tag: GpsTime
    shift_s: np.ndarray
    clock_s: np.ndarray
    position_ecef_m: np.ndarray
    velocity_ecef_m_s: np.ndarray
    shifted: np.ndarray
    obs_types: dict[str, list[str]] = field(default_factory=dict)
    version: float = 3.04

    def get(self, code3: str, system: str, sats: list[str]) -> np.ndarray:
        """(n, m) values of RINEX 3 code `code3` for the satellites of `system` (others NaN); KeyError if absent."""
        k = _code_index(self.codes, self.obs_types, self.version, code3, system)
        if k is None:
            raise KeyError(f"{self.name} has no {code3} observations for system {system}")
        out = np.full(self.values.shape[:2], np.nan)
        mask = np.array([s[:1] == system for s in sats], dtype=bool)
        out[:, mask] = self.values[:, mask, k]
        return out


@dataclass
class AlignedObs:
    """Observations of several receivers at common GPS epochs.

    time: GpsTime (n,) the grid (nominal GPS epochs, multiples of interval_s); sats: union of satellites (sorted);
    receivers: one AlignedReceiver per input, in input order; events: clock jumps found (and repaired or not).
    """

    time: GpsTime
    interval_s: float
    sats: list[str]
    receivers: list[AlignedReceiver]
    events: list[ClockJumpEvent] = field(default_factory=list)

    def receiver(self, name: str) -> AlignedReceiver:
        for r in self.receivers:
            if r.name == name:
                return r
        raise KeyError(name)


def _code_index(codes, obs_types, version, code3, system):
    from gnssatt.gnss.io.rinex_obs import rinex3_code

    types = obs_types.get(system, [])
    if code3 in types:
        return codes.index(code3)
    if version < 3:
        for c in types:
            try:
                if rinex3_code(system, c, version) == code3:
                    return codes.index(c)
            except ValueError:
                continue
    return None


def _wavelengths(obs, sats) -> np.ndarray:
    """(m, n_codes) wavelength (m) of each code for each satellite (NaN: not a carrier-related code)."""
    from gnssatt.gnss.io.rinex_obs import rinex3_code

    lam = np.full((len(sats), len(obs.codes)), np.nan)
    slots = getattr(obs.header, "glonass_slots", {}) or {}
    for j, sat in enumerate(sats):
        sysl = sat[:1]
        for k, code in enumerate(obs.codes):
            try:
                c3 = rinex3_code(sysl, code, obs.header.version) if len(code) == 2 else code
            except ValueError:
                continue
            band = c3[1:2]
            f = None
            if sysl == "R" and band in "12":
                if sat in slots:
                    f = glonass_frequency_hz(int(band), slots[sat])
            else:
                f = FREQ_BY_SYSTEM_BAND_HZ.get((sysl, band))
            if f:
                lam[j, k] = C_M_S / f
    return lam


def geometry_term_m(ephemeris, sats, r_rx_ecef_m, v_rx_ecef_m_s, t_rx: GpsTime) -> tuple[np.ndarray, np.ndarray]:
    """(G (n,) m, dG/dt (n,) m/s): rho - c dt_sv and its rate for pairs (sats[i], t_rx[i]) with receiver r, v.

    G = |R3(omega tau) r_s(t - tau) - r_rx| - c dt_s(t - tau), light time iterated (gnssatt.gnss.geometry);
    dG/dt = e . (v_s - v_rx) - c d(dt_s)/dt with e the receiver-to-satellite unit vector (the Sagnac term of the
    rate, omega x r products of ~1e-6 relative size, cancels between the two times and is left out).
    """
    sats = np.asarray(sats).astype(str)
    res = emission_time_and_position(ephemeris.state, sats, r_rx_ecef_m, t_rx,
                                     tau0_s=np.full(len(sats), 0.07))
    st = ephemeris.state(sats, res.t_tx)
    G = res.range_m - C_M_S * st.clock_s
    rate = (np.einsum("ni,ni->n", res.los_ecef, res.v_sat_ecef_m_s - np.asarray(v_rx_ecef_m_s))
            - C_M_S * st.clock_rate_s_s)
    return G, rate


def detect_clock_jumps(obs, clock_s: np.ndarray, name: str = "") -> tuple[list[ClockJumpEvent], np.ndarray]:
    """(events, cumulative jump count (n,) in whole ms): 1 ms steps of a receiver clock series.

    Args: obs RinexObs of the receiver; clock_s (n,) its SPP clock per epoch (NaN where no fix); name for events.
    The expected step is the median drift x dt over the series; a step that departs from it by k ms (|k| >= 1,
    within JUMP_TOLERANCE_S) is a jump. NaN epochs are bridged (the step is taken between the fixes around them).
    Phase: code-minus-phase per satellite (lambda L - C, first carrier/code pair on the same band) changes by
    ~c k 1 ms when only the code jumped.
    """
    n = len(clock_s)
    k_cum = np.zeros(n, dtype=np.int64)
    events: list[ClockJumpEvent] = []
    good = np.flatnonzero(np.isfinite(clock_s))
    if good.size < 2:
        return events, k_cum
    t = obs.time
    tt = t[good] - t[good[0]]
    c = clock_s[good]
    d = np.diff(c)
    dt = np.diff(tt)
    rate = d / dt
    drift = np.median(rate[np.abs(d) < MS_S / 2]) if np.any(np.abs(d) < MS_S / 2) else 0.0
    resid = d - drift * dt
    k = np.round(resid / MS_S).astype(np.int64)
    is_jump = (k != 0) & (np.abs(resid - k * MS_S) < JUMP_TOLERANCE_S)
    cmp_m = _code_minus_phase_m(obs)
    for i in np.flatnonzero(is_jump):
        a, b = good[i], good[i + 1]
        in_phase = None
        if cmp_m is not None:
            step = cmp_m[b] - cmp_m[a]
            step = step[np.isfinite(step)]
            if step.size:
                in_phase = bool(np.median(np.abs(step)) < PHASE_JUMP_TEST_M)
        events.append(ClockJumpEvent(name, int(b), t[b], float(k[i] * MS_S), in_phase))
        k_cum[b:] += k[i]
    return events, k_cum


def _code_minus_phase_m(obs) -> np.ndarray | None:
    """(n, m) lambda L - C on the first band that has both a code and a phase (GPS band 1 first)."""
    from gnssatt.gnss.io.rinex_obs import rinex3_code

    lam = _wavelengths(obs, obs.sats)
    out = np.full(obs.values.shape[:2], np.nan)
    found = False
    for sysl in sorted({s[:1] for s in obs.sats}):
        types = obs.header.obs_types.get(sysl, [])
        codes3 = {}
        for c in types:
            try:
                codes3[c] = rinex3_code(sysl, c, obs.header.version) if len(c) == 2 else c
            except ValueError:
                continue
        for c_phase, c3 in codes3.items():
            if c3[0] != "L":
                continue
            c_code = next((c for c, x in codes3.items() if x[0] == "C" and x[1] == c3[1]), None)
            if c_code is None:
                continue
            kp, kc = obs.codes.index(c_phase), obs.codes.index(c_code)
            mask = np.array([s[:1] == sysl for s in obs.sats])
            val = obs.values[:, mask, kp] * lam[mask, kp][None, :] - obs.values[:, mask, kc]
            sub = out[:, mask]
            fill = np.isnan(sub)
            sub[fill] = val[fill]
            out[:, mask] = sub
            found = True
            break
    return out if found else None


def _fill_series(t_s: np.ndarray, y: np.ndarray, rate: np.ndarray | None = None) -> np.ndarray:
    """y (n,) or (n, k) with NaN rows filled: linear in time between values; beyond the ends extrapolated with
    `rate` (same shape, per unit of t_s; e.g. the velocity for a position, the drift for a clock; NaN rate -> the
    slope of the two nearest values; one value only -> constant). All-NaN columns stay NaN.

    Extrapolation matters: a LEO moves 8 km in a second, so holding its first fix constant over the first
    seconds of a file would misplace it by tens of km (8 mm of shift error over 1 ms); the velocity keeps it < 1 m.
    """
    y = np.asarray(y, dtype=np.float64)
    one_d = y.ndim == 1
    Y = y[:, None] if one_d else y.reshape(len(y), -1)
    R = None if rate is None else (np.asarray(rate, np.float64)[:, None] if one_d
                                   else np.asarray(rate, np.float64).reshape(len(y), -1))
    out = Y.copy()
    for j in range(Y.shape[1]):
        ok = np.flatnonzero(np.isfinite(Y[:, j]))
        if ok.size == 0 or ok.size == len(Y):
            continue
        out[:, j] = np.interp(t_s, t_s[ok], Y[ok, j])
        for end, side in ((ok[0], t_s < t_s[ok[0]]), (ok[-1], t_s > t_s[ok[-1]])):
            slope = np.nan if R is None else R[end, j]
            if not np.isfinite(slope) and ok.size >= 2:
                a, b = (ok[0], ok[1]) if end == ok[0] else (ok[-2], ok[-1])
                slope = (Y[b, j] - Y[a, j]) / (t_s[b] - t_s[a])
            if np.isfinite(slope):
                out[side, j] = Y[end, j] + slope * (t_s[side] - t_s[end])
    return out[:, 0] if one_d else out.reshape(y.shape)


#: A jump-free clock fix farther than this from the running median of its neighbours is not trusted (s), or more
#: than 6 x their median absolute deviation when that is larger (real receivers: SPP clock noise ~3-10 ns).
CLOCK_OUTLIER_S = 30e-9
CLOCK_MEDIAN_WINDOW = 30  # epochs either side (NaN-padded at the ends, so a bad start is outvoted)


def _reliable_fixes(sol) -> np.ndarray:
    """(n,) bool: fixes good enough to define the clock, position and velocity used for the shift."""
    from gnssatt.gnss.positioning import FLAG_HIGH_PDOP, FLAG_RAIM_FAILED, FLAG_RAIM_UNTESTED

    return sol.valid & ((sol.flags & (FLAG_RAIM_FAILED | FLAG_RAIM_UNTESTED | FLAG_HIGH_PDOP)) == 0) \
        & np.isfinite(sol.clock_s)


def _clock_outliers(clock_cont: np.ndarray) -> np.ndarray:
    """(n,) bool: jump-free clock values that depart from the running median (detrended) of their neighbours."""
    n = len(clock_cont)
    out = np.zeros(n, dtype=bool)
    ok = np.flatnonzero(np.isfinite(clock_cont))
    if ok.size < 5:
        return out
    y = clock_cont[ok]
    x = ok.astype(np.float64)
    w = CLOCK_MEDIAN_WINDOW
    slope = np.median(np.diff(y) / np.diff(x))
    detr = np.concatenate([np.full(w, np.nan), y - slope * x, np.full(w, np.nan)])
    win = np.lib.stride_tricks.sliding_window_view(detr, 2 * w + 1)  # NaN-padded: the ends use half windows
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(win, axis=1)
        mad = np.nanmedian(np.abs(win - med[:, None]), axis=1)
    dev = np.abs(detr[w:-w] - med)
    out[ok] = dev > np.maximum(CLOCK_OUTLIER_S, 6.0 * 1.4826 * mad)
    return out


def align_to_gps_epochs(obs_list, solutions, ephemeris, *, names=None, interval_s: float | None = None,
                        repair_clock_jumps: bool = False) -> AlignedObs:
    """AlignedObs: every receiver's code, phase and Doppler moved to common nominal GPS epochs; clock jumps found.

    Args:
        obs_list: RinexObs per receiver.
        solutions: SppSolution per receiver over all its epochs (gnssatt.gnss.positioning.spp), or None to compute
            them here with default options. Epochs without a fix get clock/position/velocity interpolated in time
            between fixes (after removing jumps); a receiver without any fix raises ValueError.
        ephemeris: SatelliteEphemeris used for the geometry term (the same as for the SPP, preferably).
        names: receiver names (default: marker names, else 'rx0', 'rx1', ...).
        interval_s: grid spacing; default the smallest of the receivers' median tag spacings.
        repair_clock_jumps: remove detected whole-millisecond jumps from code (and phase where it jumped).
    Implements: see module docstring (derivation, error budget, jump test).
    """
    from gnssatt.gnss.positioning import spp

    if solutions is None:
        solutions = [spp(o, ephemeris) for o in obs_list]
    if names is None:
        names = [(o.header.marker_name or f"rx{i}") for i, o in enumerate(obs_list)]
        if len(set(names)) < len(names):
            names = [f"{nm}#{i}" for i, nm in enumerate(names)]
    if interval_s is None:
        steps = [np.median(np.diff(o.time - o.time[0])) for o in obs_list if len(o.time) > 1]
        interval_s = float(min(steps)) if steps else 1.0
    interval_s = float(interval_s)
    step_ms = int(round(interval_s * 1000.0))
    if step_ms <= 0 or abs(step_ms - interval_s * 1000.0) > 1e-6:
        raise ValueError(f"interval_s must be a positive whole number of milliseconds, got {interval_s}")

    per_rx = []
    events: list[ClockJumpEvent] = []
    for o, sol, name in zip(obs_list, solutions, names):
        if len(sol.clock_s) != len(o.time):
            raise ValueError(f"{name}: solution has {len(sol.clock_s)} epochs, observations {len(o.time)}")
        t_rel = o.time - o.time[0]
        reliable = _reliable_fixes(sol)
        clk_in = np.where(reliable, sol.clock_s, np.nan)
        if not np.isfinite(clk_in).any():
            raise ValueError(f"{name}: no reliable SPP fix at any epoch; cannot align")
        ev, k_cum = detect_clock_jumps(o, clk_in, name)
        # Continuous clock (jumps removed); fixes that stray from their neighbours are dropped (a clock error of
        # 100 ns moves a LEO range by 0.8 mm over the shift), then everything is interpolated in time.
        clock_cont = clk_in - k_cum * MS_S
        reliable &= ~_clock_outliers(clock_cont)
        vel = _fill_series(t_rel, np.where(reliable[:, None] & np.isfinite(sol.velocity_ecef_m_s),
                                           sol.velocity_ecef_m_s, np.nan))
        vel = np.where(np.isfinite(vel), vel, 0.0)  # no velocity at all: a static receiver is assumed
        drift = np.where(reliable & np.isfinite(sol.clock_drift_s_s), sol.clock_drift_s_s, np.nan)
        clock_cont = _fill_series(t_rel, np.where(reliable, clock_cont, np.nan), rate=_fill_series(t_rel, drift))
        clock = clock_cont + k_cum * MS_S
        pos = _fill_series(t_rel, np.where(reliable[:, None], sol.position_ecef_m, np.nan), rate=vel)
        t_true = o.time - clock  # GPS time of each sample
        # nominal epoch: whole milliseconds of GPS time rounded to the grid (two-part arithmetic, no float drift)
        ms = t_true.s * 1000 + np.round(t_true.frac * 1000.0).astype(np.int64)
        grid_ms = np.round(ms / step_ms).astype(np.int64) * step_ms
        # the grid epoch in two parts: whole seconds + fraction
        t0 = GpsTime(grid_ms // 1000, (grid_ms % 1000) / 1000.0)
        per_rx.append(dict(obs=o, name=name, clock=clock, k_cum=k_cum, pos=pos, vel=vel, t_true=t_true, t0=t0,
                           grid_ms=grid_ms, events=ev))
        events.extend(ev)

    all_ms = np.unique(np.concatenate([r["grid_ms"] for r in per_rx]))
    grid = GpsTime(all_ms // 1000, (all_ms % 1000) / 1000.0)
    sats = sorted(set().union(*[set(r["obs"].sats) for r in per_rx]))
    n, m = len(all_ms), len(sats)

    receivers = []
    for r in per_rx:
        o = r["obs"]
        idx = np.searchsorted(all_ms, r["grid_ms"])
        dup = np.zeros(len(idx), dtype=bool)
        dup[1:] = idx[1:] == idx[:-1]  # two tags on one grid epoch: keep the first, report nothing else
        rows = np.flatnonzero(~dup)
        col = np.array([sats.index(s) for s in o.sats], dtype=np.int64)
        n_codes = len(o.codes)
        values = np.full((n, m, n_codes), np.nan)
        lli = np.full((n, m, n_codes), -1, dtype=np.int8)
        ssi = np.full((n, m, n_codes), -1, dtype=np.int8)
        vals = o.values.copy()
        lam = _wavelengths(o, o.sats)  # (m_rx, n_codes)
        kinds = np.array([c[:1] for c in o.codes])
        # --- repair whole-ms jumps (kept clock made continuous) ---
        clock_kept = r["clock"].copy()
        if repair_clock_jumps and np.any(r["k_cum"]):
            phase_k = np.zeros(len(o.time), dtype=np.int64)
            for ev in r["events"]:
                ev.repaired = True
                if ev.in_phase:
                    phase_k[ev.index:] += int(round(ev.jump_s / MS_S))
            kc = r["k_cum"].astype(np.float64)
            for k_code in np.flatnonzero((kinds == "C") | (kinds == "P")):
                vals[:, :, k_code] -= (C_M_S * MS_S * kc)[:, None]
            for k_ph in np.flatnonzero(kinds == "L"):
                vals[:, :, k_ph] -= (C_M_S * MS_S * phase_k.astype(np.float64))[:, None] / lam[None, :, k_ph]
            clock_kept = clock_kept - kc * MS_S
        # --- geometry shift ---
        dt = (r["t0"] - r["t_true"])  # (n_rx,) seconds the sample is moved
        ii, jj = np.nonzero(np.isfinite(vals).any(axis=2))
        sat_ids = np.array(o.sats, dtype=object)[jj].astype(str)
        t_a = GpsTime(r["t_true"].s[ii], r["t_true"].frac[ii])
        t_b = GpsTime(r["t0"].s[ii], r["t0"].frac[ii])
        r_a = r["pos"][ii]
        v_a = r["vel"][ii]
        r_b = r_a + v_a * dt[ii][:, None]
        both_t = GpsTime.concatenate([t_a, t_b])
        G, Gd = geometry_term_m(ephemeris, np.concatenate([sat_ids, sat_ids]), np.concatenate([r_a, r_b]),
                                np.concatenate([v_a, v_a]), both_t)
        k2 = len(ii)
        dG = G[k2:] - G[:k2]
        dGd = Gd[k2:] - Gd[:k2]
        ok = np.isfinite(dG) & np.isfinite(dGd)
        shifted = np.zeros((len(o.time), len(o.sats)), dtype=bool)
        shifted[ii[ok], jj[ok]] = True
        d_code = np.zeros((len(o.time), len(o.sats)))
        d_rate = np.zeros((len(o.time), len(o.sats)))
        d_code[ii[ok], jj[ok]] = dG[ok]
        d_rate[ii[ok], jj[ok]] = dGd[ok]
        for k in range(n_codes):
            if kinds[k] in ("C", "P"):
                vals[:, :, k] += d_code
            elif kinds[k] == "L":
                vals[:, :, k] += d_code / lam[None, :, k]
            elif kinds[k] == "D":
                vals[:, :, k] -= d_rate / lam[None, :, k]
        tgt = idx[rows]
        values[tgt[:, None], col[None, :]] = vals[rows]
        lli[tgt[:, None], col[None, :]] = o.lli[rows]
        ssi[tgt[:, None], col[None, :]] = o.ssi[rows]
        present = np.zeros(n, dtype=bool)
        present[tgt] = True
        shift = np.full(n, np.nan)
        shift[tgt] = dt[rows]
        clk = np.full(n, np.nan)
        clk[tgt] = clock_kept[rows]
        posg = np.full((n, 3), np.nan)
        posg[tgt] = r["pos"][rows] + r["vel"][rows] * dt[rows][:, None]
        velg = np.full((n, 3), np.nan)
        velg[tgt] = r["vel"][rows]
        sh = np.zeros((n, m), dtype=bool)
        sh[tgt[:, None], col[None, :]] = shifted[rows]
        tag_s = grid.s.copy()
        tag_f = grid.frac.copy()
        tag_s[tgt], tag_f[tgt] = o.time.s[rows], o.time.frac[rows]
        receivers.append(AlignedReceiver(
            name=r["name"], codes=list(o.codes), values=values, lli=lli, ssi=ssi, present=present,
            time_tag=GpsTime(tag_s, tag_f), shift_s=shift, clock_s=clk, position_ecef_m=posg,
            velocity_ecef_m_s=velg, shifted=sh, obs_types=dict(o.header.obs_types), version=o.header.version))
    return AlignedObs(time=grid, interval_s=interval_s, sats=sats, receivers=receivers, events=events)
