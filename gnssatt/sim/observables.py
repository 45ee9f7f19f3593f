"""The signal model: per antenna, at its own reception time, GPS L1 C/A and L2 P(Y) code, phase, Doppler, C/N0.

For antenna a, satellite s, frequency f (lambda_f, receiver tag T in receiver time, true reception time
t = T - dt_a(T), transmission time t - tau by light-time iteration with the Sagnac rotation):

  P_f   = rho - e.pco_f + c (dt_a - dt_s + k_f TGD_s) + I_f + T_trop + B_a,f + MP^P + eps^P
  Phi_f = rho - e.pco_f + PCV_f(az, el) + c (dt_a - dt_s) - I_f + T_trop + lambda_f w
          + MP^Phi + eps^Phi + lambda_f (N_a,s,f + b_a,f + b_s,f)            [metres; written in cycles]
  D_f   = -d/dT (Phi_f without MP, noise) / lambda_f                         [Hz, RINEX sign]

rho: geometric range from the satellite (IS-GPS-200 broadcast model, truth) at transmission to the
antenna reference point (platform CoM + R_ecef_from_body (lever arm + hidden offset)) at reception;
e: unit vector antenna -> satellite; pco_f and PCV_f in the antenna frame (CONVENTIONS.md), so
e.pco = e_ant . pco_ant; k_L1 = 1, k_L2 = gamma (IS-GPS-200 20.3.3.3.3.2); I_f = 40.3 STEC / f^2 common
to all antennas of the platform (evaluated once per epoch at the CoM); w: carrier wind-up (Wu et al.
1993), unwrapped in time; N integer per arc; b fractional receiver / satellite phase biases.

Implements: light time + Sagnac (IS-GPS-200 20.3.3.4.3.4 rotation of the ECEF frame during flight);
Wu, Wu, Hajj, Bertiger, Lichten 1993 (phase wind-up, the RTKLIB `windupcorr` form); first-order
ionosphere 40.3 TEC/f^2 (code delayed, phase advanced); thin-shell mapping function; first-order
Gauss-Markov multipath; sigma ~ 1/sqrt(C/N0) thermal noise (Kaplan & Hegarty 2006, sec. 7.2).
Neglects: higher-order ionosphere, Shapiro delay, satellite antenna offsets/PCV (broadcast orbit =
phase centre), satellite yaw steering (satellite axes: z to Earth centre, y negative orbit normal),
code PCV, inter-frequency code biases beyond TGD and a receiver code bias.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from gnssatt.sim._constants import (C_M_S, F_L1_HZ, F_L2_HZ, GAMMA_L2, IONO_K_M3_S2, OMEGA_E_RAD_S,
                                   R_EARTH_M)

FREQS = {"L1": F_L1_HZ, "L2": F_L2_HZ}
PCV_AZ_STEP_DEG = 5.0
PCV_EL_STEP_DEG = 5.0
PCV_AZ_DEG = np.arange(0.0, 360.0 + PCV_AZ_STEP_DEG / 2, PCV_AZ_STEP_DEG)     # 73 nodes, 360 == 0
PCV_EL_DEG = np.arange(-90.0, 90.0 + PCV_EL_STEP_DEG / 2, PCV_EL_STEP_DEG)    # 37 nodes


# ----------------------------------------------------------------------------------------- antennas
def antenna_frame(boresight_body: np.ndarray) -> np.ndarray:
    """R_ant_from_body (3, 3): z along boresight, x = body x projected normal to z (body y if parallel)."""
    z = np.asarray(boresight_body, dtype=np.float64)
    z = z / np.linalg.norm(z)
    ref = np.array([1.0, 0.0, 0.0])
    if np.linalg.norm(np.cross(z, ref)) < 1e-9:
        ref = np.array([0.0, 1.0, 0.0])
    x = ref - z * np.dot(ref, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])


#: expected RMS (over el >= 0, solid-angle weighted, about its mean) of a pcv_grid_mm pattern per mm of its
#: peak-to-peak: 0.2327 from 4000 draws (tests/attitude/test_antenna_consider.py re-draws it)
PCV_RMS_PER_PEAK_TO_PEAK = 0.2327


def pcv_grid_mm(rng: np.random.Generator, peak_to_peak_mm: float) -> np.ndarray:
    """A smooth random PCV pattern (len(PCV_EL_DEG), len(PCV_AZ_DEG)) in mm, peak-to-peak over el >= 0 as asked.

    Low-order azimuth harmonics (m = 1..3) with elevation envelopes growing towards the horizon, plus
    an elevation-only bowl; below the antenna horizon the pattern keeps growing (x1.5 at -90 deg).
    """
    if peak_to_peak_mm <= 0:
        return np.zeros((len(PCV_EL_DEG), len(PCV_AZ_DEG)))
    az = np.radians(PCV_AZ_DEG)[None, :]
    el = np.radians(PCV_EL_DEG)[:, None]
    c = np.cos(np.clip(el, 0, None))          # 0 at zenith, 1 at horizon
    below = np.clip(-el, 0, None) / (np.pi / 2)
    env = c + 0.5 * below
    val = rng.normal(0, 1) * (1 - np.sin(np.clip(el, 0, None))) ** 2 + 0.5 * rng.normal(0, 1) * below
    for m in (1, 2, 3):
        amp = rng.normal(0, 1.0 / m)
        val = val + amp * env ** (1 + 0.5 * m) * np.cos(m * az + rng.uniform(0, 2 * np.pi))
    val = val + 0.0 * az
    upper = PCV_EL_DEG >= 0
    p2p = val[upper].max() - val[upper].min()
    val = val * (peak_to_peak_mm / p2p)
    return val - val[PCV_EL_DEG == 90.0].mean()


def bilinear_pcv_mm(grid: np.ndarray, az_deg: np.ndarray, el_deg: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of a PCV grid (PCV_EL_DEG x PCV_AZ_DEG nodes) at az in [0, 360), el in [-90, 90]."""
    a = np.mod(az_deg, 360.0) / PCV_AZ_STEP_DEG
    e = (np.clip(el_deg, -90.0, 90.0) + 90.0) / PCV_EL_STEP_DEG
    ia = np.minimum(np.floor(a).astype(np.int64), len(PCV_AZ_DEG) - 2)
    ie = np.minimum(np.floor(e).astype(np.int64), len(PCV_EL_DEG) - 2)
    fa, fe = a - ia, e - ie
    g = grid
    return ((1 - fe) * ((1 - fa) * g[ie, ia] + fa * g[ie, ia + 1])
            + fe * ((1 - fa) * g[ie + 1, ia] + fa * g[ie + 1, ia + 1]))


def gain_db(el_ant_deg: np.ndarray, horizon_loss_db: float, backlobe_db_per_deg: float) -> np.ndarray:
    """Patch-antenna gain relative to boresight: -L (theta/90)^2 above the horizon, then -slope per degree."""
    theta = 90.0 - el_ant_deg
    return np.where(theta <= 90.0, -horizon_loss_db * (theta / 90.0) ** 2,
                    -horizon_loss_db - backlobe_db_per_deg * (theta - 90.0))


# ------------------------------------------------------------------------------------------ clocks
@dataclass
class ClockModel:
    """Receiver clock dt(T) in seconds as a function of receiver time T (s since t0).

    steered: bias + amp sin(2 pi T / period + phase) (|dt| < 1 us when bias + amp < 1 us);
    free: bias + drift T, kept in (-0.5, 0.5] ms by whole 1 ms jumps (code and phase jump together
    unless `jump_in_phase` is False, then only the code and the time tags see them).
    """

    mode: str
    bias_s: float
    amp_s: float = 0.0
    period_s: float = 1800.0
    phase_rad: float = 0.0
    drift_s_s: float = 0.0
    jump_in_phase: bool = True

    def raw(self, T):
        T = np.asarray(T, dtype=np.float64)
        if self.mode == "steered":
            return self.bias_s + self.amp_s * np.sin(2 * np.pi * T / self.period_s + self.phase_rad)
        return self.bias_s + self.drift_s_s * T

    def jumps(self, T_int):
        """Whole milliseconds removed at integer epochs T_int (free-running only)."""
        if self.mode == "steered":
            return np.zeros(np.shape(T_int), dtype=np.int64)
        return np.floor(self.raw(T_int) * 1e3 + 0.5).astype(np.int64)

    def offset(self, T, k_jumps):
        return self.raw(T) - 1e-3 * k_jumps


# ------------------------------------------------------------------------------------- geometry
def light_time_geometry(const, dt_rx_true: np.ndarray, r_ant_ecef: np.ndarray, tau0=None, iters: int = 3):
    """Range and line of sight from every satellite to one antenna, light time + Sagnac.

    Args:
        const: Constellation; dt_rx_true: (n_ep,) true reception times, seconds since const.t_ref.
        r_ant_ecef: (n_ep, 3) antenna position at reception, ECEF of the reception time.
    Returns: rho_m (n_ep, n_sv), e_ecef (n_ep, n_sv, 3) antenna->satellite, dt_sv_s (n_ep, n_sv), tau_s.
    """
    n_sv = const.n
    tau = np.full((len(dt_rx_true), n_sv), 0.075) if tau0 is None else tau0.copy()
    for _ in range(iters):
        r_tx, dt_sv = const.position_clock(dt_rx_true[:, None] - tau)
        th = OMEGA_E_RAD_S * tau
        c, s = np.cos(th), np.sin(th)
        r_s = np.stack([c * r_tx[..., 0] + s * r_tx[..., 1], -s * r_tx[..., 0] + c * r_tx[..., 1],
                        r_tx[..., 2]], axis=-1)
        d = r_s - r_ant_ecef[:, None, :]
        rho = np.sqrt(np.einsum("...i,...i->...", d, d))
        tau = rho / C_M_S
    return rho, d / rho[..., None], dt_sv, tau, r_s


def earth_blocked(r_ant: np.ndarray, e: np.ndarray, rho: np.ndarray, block_height_m: float) -> np.ndarray:
    """True where the straight ray antenna -> satellite passes within R_E + h of the Earth's centre."""
    s = -np.einsum("...i,...i->...", r_ant[:, None, :], e)           # along-ray distance to closest approach
    s = np.clip(s, 0.0, rho)
    closest = r_ant[:, None, :] + e * s[..., None]
    return np.einsum("...i,...i->...", closest, closest) < (R_EARTH_M + block_height_m) ** 2


def windup_cycles(e_ecef: np.ndarray, x_r: np.ndarray, y_r: np.ndarray, x_s: np.ndarray, y_s: np.ndarray):
    """Carrier phase wind-up in cycles, unwrapped along axis 0 (epochs), first value in (-0.5, 0.5].

    Args: e_ecef (n_ep, n_sv, 3) antenna->satellite; x_r, y_r (n_ep, 3) receiver antenna x/y axes;
    x_s, y_s (n_ep, n_sv, 3) satellite body x/y axes. Implements: Wu et al. 1993 eq. (RTKLIB windupcorr).
    """
    k = -e_ecef                                                         # satellite -> receiver
    kx = np.einsum("...i,...i->...", k, x_s)
    ds = x_s - k * kx[..., None] - np.cross(k, y_s)
    kxr = np.einsum("...i,...i->...", k, x_r[:, None, :])
    dr = x_r[:, None, :] - k * kxr[..., None] + np.cross(k, np.broadcast_to(y_r[:, None, :], k.shape))
    cosp = np.einsum("...i,...i->...", ds, dr) / (np.linalg.norm(ds, axis=-1) * np.linalg.norm(dr, axis=-1))
    ph = np.arccos(np.clip(cosp, -1.0, 1.0))
    sgn = np.sign(np.einsum("...i,...i->...", k, np.cross(ds, dr)))
    ph = np.where(sgn < 0, -ph, ph)
    return np.unwrap(ph, axis=0) / (2 * np.pi)


def satellite_axes(r_sat_ecef: np.ndarray, r_sat_ecef_next: np.ndarray, dt_s: float):
    """Satellite body x, y axes (n_ep, n_sv, 3): z to the Earth's centre, y = -(r x v_inertial) unit."""
    v = (r_sat_ecef_next - r_sat_ecef) / dt_s + np.cross(np.array([0, 0, OMEGA_E_RAD_S]), r_sat_ecef)
    z = -r_sat_ecef / np.linalg.norm(r_sat_ecef, axis=-1, keepdims=True)
    h = np.cross(r_sat_ecef, v)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    return np.cross(y, z), y


# ----------------------------------------------------------------------------------- atmosphere
def ionosphere_l1_m(r_com_ecef, e_ecef, tod_s, kind: str, vtec_tecu: float, scale_height_km: float = 600.0):
    """First-order L1 ionospheric delay (m) per epoch and satellite, common to all antennas.

    Spacecraft: TEC above the platform, VTEC(h) = vtec_tecu * exp(-(h - 350 km)/H) * D(local time)
    mapped by a thin shell 400 km above the platform; rays below the local horizon get the limb term
    2 vtec_tecu exp(-(h_tangent - 350 km)/H) added (they cross the dense layer twice).
    Terrestrial: vtec_tecu * D(local time) with the single-layer mapping at 350 km.
    D = 0.35 + 0.65 max(0, cos(2 pi (LT - 14 h)/24 h)). Returns 40.3 TEC / f_L1^2 in m (L2: x gamma).
    """
    r = np.linalg.norm(r_com_ecef, axis=-1)                               # (n_ep,)
    up = r_com_ecef / r[:, None]
    sin_el = np.einsum("...i,...i->...", e_ecef, up[:, None, :])           # local-horizon elevation
    lon = np.arctan2(r_com_ecef[:, 1], r_com_ecef[:, 0])
    lt_h = np.mod(tod_s / 3600.0 + np.degrees(lon) / 15.0, 24.0)
    diurnal = 0.35 + 0.65 * np.maximum(0.0, np.cos(2 * np.pi * (lt_h - 14.0) / 24.0))
    cos_el = np.sqrt(np.clip(1 - sin_el ** 2, 0, 1))
    if kind == "spacecraft":
        h_km = (r - R_EARTH_M) / 1e3
        vtec = vtec_tecu * np.exp(-(h_km - 350.0) / scale_height_km) * diurnal
        shell = r + 400e3
        mapping = 1.0 / np.sqrt(1 - (r[:, None] * np.where(sin_el > 0, cos_el, 1.0) / shell[:, None]) ** 2)
        stec = vtec[:, None] * mapping
        h_t_km = (r[:, None] * cos_el - R_EARTH_M) / 1e3
        limb = 2 * vtec_tecu * diurnal[:, None] * np.exp(-np.clip(h_t_km - 350.0, 0, None) / scale_height_km)
        stec = stec + np.where(sin_el < 0, limb, 0.0)
    else:
        shell = R_EARTH_M + 350e3
        mapping = 1.0 / np.sqrt(1 - (R_EARTH_M * cos_el / shell) ** 2)
        stec = (vtec_tecu * diurnal)[:, None] * mapping
    return IONO_K_M3_S2 * stec * 1e16 / F_L1_HZ ** 2, sin_el


def troposphere_m(sin_el: np.ndarray, zenith_delay_m: float) -> np.ndarray:
    """Slant tropospheric delay (m): zenith delay x 1 / sin(sqrt(el^2 + (2.5 deg)^2)) (simple mapping)."""
    el = np.arcsin(np.clip(sin_el, -1, 1))
    return zenith_delay_m / np.sin(np.sqrt(np.clip(el, 0, None) ** 2 + np.radians(2.5) ** 2))


# ------------------------------------------------------------------------------------ stochastics
def gauss_markov(rng: np.random.Generator, n_ep: int, n_sv: int, dt_s: float, tau_s: float) -> np.ndarray:
    """Unit-variance first-order Gauss-Markov sequences (n_ep, n_sv) along axis 0, stationary from the start."""
    phi = np.exp(-dt_s / tau_s)
    w = rng.standard_normal((n_ep, n_sv))
    x0 = w[0].copy()
    w[0] = 0.0
    y, _ = lfilter([np.sqrt(1 - phi * phi)], [1.0, -phi], w, axis=0, zi=(phi * x0)[None, :])
    y[0] = x0
    return y


def horizon_growth(el_ant_deg: np.ndarray, zenith: float, horizon: float, cap: float) -> np.ndarray:
    """Multipath sigma growing from `zenith` at el 90 to `horizon` at el 0 and on below, capped at `cap`."""
    x = (90.0 - el_ant_deg) / 90.0
    return np.minimum(zenith + (horizon - zenith) * x ** 2, cap)


# ------------------------------------------------------------------------------------- tracking
@dataclass
class TrackingConfig:
    n_channels: int = 12
    acq_l1_dbhz: float = 32.0
    trk_l1_dbhz: float = 27.0
    acq_l2_dbhz: float = 27.0
    trk_l2_dbhz: float = 22.0
    acq_delay_l1_s: tuple = (0.0, 0.0)
    acq_delay_l2_s: tuple = (0.0, 0.0)


def track(cn0_l1: np.ndarray, cn0_l2: np.ndarray | None, outage: np.ndarray, dt_s: float, cfg: TrackingConfig,
          rng: np.random.Generator):
    """Tracked masks (n_ep, n_sv) for L1 and L2 from a 12-channel receiver model.

    Channels are assigned to the strongest acquirable satellites; acquisition takes a random delay;
    a signal below its tracking threshold is lost; L2 P(Y) is acquired only while L1 tracks (after its
    own delay) and lost below its threshold; an outage drops every channel. cn0 NaN = not visible.
    """
    n_ep, n_sv = cn0_l1.shape
    d1 = rng.uniform(*cfg.acq_delay_l1_s, size=(n_ep, n_sv))
    d2 = rng.uniform(*cfg.acq_delay_l2_s, size=(n_ep, n_sv))
    c1 = np.nan_to_num(cn0_l1, nan=-99.0)
    c2 = np.nan_to_num(cn0_l2, nan=-99.0) if cn0_l2 is not None else np.full_like(c1, -99.0)
    st1 = np.zeros(n_sv, np.int8)
    st2 = np.zeros(n_sv, np.int8)
    t1 = np.zeros(n_sv)
    t2 = np.zeros(n_sv)
    trk1 = np.zeros((n_ep, n_sv), bool)
    trk2 = np.zeros((n_ep, n_sv), bool)
    order_cache = np.arange(n_sv)
    for k in range(n_ep):
        if outage[k]:
            st1[:] = 0
            st2[:] = 0
            continue
        a1, a2 = c1[k], c2[k]
        ok1 = a1 >= cfg.trk_l1_dbhz
        st1[~ok1] = 0
        acq = st1 == 1
        t1[acq] -= dt_s
        st1[acq & (t1 <= 1e-9)] = 2
        free = cfg.n_channels - int(np.count_nonzero(st1))
        if free > 0:
            cand = (st1 == 0) & (a1 >= cfg.acq_l1_dbhz)
            if cand.any():
                idx = order_cache[cand]
                idx = idx[np.argsort(-a1[idx], kind="stable")][:free]
                t1[idx] = d1[k, idx]
                st1[idx] = np.where(d1[k, idx] <= 1e-9, 2, 1)
        on1 = st1 == 2
        st2[~on1 | (a2 < cfg.trk_l2_dbhz)] = 0
        acq2 = st2 == 1
        t2[acq2] -= dt_s
        st2[acq2 & (t2 <= 1e-9)] = 2
        new2 = (st2 == 0) & on1 & (a2 >= cfg.acq_l2_dbhz)
        if new2.any():
            t2[new2] = d2[k, new2]
            st2[new2] = np.where(d2[k, new2] <= 1e-9, 2, 1)
        trk1[k] = on1
        trk2[k] = st2 == 2
    return trk1, trk2


def poisson_windows(rng, n_ep: int, dt_s: float, rate_per_hour: float, length_s: tuple) -> np.ndarray:
    """Boolean (n_ep,) mask of random windows (Poisson starts at `rate_per_hour`, uniform lengths)."""
    mask = np.zeros(n_ep, bool)
    if rate_per_hour <= 0:
        return mask
    starts = np.nonzero(rng.random(n_ep) < rate_per_hour * dt_s / 3600.0)[0]
    lens = rng.uniform(*length_s, size=len(starts))
    for s, ln in zip(starts, lens):
        mask[s: s + max(1, int(round(ln / dt_s)))] = True
    return mask


@dataclass
class Arcs:
    """Ambiguity arcs of one antenna and frequency: arc index per (epoch, sat) (-1 untracked) and per-arc data."""

    arc_id: np.ndarray                  # (n_ep, n_sv) int, -1 where not tracked
    sat: list = field(default_factory=list)
    start: list = field(default_factory=list)
    end: list = field(default_factory=list)
    cause: list = field(default_factory=list)       # 'acquisition' | 'slip'
    lli: list = field(default_factory=list)         # LLI bit 0 set on the first epoch
    n_cyc: list = field(default_factory=list)


def build_arcs(tracked: np.ndarray, slip: np.ndarray, slip_lli: np.ndarray) -> Arcs:
    """Arcs from a tracked mask and slip events (slip only where tracked and not an arc start)."""
    prev = np.vstack([np.zeros((1, tracked.shape[1]), bool), tracked[:-1]])
    start_acq = tracked & ~prev
    start_slip = tracked & prev & slip
    starts = start_acq | start_slip
    arc_id = np.full(tracked.shape, -1, np.int64)
    arcs = Arcs(arc_id)
    counter = 0
    for s in range(tracked.shape[1]):
        col_start = np.nonzero(starts[:, s])[0]
        if len(col_start) == 0:
            continue
        ends = np.append(col_start[1:], tracked.shape[0])
        for a, b in zip(col_start, ends):
            run = tracked[a:b, s]
            last = a + (np.argmin(run) if not run.all() else len(run)) - 1
            arc_id[a: last + 1, s] = counter
            arcs.sat.append(s)
            arcs.start.append(int(a))
            arcs.end.append(int(last))
            is_slip = bool(start_slip[a, s])
            arcs.cause.append("slip" if is_slip else "acquisition")
            arcs.lli.append(bool(slip_lli[a, s]) if is_slip else True)
            counter += 1
    return arcs


def noise_scale(cn0: np.ndarray, ref_dbhz: float, grows: bool, max_scale: float = 4.0) -> np.ndarray:
    """Thermal-noise scale 10^((ref - C/N0)/20) (sigma ~ 1/sqrt(C/N0)), 1 where `grows` is False.

    Clipped to [0.5, max_scale]: a PLL/DLL near its tracking threshold is lost rather than noisier (the tracking
    thresholds end the growth; 4 = 12 dB below the reference C/N0).
    """
    if not grows:
        return np.ones_like(cn0)
    return np.clip(10.0 ** ((ref_dbhz - np.nan_to_num(cn0, nan=ref_dbhz)) / 20.0), 0.5, max_scale)


__all__ = ["antenna_frame", "pcv_grid_mm", "bilinear_pcv_mm", "gain_db", "ClockModel", "light_time_geometry",
           "earth_blocked", "windup_cycles", "satellite_axes", "ionosphere_l1_m", "troposphere_m", "gauss_markov",
           "horizon_growth", "TrackingConfig", "track", "poisson_windows", "Arcs", "build_arcs", "noise_scale",
           "FREQS", "GAMMA_L2", "PCV_AZ_DEG", "PCV_EL_DEG"]
