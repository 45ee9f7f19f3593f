"""Single point positioning (SPP) of one receiver per epoch from code, with RAIM, and velocity from Doppler.

Public API:
    spp(obs, ephemeris, options=SppOptions(...), *, epochs=None) -> SppSolution
    klobuchar_l1_delay_s(...), saastamoinen_delay_m(...)  (the two atmosphere models, also used by others)

Model per epoch k and satellite s (ionosphere-free P1/P2 where both bands exist, else single frequency):
    P = |R3(omega tau) r_sat(t_tx) - r_rx| + c dt_rx - c dt_sv(t_tx) + T + I + e
- t_tx (GPS time of emission) comes from the pseudorange itself: t_tx = T_tag - P / c - dt_sv (the satellite
  time of emission is the receiver tag minus the pseudorange over c, whatever the receiver clock; RTKLIB
  `satposs`), so the satellite state does not depend on the unknown receiver clock and needs no iteration on it.
- R3(omega tau): Earth rotation during the flight time tau = rho / c (Sagnac; gnssatt.gnss.geometry.sagnac_rotate).
- dt_sv: `ephemeris.state` clock (ionosphere-free reference); single-frequency rows subtract the L1 group delay
  (`ephemeris.group_delay_s`, T_GD of IS-GPS-200 20.3.3.3.3.2).
- T: Saastamoinen (1972) zenith delays with a standard atmosphere and 1/cos(z) mapping, for receivers below
  10 km height; none above (spacecraft). I: 0 for the ionosphere-free combination; Klobuchar (IS-GPS-200
  20.3.3.5.2.5) from the navigation header for single-frequency rows of receivers below 100 km; none above
  (a LEO sees only the plasmasphere above it, where the ground model does not apply).
- Unknowns per epoch: position (3), receiver clock c dt_rx (1), plus one inter-system bias per extra system.
  The receiver position is that of the reception time t_rx = T_tag - dt_rx (GPS time), reported as `time`.
- Weighted least squares by Gauss-Newton, batched over all epochs at once (normal equations by einsum over
  epochs, one batched solve). Variance of a row: f sigma_code^2 q / N + sigma_ure^2 (orbit/clock error), with
  q = g1^2 q1 + g2^2 q2 for the ionosphere-free combination (g1 = 2.546, g2 = 1.546) or q1 for one signal, and
  * weighting "cn0" (default when the file has signal-strength digits): q_i = 10^(-(C/N0_i - 51 dB-Hz) / 10)
    from the RINEX signal-strength digit d (C/N0 ~ 6 d + 3 dB-Hz, RINEX 3.04 Table 8): the SIGMA-epsilon model
    (Hartinger & Brunner 1999; Wieser & Brunner 2000) -- on GRACE-A the robust code noise doubles per digit;
  * weighting "elevation": q_i = 1 + 1/sin^2(el), the elevation measured from the local horizon for ground
    receivers and from the Earth's limb for spacecraft (local elevation + horizon dip);
  N the number of samples in the Hatch filter (1 without smoothing), and f one a-posteriori variance factor for
  the whole batch (median over the epochs with redundancy of v'Wv over its chi-square median; `calibrate_variance`)
  so that the RAIM test is calibrated to the receiver actually used.
- Gross-error screen first: P1 vs C1 > 30 m apart drops the satellite; P2 - P1 outside [-30, 100] m drops P2.
- RAIM: global test T = v' W v against the chi-square quantile (false alarm `raim_false_alarm`, dof n - m);
  an epoch that fails excludes the satellite with the largest standardised residual |v| / sqrt(var (1 - h))
  (h: leverage, diagonal of the hat matrix) and is solved again, up to `raim_max_exclusions` times; an epoch
  that still fails, or has no redundancy to test, is flagged (Brown 1992, "A baseline GPS RAIM scheme";
  Kaplan & Hegarty 3rd ed. sec. 8.2; the same chi-square test as RTKLIB `valsol`).
- Arc screening (`arc_screening`): a satellite arc (consecutive epochs) that RAIM excluded at half or more of its
  fixes (3 at least) is excluded whole and the batch solved again: a tracking channel's code bias lasts as long as
  the channel tracks (GRACE-A shows whole passes 15-80 m off), and the epochs whose geometry cannot expose it
  (5-6 satellites, no redundancy to identify) otherwise take it in full.
- Velocity and clock drift: linear least squares on range rates -lambda D (Doppler) with the satellite velocity
  and clock rate, Sagnac term included (RTKLIB `resdop`), same satellites as the position, with a chi-square
  exclusion of one satellite at a time. Without Doppler in the file, range rates come from the central
  difference of carrier phase (lambda (L(k+1) - L(k-1)) / (T(k+1) - T(k-1))) on arcs without loss of lock, and
  `velocity_source` says so (at a 10 s interval this errs by range jerk x dt^2 / 6, measured in the tests).
Implements: IS-GPS-200N sec. 20.3.3.3.3.2-3 (T_GD, ionosphere-free L1/L2), 20.3.3.5.2.5 (Klobuchar),
20.3.3.4.3.4 (Earth rotation correction); Saastamoinen (1972) with the standard atmosphere of RTKLIB `tropmodel`;
Brown (1992) RAIM.
Neglects: P1-C1 differential code biases (a C1 + P2 combination keeps them, < 1 m), the Shapiro delay (< 2 cm),
solid Earth tides, the receiver antenna offset (positions are of the antenna phase centre the code sees), GLONASS
phase (its code is used: ionosphere-free with the 9/7 FDMA coefficients, its own inter-system bias; the
Klobuchar delay of single-frequency GLONASS rows is the GPS L1 one, not scaled to the channel's frequency).
(Satellite antenna offsets of SP3 orbits are the ephemeris' business: gnssatt.gnss.ephemeris.PreciseEphemeris.)
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from gnssatt.gnss.constants import C_M_S, OMEGA_EARTH_RAD_S, PI_GPS
from gnssatt.gnss.frames import R_enu_from_ecef, ecef_to_geodetic
from gnssatt.gnss.geometry import sagnac_rotate
from gnssatt.gnss.signals import FREQ_BY_SYSTEM_BAND_HZ, FREQ_GPS_L1_HZ, FREQ_GPS_L2_HZ
from gnssatt.gnss.time import GpsTime

__all__ = ["SppSolution", "SppOptions", "spp", "klobuchar_l1_delay_s", "saastamoinen_delay_m", "select_code",
           "FLAG_OK", "FLAG_TOO_FEW", "FLAG_NOT_CONVERGED", "FLAG_RAIM_FAILED", "FLAG_RAIM_UNTESTED",
           "FLAG_HIGH_PDOP", "FLAG_NO_VELOCITY", "CODE_PREFERENCE"]

# --- epoch flags (bit field) ------------------------------------------------------------------------
FLAG_OK = 0
FLAG_TOO_FEW = 1            # fewer usable satellites than unknowns: no solution (NaN)
FLAG_NOT_CONVERGED = 2      # Gauss-Newton did not converge (NaN)
FLAG_RAIM_FAILED = 4        # the chi-square test still fails after the allowed exclusions (solution kept)
FLAG_RAIM_UNTESTED = 8      # no redundancy (n == unknowns): nothing could be tested (solution kept)
FLAG_HIGH_PDOP = 16         # PDOP above max_pdop (solution kept)
FLAG_NO_VELOCITY = 32       # no velocity / drift (no Doppler or phase rate at this epoch)

#: Code signals tried in order for each band (RINEX 3 codes; RINEX 2 P1/C1/P2 map to C1W/C1C/C2W): the P(Y)
#: code first, because the broadcast clock and T_GD and the IGS clocks refer to P1/P2.
CODE_PREFERENCE = {
    ("G", 1): ("C1W", "C1P", "C1C", "C1X", "C1L", "C1S"),
    ("G", 2): ("C2W", "C2P", "C2L", "C2X", "C2S", "C2C", "C2D"),
    ("J", 1): ("C1C", "C1X", "C1L", "C1S"),
    ("J", 2): ("C2L", "C2X", "C2S"),
    ("R", 1): ("C1P", "C1C"),          # GLONASS FDMA G1 / G2 (code only: no phase smoothing, no Doppler velocity)
    ("R", 2): ("C2P", "C2C"),
}
DOPPLER_PREFERENCE = {"G": ("D1C", "D1W", "D1P", "D1X"), "J": ("D1C", "D1X")}
PHASE_PREFERENCE = {"G": ("L1C", "L1W", "L1P", "L1X"), "J": ("L1C", "L1X")}
PHASE_PREFERENCE_BAND = {
    ("G", 1): ("L1W", "L1P", "L1C", "L1X", "L1L", "L1S"),
    ("G", 2): ("L2W", "L2P", "L2L", "L2X", "L2S", "L2C", "L2D"),
    ("J", 1): ("L1C", "L1X", "L1L", "L1S"),
    ("J", 2): ("L2L", "L2X", "L2S"),
}
#: Geometry-free phase slip test for the smoother: |second difference of lambda1 L1 - lambda2 L2| above this
#: (m) is a slip. A one-cycle L1 slip moves it by 0.19 m; the ionosphere's second difference stays at cm level
#: even for a LEO at 10 s (measured on GRACE-A: 99.9 % below 0.05 m).
GF_SLIP_M = 0.10
#: The smoother restarts when the code departs from its phase-propagated prediction by more than this (m):
#: ~10 sigma of the ionosphere-free code noise; catches gross slips and code-only 1 ms clock jumps (300 km).
SMOOTH_RESET_M = 20.0
#: carrier frequency of each (system, band number) of the code/phase preferences (gnssatt.gnss.signals)
BAND_FREQ_HZ = {(s, b): FREQ_BY_SYSTEM_BAND_HZ[(s, str(b))] for s, b in CODE_PREFERENCE if s != "R"}
#: GLONASS FDMA: f1 / f2 = 9 / 7 on every channel (GLONASS ICD 5.1 sec. 3.3.1.4), so one pair of ionosphere-free
#: coefficients for all its satellites: g1 = 81 / 32, g2 = 49 / 32.
_IF_COEFFS = {"R": (81.0 / 32.0, 49.0 / 32.0)}

#: Noise gain of the L1/L2 ionosphere-free combination: sqrt(g1^2 + g2^2), g1 = f1^2/(f1^2-f2^2) = 2.546.
_G1 = FREQ_GPS_L1_HZ ** 2 / (FREQ_GPS_L1_HZ ** 2 - FREQ_GPS_L2_HZ ** 2)
_G2 = FREQ_GPS_L2_HZ ** 2 / (FREQ_GPS_L1_HZ ** 2 - FREQ_GPS_L2_HZ ** 2)
IF_NOISE_GAIN = float(np.hypot(_G1, _G2))  # 2.98

#: Receivers above this ellipsoidal height get no troposphere and no Klobuchar and no elevation mask/weighting:
#: the neutral atmosphere ends well below, and a LEO's "elevation" is not a path length through air.
SPACEBORNE_HEIGHT_M = 100e3
#: Saastamoinen with a standard atmosphere is defined up to 10 km (RTKLIB tropmodel); above it the delay is
#: taken as 0 (< 0.4 m at zenith at 10 km... reaching 0 at the top of the troposphere).
TROPO_MAX_HEIGHT_M = 10e3

#: Two band-1 codes of one satellite (P1, C1) farther apart than this (m) -> the satellite is not used at that
#: epoch: their true difference is a differential code bias of < 10 ns (3 m) plus noise.
CODE_CONSISTENCY_M = 30.0
#: P2 - P1 (m) equals 0.65 x the L1 ionospheric delay plus a few metres of bias: outside this range the band-2 code
#: is not locked and the row falls back to single frequency. 100 m is a solar-maximum low-elevation ground delay.
GF_CODE_RANGE_M = (-30.0, 100.0)

#: C/N0 (dB-Hz) at which a code has the noise sigma_code_m under weighting="cn0"; the RINEX 3 signal-strength
#: digit d means C/N0 in [6d, 6d + 6) dB-Hz (RINEX 3.04 Table 8: 1 < 12, ..., 9 >= 54), taken as 6d + 3. RINEX 2
#: digits (1 minimum, 5 threshold of good S/N, 9 maximum; the mapping is the receiver's) are read on the same
#: scale: a different slope changes the relative weights, a different offset only the scale the batch variance
#: factor absorbs. GRACE-A (RINEX 2.10, SNR bins in V/V): the code noise doubles per digit, i.e. 6 dB.
CN0_REF_DBHZ = 51.0

#: weighting="auto" takes C/N0 weighting when at least this fraction of the band-1 codes carry a signal-strength digit.
AUTO_CN0_FRACTION = 0.9
#: Arc screening (SppOptions(arc_screening=True)): a satellite arc RAIM excluded at this fraction of its fixes, and at
#: least this many times, is excluded whole (see _arc_exclusions).
ARC_EXCLUDED_FRACTION = 0.5
ARC_MIN_EXCLUSIONS = 3
#: Bounds of the batch a-posteriori variance factor (SppOptions(calibrate_variance=True)): a code noise 10x smaller or
#: larger than assumed at most.
VARIANCE_FACTOR_RANGE = (1e-2, 1e2)

GN_MAX_ITER = 12               # from the Earth's centre a GNSS fix converges in 5-7 steps
GN_TOL_M = 1e-4                # stop when every epoch's largest correction is below 0.1 mm


@dataclass
class SppSolution:
    """Per-epoch single point positions of one receiver (n epochs, m satellites = `sats`).

    time_tag: GpsTime (n,) the receiver's epoch time tags (RINEX epochs, receiver time).
    time: GpsTime (n,) reception time in GPS time, time_tag - clock_s: the time of position_ecef_m.
    position_ecef_m (n, 3), clock_s (n,): receiver antenna position and clock offset (receiver - GPS time, s;
        GPS-system clock for multi-system solutions, whose inter-system biases are in isb_m).
    velocity_ecef_m_s (n, 3), clock_drift_s_s (n,): Earth-fixed velocity and clock drift (NaN without rates).
    n_sats (n,): satellites in the position fix; pdop, gdop (n,); chi2 (n,): v'Wv of the final fix.
    residuals_m (n, m): post-fit code residuals (NaN where not used); used (n, m): in the fix;
        excluded (n, m): removed by RAIM or the arc screening; iono_free (n, m): the row was the ionosphere-free
        combination.
    elevation_deg, azimuth_deg (n, m): in the local level frame at the solution (ground and space alike).
    covariance (n, 4, 4): formal covariance of (x, y, z, c dt) in m^2 from the a priori variances.
    flags (n,): bit field of FLAG_* values; 0 is a clean fix.
    velocity_source: 'doppler', 'phase-rate' or 'none'. isb_m: (n, k) inter-system biases for `isb_systems`.
    weighting: the row weighting used ('cn0' or 'elevation'); variance_factor: the batch a-posteriori factor the
        a-priori code variances were scaled by (1.0 without calibration); arc_excluded (n, m): cells removed by
        the arc screening (a subset of `excluded`).
    """

    sats: list[str]
    time_tag: GpsTime
    time: GpsTime
    position_ecef_m: np.ndarray
    clock_s: np.ndarray
    velocity_ecef_m_s: np.ndarray
    clock_drift_s_s: np.ndarray
    n_sats: np.ndarray
    pdop: np.ndarray
    gdop: np.ndarray
    chi2: np.ndarray
    residuals_m: np.ndarray
    used: np.ndarray
    excluded: np.ndarray
    iono_free: np.ndarray
    elevation_deg: np.ndarray
    azimuth_deg: np.ndarray
    covariance: np.ndarray
    flags: np.ndarray
    velocity_source: str = "none"
    isb_systems: list[str] = field(default_factory=list)
    isb_m: np.ndarray | None = None
    weighting: str = "elevation"
    variance_factor: float = 1.0
    arc_excluded: np.ndarray | None = None

    @property
    def valid(self) -> np.ndarray:
        """(n,) bool: epochs with a position (no FLAG_TOO_FEW / FLAG_NOT_CONVERGED)."""
        return (self.flags & (FLAG_TOO_FEW | FLAG_NOT_CONVERGED)) == 0


# --- atmosphere models ----------------------------------------------------------------------------------------

def klobuchar_l1_delay_s(alpha, beta, lat_rad, lon_rad, azimuth_rad, elevation_rad, gps_sow) -> np.ndarray:
    """Ionospheric L1 group delay (s), shape of the broadcast inputs, by the broadcast Klobuchar model.

    Args:
        alpha, beta: (4,) broadcast coefficients (s, s/semicircle, ...; RINEX ION ALPHA / BETA, GPSA / GPSB).
        lat_rad, lon_rad: receiver geodetic latitude / longitude; azimuth_rad, elevation_rad: of the satellite;
        gps_sow: GPS seconds of week (any offset by whole days works: only the time of day is used).
    Implements: IS-GPS-200N sec. 20.3.3.5.2.5 and Figure 20-4 (semicircle units, pi = PI_GPS, obliquity
    F = 1 + 16 (0.53 - E)^3, 5 ns night-time floor, x = 2 pi (t - 50400) / PER).
    Neglects: whatever the 8 coefficients cannot describe (the model removes about 50 % of the delay RMS).
    """
    a = np.asarray(alpha, dtype=np.float64)
    b = np.asarray(beta, dtype=np.float64)
    el_sc = np.asarray(elevation_rad, dtype=np.float64) / PI_GPS  # semicircles
    lat_sc = np.asarray(lat_rad, dtype=np.float64) / PI_GPS
    lon_sc = np.asarray(lon_rad, dtype=np.float64) / PI_GPS
    az = np.asarray(azimuth_rad, dtype=np.float64)
    psi = 0.0137 / (el_sc + 0.11) - 0.022  # Earth-centred angle (semicircles)
    phi_i = np.clip(lat_sc + psi * np.cos(az), -0.416, 0.416)  # ionospheric pierce point latitude
    lam_i = lon_sc + psi * np.sin(az) / np.cos(phi_i * PI_GPS)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * PI_GPS)  # geomagnetic latitude
    t = np.mod(43200.0 * lam_i + np.asarray(gps_sow, dtype=np.float64), 86400.0)  # local time (s)
    F = 1.0 + 16.0 * (0.53 - el_sc) ** 3  # obliquity factor
    amp = np.maximum(a[0] + phi_m * (a[1] + phi_m * (a[2] + phi_m * a[3])), 0.0)
    per = np.maximum(b[0] + phi_m * (b[1] + phi_m * (b[2] + phi_m * b[3])), 72000.0)
    x = 2.0 * np.pi * (t - 50400.0) / per
    day = F * (5e-9 + amp * (1.0 - x * x / 2.0 + x ** 4 / 24.0))
    return np.where(np.abs(x) < 1.57, day, F * 5e-9)


def saastamoinen_delay_m(lat_rad, h_m, elevation_rad, humidity: float = 0.7) -> np.ndarray:
    """Tropospheric slant delay (m) by Saastamoinen with a standard atmosphere, 0 above 10 km or below el 0.

    Args: geodetic latitude (rad), ellipsoidal height (m, as orthometric: the geoid is neglected), elevation
    (rad), relative humidity (0-1).
    Implements: Saastamoinen (1972) hydrostatic + wet zenith delays with 1/cos(z) mapping, the standard
    atmosphere P = 1013.25 (1 - 2.2557e-5 h)^5.2568 hPa, T = 15 - 6.5e-3 h + 273.16 K, exactly as RTKLIB
    2.4.3 `tropmodel` (rtkcmn.c).
    Neglects: the geoid undulation in h (tens of metres -> mm), real weather, the gradient terms.
    """
    lat = np.asarray(lat_rad, dtype=np.float64)
    h = np.asarray(h_m, dtype=np.float64)
    el = np.asarray(elevation_rad, dtype=np.float64)
    ok = (h >= -100.0) & (h <= TROPO_MAX_HEIGHT_M) & (el > 0.0)
    hgt = np.clip(h, 0.0, TROPO_MAX_HEIGHT_M)
    pres = 1013.25 * (1.0 - 2.2557e-5 * hgt) ** 5.2568
    temp = 15.0 - 6.5e-3 * hgt + 273.16
    e = 6.108 * humidity * np.exp((17.15 * temp - 4684.0) / (temp - 38.45))
    cos_z = np.cos(np.pi / 2.0 - np.where(ok, el, np.pi / 2.0))
    trph = 0.0022768 * pres / (1.0 - 0.00266 * np.cos(2.0 * lat) - 0.00028 * hgt / 1e3) / cos_z
    trpw = 0.002277 * (1255.0 / temp + 0.05) * e / cos_z
    return np.where(ok, trph + trpw, 0.0)


# --- observation selection ------------------------------------------------------------------------------------

def select_code(obs, system: str, candidates) -> tuple[np.ndarray, np.ndarray]:
    """(values (n_epochs, n_sats), index into `candidates` (-1 where none)): the first present code per cell.

    Satellites of other systems are NaN. `candidates` are RINEX 3 codes (RINEX 2 files are searched through
    `rinex3_code`, so 'C1W' finds P1).
    """
    n_ep, n_sat = obs.values.shape[:2]
    out = np.full((n_ep, n_sat), np.nan)
    which = np.full((n_ep, n_sat), -1, dtype=np.int64)
    for j, code in enumerate(candidates):
        try:
            v = obs.get(code, system)
        except KeyError:
            continue
        fill = np.isnan(out) & np.isfinite(v) & (v != 0.0)  # 0.000 is "no measurement" in many files
        out[fill] = v[fill]
        which[fill] = j
    return out, which


def _code_ssi(obs, system: str, candidates) -> np.ndarray:
    """(n_epochs, n_sats) signal-strength digit (1-9; 0 or -1 unknown) of the code `select_code` picks per cell."""
    n_ep, n_sat = obs.values.shape[:2]
    out = np.full((n_ep, n_sat), -1, dtype=np.int64)
    taken = np.zeros((n_ep, n_sat), dtype=bool)
    for code in candidates:
        k = obs.code_index(code, system)
        if k is None:
            continue
        v = obs.values[:, :, k]
        fill = ~taken & np.isfinite(v) & (v != 0.0)
        out[fill] = obs.ssi[:, :, k][fill]
        taken |= fill
    return out


def _phase_rate_m_s(obs, system: str, t_tag: GpsTime) -> np.ndarray:
    """(n_epochs, n_sats) range rate from the central difference of L1 phase, m/s (NaN across LLI/gaps)."""
    lam = C_M_S / FREQ_GPS_L1_HZ
    out = np.full(obs.values.shape[:2], np.nan)
    for code in PHASE_PREFERENCE.get(system, ()):
        k = obs.code_index(code, system)
        if k is None:
            continue
        phi = obs.values[:, :, k]
        lli = obs.lli[:, :, k]
        slip = (lli >= 0) & ((lli & 1) == 1)
        if len(phi) < 3:
            return out
        dt = (t_tag[2:] - t_tag[:-2])[:, None]
        rate = lam * (phi[2:] - phi[:-2]) / dt
        bad = slip[1:-1] | slip[2:]  # a slip at k or k+1 breaks the arc between k-1 and k+1
        rate = np.where(bad, np.nan, rate)
        fill = np.isnan(out[1:-1])
        out[1:-1][fill] = rate[fill]
        # Phase is -(range rate) in Doppler sign: the phase grows with range in RINEX, so the rate is +range rate.
    return out


def _arc_exclusions(present, excluded, fixed, t_tag: GpsTime) -> np.ndarray:
    """(n, m) bool: the cells of every satellite arc that RAIM excluded at most of its fixes.

    An arc is a run of consecutive epochs (no gap above 1.5 intervals) with a usable row of the satellite. An arc
    whose satellite was excluded at >= ARC_EXCLUDED_FRACTION of the arc's epochs with a fix, and at least
    ARC_MIN_EXCLUSIONS times, is excluded whole: a code bias of a tracking channel lasts as long as the channel
    tracks (on GRACE-A whole passes of 15-80 m), and the epochs whose geometry cannot expose it (5-6 satellites)
    then lose it too.
    Args: present, excluded (n, m) bool; fixed (n,) bool; t_tag (n,) epochs.
    """
    n, m = present.shape
    out = np.zeros((n, m), dtype=bool)
    if n == 0 or m == 0:
        return out
    dt = np.diff(t_tag - t_tag[0]) if n > 1 else np.zeros(0)
    step = float(np.median(dt)) if dt.size else 1.0
    cont = np.zeros((n, m), dtype=bool)
    if n > 1:
        cont[1:] = present[1:] & present[:-1] & (dt <= 1.5 * step)[:, None]
    start = present & ~cont
    arc = np.cumsum(start, axis=0) + np.arange(m)[None, :] * (n + 1)  # unique id per (satellite, arc)
    arc = np.where(present, arc, -1)
    ids = arc[present]
    uniq, inv = np.unique(ids, return_inverse=True)
    n_fix = np.bincount(inv, weights=(fixed[:, None] & present)[present].astype(float), minlength=len(uniq))
    n_exc = np.bincount(inv, weights=(excluded & present & fixed[:, None])[present].astype(float),
                        minlength=len(uniq))
    bad = (n_exc >= ARC_MIN_EXCLUSIONS) & (n_exc >= ARC_EXCLUDED_FRACTION * np.maximum(n_fix, 1))
    out[present] = bad[inv]
    return out


# --- the solver ----------------------------------------------------------------------------------------------

def _dops(N_inv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = np.diagonal(N_inv, axis1=-2, axis2=-1)
    return np.sqrt(d[..., :3].sum(-1)), np.sqrt(d[..., :4].sum(-1))


def _batch_solve(N: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, N^-1, ok) of the batched normal equations N x = b, (n, p, p) and (n, p); singular -> ok False."""
    n, p = b.shape
    cond_ok = np.ones(n, dtype=bool)
    eye = np.eye(p)
    finite = np.all(np.isfinite(N), axis=(1, 2)) & np.all(np.isfinite(b), axis=1)
    N = np.where(finite[:, None, None], N, eye)
    scale = np.sqrt(np.maximum(np.diagonal(N, axis1=1, axis2=2), 1e-300))
    Ns = N / scale[:, :, None] / scale[:, None, :]
    # Regularise the singular epochs so the batch solve succeeds; they are flagged and set to NaN by the caller.
    cond_ok &= finite & (np.linalg.cond(Ns) < 1e12)
    Ns = np.where(cond_ok[:, None, None], Ns, eye)
    Ninv_s = np.linalg.inv(Ns)
    N_inv = Ninv_s / scale[:, :, None] / scale[:, None, :]
    x = np.einsum("nij,nj->ni", N_inv, np.where(finite[:, None], b, 0.0))
    return x, N_inv, cond_ok


@dataclass(frozen=True)
class SppOptions:
    """Options of `spp` (one record instead of 18 keyword arguments); defaults are the service's.

    systems: satellite systems to use ('G', 'J'); the first is the clock reference, each other system gets an
        inter-system bias unknown (QZSS is on GPS time but its receiver biases differ).
    iono_free: use the L1/L2 ionosphere-free code combination where both bands are present (else single-frequency
        L1 everywhere); single-frequency rows are then dropped at epochs that have at least unknowns + 1
        ionosphere-free rows.
    elevation_mask_deg: local-horizon mask; default 10 deg for ground receivers and none above 100 km.
    sigma_code_m: a-priori code noise of one signal (m): at zenith (weighting "elevation") or at 51 dB-Hz
        (weighting "cn0"); with calibrate_variance it only sets the start, the batch rescales it.
    sigma_ure_m: orbit + clock error (m), default 1.0 for broadcast and 0.1 for precise ephemerides (the class
        name decides), else 1.0.
    raim_false_alarm: probability of the chi-square global test; raim_max_exclusions: satellites RAIM may remove
        per epoch. max_pdop: epochs above are flagged FLAG_HIGH_PDOP.
    initial_position_ecef_m: (3,) start of Gauss-Newton; default the header APPROX POSITION or the Earth's centre
        (which converges for ground and LEO receivers).
    klobuchar: (alpha, beta) for single-frequency ground rows; default taken from `ephemeris.nav` when it has
        klobuchar_alpha/beta; none -> no ionosphere correction (flagged nowhere; the residuals show it).
    velocity: solve velocity and clock drift (Doppler, else carrier-phase rate).
    sigma_range_rate_m_s: range-rate noise for the velocity chi-square test.
    smoothing_window_s: when given, the code (ionosphere-free and single-frequency series apart) is carrier-
        smoothed by the Hatch filter over this window (`hatch_smooth`; arcs cut at LLI, gaps, geometry-free phase
        jumps > GF_SLIP_M and code-prediction jumps > SMOOTH_RESET_M). Still one independent fix per epoch; the
        phase only filters the code noise. sigma_code_m then applies to the smoothed code. Keep the window short
        (~100 s) for single-frequency rows (the ionosphere makes code and phase diverge at 2 dI/dt); the
        ionosphere-free rows have no divergence.
    weighting: "cn0" (signal-strength digits), "elevation", or "auto" (default): "cn0" when at least 90 % of the
        band-1 codes carry a digit, else "elevation". Measured on GRACE-A (CODE, whole day, code only): 1.47 m
        RMS with "cn0" against 2.39 m with "elevation" (each with calibration and arc screening).
    smooth_variance: with smoothing, divide the code variance by the samples in the Hatch filter (a fresh arc
        keeps the raw noise, a converged one is trusted more).
    calibrate_variance: rescale the a-priori code variance by the batch a-posteriori variance factor (within
        VARIANCE_FACTOR_RANGE) and solve again. The factor is reported in `variance_factor`.
    arc_screening: exclude whole arcs RAIM excluded most of the time and solve again (module docstring); the
        cells removed are reported in `arc_excluded`.
    """

    systems: tuple[str, ...] = ("G",)
    iono_free: bool = True
    elevation_mask_deg: float | None = None
    sigma_code_m: float = 0.3
    sigma_ure_m: float | None = None
    raim_false_alarm: float = 1e-3
    raim_max_exclusions: int = 3
    max_pdop: float = 20.0
    initial_position_ecef_m: object = None
    klobuchar: tuple | None = None
    velocity: bool = True
    sigma_range_rate_m_s: float = 0.1
    smoothing_window_s: float | None = None
    weighting: str = "auto"
    smooth_variance: bool = True
    calibrate_variance: bool = True
    arc_screening: bool = True


@dataclass
class _Columns:
    """The epochs and satellite columns of `obs` that spp solves for."""

    sel: np.ndarray           # (n,) epoch indices into obs
    t_tag: GpsTime            # (n,) receiver time tags
    cols: np.ndarray          # (m,) satellite columns into obs.sats
    sats: list[str]           # (m,)
    sys_list: list[str]       # systems, clock reference first
    sys_of: np.ndarray        # (m,) system letter per column
    sys_col: np.ndarray       # (m,) inter-system bias column (-1 for the reference system)

    @property
    def n_isb(self) -> int:
        return len(self.sys_list) - 1

    def of_system(self, arr: np.ndarray, sysl: str) -> np.ndarray:
        """(n, m_sys) cells of an (n_epochs_obs, n_sats_obs) array for the selected epochs and system columns."""
        return arr[self.sel][:, self.cols[self.sys_of == sysl]]


def _columns(obs, systems, epochs) -> _Columns:
    sel = np.arange(len(obs.time)) if epochs is None else np.arange(len(obs.time))[epochs]
    sys_list = list(systems)
    sats_all = list(obs.sats)
    cols = np.array([j for j, s in enumerate(sats_all) if s[:1] in sys_list], dtype=np.int64)
    sats = [sats_all[j] for j in cols]
    sys_of = np.array([s[:1] for s in sats])
    sys_col = np.array([sys_list.index(s) - 1 for s in sys_of], dtype=np.int64)
    return _Columns(sel, obs.time[sel], cols, sats, sys_list, sys_of, sys_col)


def _band_codes(obs, c: _Columns) -> tuple[np.ndarray, np.ndarray]:
    """(P1, P2) (n, m) m: the preferred band-1 and band-2 code of each cell (CODE_PREFERENCE), NaN where none."""
    n, m = len(c.sel), len(c.cols)
    P1 = np.full((n, m), np.nan)
    P2 = np.full((n, m), np.nan)
    for sysl in c.sys_list:
        c1, _ = select_code(obs, sysl, CODE_PREFERENCE.get((sysl, 1), ()))
        c2, _ = select_code(obs, sysl, CODE_PREFERENCE.get((sysl, 2), ()))
        mk = c.sys_of == sysl
        P1[:, mk] = c.of_system(c1, sysl)
        P2[:, mk] = c.of_system(c2, sysl)
    return P1, P2


def _weighting_and_cn0(obs, c: _Columns, P1: np.ndarray, weighting: str):
    """(weighting, relative variances [q1, q2] (n, m) or None): "auto" resolved; q_i = 10^(-(C/N0_i - 51)/10).

    Implements: the SIGMA-epsilon model (Hartinger & Brunner 1999) with C/N0 ~ 6 d + 3 dB-Hz from the RINEX
    signal-strength digit d (RINEX 3.04 Table 8).
    """
    if weighting not in ("auto", "cn0", "elevation"):
        raise ValueError(f"weighting must be 'auto', 'cn0' or 'elevation', not {weighting!r}")
    n, m = P1.shape
    if weighting == "auto":
        # C/N0 weighting when the file gives a signal-strength digit for (nearly) every band-1 code it has
        have, with_digit = 0, 0
        for sysl in c.sys_list:
            mk = c.sys_of == sysl
            d1 = c.of_system(_code_ssi(obs, sysl, CODE_PREFERENCE.get((sysl, 1), ())), sysl)
            have += int(np.isfinite(P1[:, mk]).sum())
            with_digit += int((np.isfinite(P1[:, mk]) & (d1 > 0)).sum())
        weighting = "cn0" if have and with_digit >= AUTO_CN0_FRACTION * have else "elevation"
    if weighting != "cn0":
        return weighting, None
    ssi_rel = [np.ones((n, m)), np.ones((n, m))]
    for sysl in c.sys_list:
        mk = c.sys_of == sysl
        for b in (1, 2):
            d = c.of_system(_code_ssi(obs, sysl, CODE_PREFERENCE.get((sysl, b), ())), sysl)
            sub = ssi_rel[b - 1][:, mk]
            ok_ = d > 0
            sub[ok_] = 10.0 ** (-(6.0 * d[ok_] + 3.0 - CN0_REF_DBHZ) / 10.0)
            ssi_rel[b - 1][:, mk] = sub
    return weighting, ssi_rel


def _screen_codes(obs, c: _Columns, P1: np.ndarray, P2: np.ndarray) -> np.ndarray:
    """Blank codes not yet locked (in place on P1, P2); returns P2 with implausible P2 - P1 removed.

    Two band-1 codes (P1 and C1) that disagree by more than CODE_CONSISTENCY_M, or a P2 - P1 outside what the
    ionosphere can do (GF_CODE_RANGE_M), mark a code not yet locked (seen on GRACE-A at acquisition: P1 100 m
    off C1).
    """
    for sysl in c.sys_list:
        mk = c.sys_of == sysl
        vals = []
        for code in CODE_PREFERENCE.get((sysl, 1), ()):
            try:
                vals.append(c.of_system(obs.get(code, sysl), sysl))
            except KeyError:
                continue
        if len(vals) >= 2:
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN cells: no code at all
                spread = np.nanmax(vals, axis=0) - np.nanmin(vals, axis=0)
            bad = np.isfinite(spread) & (spread > CODE_CONSISTENCY_M)
            sub1, sub2 = P1[:, mk], P2[:, mk]
            sub1[bad], sub2[bad] = np.nan, np.nan
            P1[:, mk], P2[:, mk] = sub1, sub2
    gf_code = P2 - P1
    return np.where(np.isfinite(gf_code) & ((gf_code < GF_CODE_RANGE_M[0]) | (gf_code > GF_CODE_RANGE_M[1])),
                    np.nan, P2)


@dataclass
class _Codes:
    """The code observable of each cell and what it is made of."""

    P_obs: np.ndarray     # (n, m) m: ionosphere-free (smoothed) code where use_if, else band-1 (smoothed)
    P_raw: np.ndarray     # (n, m) m: a raw code, for the emission time only (10 m -> 0.1 mm of orbit)
    use_if: np.ndarray    # (n, m) bool: ionosphere-free row
    has: np.ndarray       # (n, m) bool: a row is formed
    n_smooth: np.ndarray  # (n, m) samples in the Hatch filter (1 without smoothing)


def _code_observables(obs, c: _Columns, P1: np.ndarray, P2: np.ndarray, opts: SppOptions) -> _Codes:
    """_Codes: P_IF = g1 P1 - g2 P2 (g1 = 2.546, g2 = 1.546) where both bands exist, optionally Hatch-smoothed.

    Ionosphere-free rows only, where an epoch has enough of them for a tested fix (unknowns + 1): a single-
    frequency row keeps the ionospheric delay (metres; for a spacecraft nothing models it), which biases the fix
    more than the lost geometry costs. Epochs short of IF rows keep their single-frequency rows.
    """
    n, m = P1.shape
    use_if = np.isfinite(P1) & np.isfinite(P2) if opts.iono_free else np.zeros((n, m), dtype=bool)
    g1 = np.array([_IF_COEFFS.get(x, (_G1, _G2))[0] for x in c.sys_of]) if len(c.sys_of) else np.zeros(0)
    g2 = np.array([_IF_COEFFS.get(x, (_G1, _G2))[1] for x in c.sys_of]) if len(c.sys_of) else np.zeros(0)
    P_if = g1[None, :] * P1 - g2[None, :] * P2
    n_smooth = np.ones((n, m))
    if opts.smoothing_window_s is not None:
        P1s, P_ifs, n_smooth = _smoothed_codes(obs, c, P1, P_if, use_if, float(opts.smoothing_window_s))
    else:
        P1s, P_ifs = P1, P_if
    P_raw = np.where(np.isfinite(P1), P1, P2)
    has = np.isfinite(P1) | use_if
    if opts.iono_free:
        n_if = use_if.sum(axis=1)
        has = np.where((n_if >= 4 + c.n_isb + 1)[:, None], use_if, has)
    return _Codes(np.where(use_if, P_ifs, P1s), P_raw, use_if, has, n_smooth)


@dataclass
class _SatStates:
    """Satellite states at emission and the clock-corrected code of each cell."""

    r_sat: np.ndarray     # (n, m, 3) m, ECEF of emission time
    v_sat: np.ndarray     # (n, m, 3) m/s
    clk_rate: np.ndarray  # (n, m) s/s
    single: np.ndarray    # (n, m) bool: single-frequency row
    P_corr: np.ndarray    # (n, m) m: P + c (dt_sv - T_GD on single-frequency rows)
    avail: np.ndarray     # (n, m) bool: usable row


def _satellite_states(ephemeris, c: _Columns, codes: _Codes) -> _SatStates:
    """_SatStates at t_tx = T_tag - P/c - dt_sv (two passes for dt_sv; RTKLIB `satposs`).

    Implements: IS-GPS-200 20.3.3.3.3.2 (single-frequency users subtract T_GD from the satellite clock).
    """
    t_tag, has, use_if = c.t_tag, codes.has, codes.use_if
    n, m = has.shape
    ii, jj = np.nonzero(has)
    sat_ids = np.array(c.sats, dtype=object)[jj].astype(str) if ii.size else np.array([], dtype=str)
    t_tx = GpsTime(t_tag.s[ii], t_tag.frac[ii]) - codes.P_raw[ii, jj] / C_M_S
    st = ephemeris.state(sat_ids, t_tx)
    t_tx = t_tx - np.nan_to_num(st.clock_s)
    st = ephemeris.state(sat_ids, t_tx)
    r_sat = np.full((n, m, 3), np.nan)
    v_sat = np.full((n, m, 3), np.nan)
    clk_sv = np.full((n, m), np.nan)
    clk_rate = np.full((n, m), np.nan)
    r_sat[ii, jj], v_sat[ii, jj], clk_sv[ii, jj], clk_rate[ii, jj] = (st.r_ecef_m, st.v_ecef_m_s, st.clock_s,
                                                                       st.clock_rate_s_s)
    tgd = np.zeros((n, m))
    single = has & ~use_if
    if np.any(single):
        si, sj = np.nonzero(single)
        g = ephemeris.group_delay_s(np.array(c.sats, dtype=object)[sj].astype(str),
                                    GpsTime(t_tag.s[si], t_tag.frac[si]))
        tgd[si, sj] = np.nan_to_num(g)
    # P + c dt_sv(L1 user) ; the L1 user's clock is dt_sv - T_GD
    P_corr = codes.P_obs + C_M_S * (clk_sv - np.where(single, tgd, 0.0))
    avail = has & np.isfinite(P_corr) & np.all(np.isfinite(r_sat), axis=-1)
    return _SatStates(r_sat, v_sat, clk_rate, single, P_corr, avail)


def _a_priori_variance(codes: _Codes, ssi_rel, weighting: str, opts: SppOptions) -> np.ndarray:
    """(n, m) m^2: sigma_code^2 q / N before elevation weighting, q = g1^2 q1 + g2^2 q2 (IF) or q1 (module doc)."""
    use_if = codes.use_if
    if weighting == "cn0":
        rel1, rel2 = ssi_rel[0], ssi_rel[1]
        var0 = opts.sigma_code_m ** 2 * np.where(use_if, _G1 ** 2 * rel1 + _G2 ** 2 * rel2, rel1)
    else:
        var0 = opts.sigma_code_m ** 2 * np.where(use_if, IF_NOISE_GAIN ** 2, 1.0)
    if opts.smooth_variance:
        var0 = var0 / codes.n_smooth
    return var0


def _klobuchar_of(ephemeris, klobuchar):
    """(alpha, beta) given, else those of `ephemeris.nav`, else None."""
    if klobuchar is not None:
        return klobuchar
    nav = getattr(ephemeris, "nav", None)
    a_ = getattr(nav, "klobuchar_alpha", None)
    b_ = getattr(nav, "klobuchar_beta", None)
    return (a_, b_) if a_ is not None and b_ is not None else None


class _SppProblem:
    """The batched WLS problem of one receiver: the measurement model, Gauss-Newton and RAIM over all epochs.

    Implements: the module docstring's model (Sagnac, Saastamoinen below TROPO_MAX_HEIGHT_M, Klobuchar for
    single-frequency ground rows), RAIM by the chi-square global test and the largest standardised residual.
    """

    def __init__(self, c: _Columns, sat: _SatStates, var0: np.ndarray, weighting: str, klobuchar, sigma_ure_m: float,
                 opts: SppOptions):
        self.c, self.sat, self.var0, self.weighting = c, sat, var0, weighting
        self.klobuchar, self.sigma_ure_m, self.opts = klobuchar, sigma_ure_m, opts
        self.n_isb = c.n_isb
        self.p = 4 + self.n_isb
        _, self.sow = c.t_tag.week_sow()
        # A weak prior (sigma 1 km) on each inter-system bias keeps an epoch without satellites of that system
        # solvable.
        self.isb_prior = np.zeros((self.p, self.p))
        for k in range(self.n_isb):
            self.isb_prior[4 + k, 4 + k] = 1e-6

    def mask_deg(self, ground):
        if self.opts.elevation_mask_deg is not None:
            return np.where(ground, self.opts.elevation_mask_deg, -90.0)
        return np.where(ground, 10.0, -90.0)

    def model(self, xk, rows_mask):
        """(residual v, design H, variance var, elevation, azimuth, ground) for the epochs `rows_mask` at xk."""
        sys_col, n_isb, p, klobuchar = self.c.sys_col, self.n_isb, self.p, self.klobuchar
        r_sat = self.sat.r_sat
        r_rx = xk[:, :3]
        d0 = r_sat[rows_mask] - r_rx[:, None, :]
        tau = np.linalg.norm(d0, axis=-1) / C_M_S
        rs = sagnac_rotate(r_sat[rows_mask], tau)
        d = rs - r_rx[:, None, :]
        rho = np.linalg.norm(d, axis=-1)
        e = d / rho[..., None]
        lat, lon, h = ecef_to_geodetic(r_rx)
        R = R_enu_from_ecef(lat, lon)  # (k, 3, 3)
        enu = np.einsum("kij,ksj->ksi", R, e)
        el = np.arcsin(np.clip(enu[..., 2], -1.0, 1.0))
        az = np.mod(np.arctan2(enu[..., 0], enu[..., 1]), 2 * np.pi)
        ground = (h < SPACEBORNE_HEIGHT_M)[:, None]
        trop = np.where(ground, saastamoinen_delay_m(lat[:, None], h[:, None], el), 0.0)
        iono = np.zeros_like(rho)
        if klobuchar is not None:
            sgl = self.sat.single[rows_mask]
            kl = klobuchar_l1_delay_s(klobuchar[0], klobuchar[1], lat[:, None], lon[:, None], az, el,
                                      self.sow[rows_mask][:, None]) * C_M_S
            iono = np.where(ground & sgl & (el > 0), kl, 0.0)
        cdt = xk[:, 3:4]
        isb = np.zeros_like(rho)
        if n_isb:
            for k in range(n_isb):
                isb = isb + np.where(sys_col[None, :] == k, xk[:, 4 + k][:, None], 0.0)
        v = self.sat.P_corr[rows_mask] - (rho + cdt + isb + trop + iono)
        H = np.zeros(rho.shape + (p,))
        H[..., :3] = -e
        H[..., 3] = 1.0
        for k in range(n_isb):
            H[..., 4 + k] = (sys_col[None, :] == k)
        H = np.where(np.isfinite(H), H, 0.0)  # rows without a satellite state get zero weight anyway
        # Elevation weighting. Ground: above the local horizon. Spacecraft: above the Earth's limb, which lies
        # dip = arccos(R / (R + h)) below the local horizontal (21 deg at 450 km): signals grazing the limb are
        # weak and noisy (GRACE-A P1/P2: median |residual| 2.4 m below 0 deg local elevation, 0.6 m above 40 deg).
        dip = np.arccos(np.clip(6371e3 / (6371e3 + np.maximum(h, 0.0)), -1.0, 1.0))
        el_w = np.where(ground, el, el + dip[:, None])
        sin_el = np.maximum(np.sin(el_w), np.sin(np.radians(5.0)))
        el_factor = (1.0 + 1.0 / sin_el ** 2) if self.weighting != "cn0" else 1.0
        var = self.var0[rows_mask] * el_factor + self.sigma_ure_m ** 2
        return v, H, var, el, az, ground

    def n_unknowns(self, u: np.ndarray) -> np.ndarray:
        """(k,) position + clock + one bias per extra system that has a row in `u` (k, m)."""
        sys_col = self.c.sys_col
        return 4 + np.sum([np.any(u & (sys_col[None, :] == k), axis=1) for k in range(self.n_isb)], axis=0)

    def gauss_newton(self, rows, xk, usek):
        """Iterate the batched WLS on epochs `rows` (index array) from xk; returns x, N_inv, ok, converged.

        Epochs leave the iteration once converged (or singular): later iterations solve only the others.
        """
        p = self.p
        xk = np.array(xk, dtype=np.float64, copy=True)
        conv = np.zeros(len(rows), dtype=bool)
        N_inv = np.zeros((len(rows), p, p))
        ok = np.ones(len(rows), dtype=bool)
        act = np.arange(len(rows))
        for it in range(GN_MAX_ITER):
            v, H, var, el, az, ground = self.model(xk[act], rows[act])
            u = usek[act].copy()
            if it >= 1:  # the elevation mask needs a position first
                u &= ~(ground & (el < np.radians(self.mask_deg(ground))))
            w = np.where(u, 1.0 / var, 0.0)
            v0 = np.where(u, v, 0.0)
            N = np.einsum("ksi,ks,ksj->kij", H, w, H) + self.isb_prior
            b = np.einsum("ksi,ks,ks->ki", H, w, v0)
            enough = u.sum(1) >= self.n_unknowns(u)
            dx, N_inv_a, ok_a = _batch_solve(N, b)
            ok_a &= enough
            dx = np.where(ok_a[:, None], dx, 0.0)
            xk[act] += dx
            N_inv[act], ok[act] = N_inv_a, ok_a
            conv[act] = np.max(np.abs(dx[:, :4]), axis=1) < GN_TOL_M
            act = act[~(conv[act] | ~ok[act])]
            if act.size == 0:
                break
        return xk, N_inv, ok, conv

    def solve_with_raim(self, x, use, excluded):
        """Batched Gauss-Newton + RAIM exclusion loop over all epochs; updates use/excluded in place.

        Returns (x, N_inv, ok, conv, T, dof): T = v'Wv, dof = rows - unknowns.
        """
        from scipy.stats import chi2 as chi2_dist

        opts, p = self.opts, self.p
        n = len(x)
        rows = np.arange(n)
        x, N_inv_all, ok, conv = self.gauss_newton(rows, x, use)
        T = np.zeros(n)
        dof = np.zeros(n, dtype=np.int64)
        idx = rows  # epochs whose test statistic is (re)computed this round: all, then the re-solved ones
        # --- RAIM loop: re-solve failing epochs without their worst satellite ---
        for _round in range(opts.raim_max_exclusions + 1):
            v, H, var, el, az, ground = self.model(x[idx], idx)
            u = use[idx] & ~(ground & (el < np.radians(self.mask_deg(ground))))
            w = np.where(u, 1.0 / var, 0.0)
            T[idx] = np.einsum("ks,ks->k", w, np.where(u, v, 0.0) ** 2)
            dof[idx] = u.sum(1) - p
            d_i = dof[idx]
            thr = np.where(d_i > 0, chi2_dist.ppf(1.0 - opts.raim_false_alarm, np.maximum(d_i, 1)), np.inf)
            fail = ok[idx] & conv[idx] & (d_i >= 2) & (T[idx] > thr)  # keep one redundant row to test again
            if _round == opts.raim_max_exclusions or not np.any(fail):
                break
            loc = np.flatnonzero(fail)
            cand = idx[loc]
            # standardised residuals with leverage h = w H N^-1 H^T (diagonal)
            Hk, wk, vk = H[loc], w[loc], v[loc]
            h = np.einsum("ksi,kij,ksj->ks", Hk, N_inv_all[cand], Hk) * wk
            with np.errstate(divide="ignore", invalid="ignore"):
                std = np.abs(vk) * np.sqrt(wk) / np.sqrt(np.maximum(1.0 - h, 1e-6))
            std = np.where(u[loc], std, -np.inf)
            worst = np.argmax(std, axis=1)
            use[cand, worst] = False
            excluded[cand, worst] = True
            xs, N_inv_c, ok_c, conv_c = self.gauss_newton(cand, x[cand], use[cand])
            x[cand], N_inv_all[cand], ok[cand], conv[cand] = xs, N_inv_c, ok_c, conv_c
            idx = cand
        return x, N_inv_all, ok, conv, T, dof


@dataclass
class _Fix:
    """The state of the batch after a RAIM solve."""

    x: np.ndarray
    ok: np.ndarray
    conv: np.ndarray
    use: np.ndarray
    excluded: np.ndarray
    variance_factor: float = 1.0
    arc_excluded: np.ndarray | None = None


def _solve_batch(prob: _SppProblem, x_start: np.ndarray) -> _Fix:
    """_Fix after RAIM, the a-posteriori variance calibration and the arc screening (each re-solves the batch).

    The variance factor is the median of T over its chi-square median across the epochs that passed RAIM with
    redundancy: the a-priori code noise becomes that of this receiver, so that the RAIM test is neither blind
    (sigma too large) nor trigger-happy (too small).
    """
    from scipy.stats import chi2 as chi2_dist

    opts, sat, t_tag = prob.opts, prob.sat, prob.c.t_tag
    n, m = sat.avail.shape
    use = sat.avail.copy()
    excluded = np.zeros((n, m), dtype=bool)
    x, N_inv_all, ok, conv, T, dof = prob.solve_with_raim(x_start.copy(), use, excluded)
    variance_factor = 1.0
    if opts.calibrate_variance:
        good0 = ok & conv & (dof > 0)
        if good0.sum() >= 10:
            f = float(np.median(T[good0] / chi2_dist.ppf(0.5, dof[good0])))
            if np.isfinite(f) and f > 0:
                variance_factor = float(np.clip(f, VARIANCE_FACTOR_RANGE[0], VARIANCE_FACTOR_RANGE[1]))
                prob.var0 = prob.var0 * variance_factor
                use = sat.avail.copy()
                excluded[:] = False
                x = np.where((ok & conv)[:, None], x, x_start)
                x, N_inv_all, ok, conv, T, dof = prob.solve_with_raim(x, use, excluded)
    arc_excluded = np.zeros((n, m), dtype=bool)
    if opts.arc_screening and opts.raim_max_exclusions > 0:
        arc_excluded = _arc_exclusions(sat.avail, excluded, ok & conv, t_tag)
        if arc_excluded.any():
            use = sat.avail & ~arc_excluded
            excluded = arc_excluded.copy()
            x = np.where((ok & conv)[:, None], x, x_start)
            x, N_inv_all, ok, conv, T, dof = prob.solve_with_raim(x, use, excluded)
    return _Fix(x, ok, conv, use, excluded, variance_factor, arc_excluded)


def _initial_state(obs, opts: SppOptions, n: int, p: int) -> np.ndarray:
    """(n, p) Gauss-Newton start: the given position, else the header's APPROX POSITION, else the geocentre."""
    x0 = np.zeros(3)
    if opts.initial_position_ecef_m is not None:
        x0 = np.asarray(opts.initial_position_ecef_m, dtype=np.float64)
    elif getattr(obs.header, "approx_position_ecef_m", None) is not None:
        x0 = np.asarray(obs.header.approx_position_ecef_m, dtype=np.float64)
    x = np.zeros((n, p))
    x[:, :3] = x0
    return x


def _final_solution(obs, prob: _SppProblem, fix: _Fix, codes: _Codes) -> SppSolution:
    """SppSolution from the solved batch: final test, flags, DOPs (unit weights), velocity and drift."""
    from scipy.stats import chi2 as chi2_dist

    opts, c, sat = prob.opts, prob.c, prob.sat
    x, use, n_isb, p = fix.x, fix.use, prob.n_isb, prob.p
    n = len(x)
    flags = np.zeros(n, dtype=np.int64)
    v, H, var, el, az, ground = prob.model(x, np.arange(n))
    used = use & ~(ground & (el < np.radians(prob.mask_deg(ground))))
    w = np.where(used, 1.0 / var, 0.0)
    T = np.einsum("ks,ks->k", w, np.where(used, v, 0.0) ** 2)
    n_par = prob.n_unknowns(used)
    dof = used.sum(1) - n_par
    thr = np.where(dof > 0, chi2_dist.ppf(1.0 - opts.raim_false_alarm, np.maximum(dof, 1)), np.inf)
    N = np.einsum("ksi,ks,ksj->kij", H, w, H) + prob.isb_prior
    _, N_inv_all, ok2, = _batch_solve(N, np.zeros((n, p)))
    few = used.sum(1) < n_par
    ok = fix.ok & ok2 & ~few
    flags |= np.where(few, FLAG_TOO_FEW, 0)
    flags |= np.where(~few & ~(ok & fix.conv), FLAG_NOT_CONVERGED, 0)
    good = ok & fix.conv
    flags |= np.where(good & (dof > 0) & (T > thr), FLAG_RAIM_FAILED, 0)
    flags |= np.where(good & (dof == 0), FLAG_RAIM_UNTESTED, 0)
    # DOPs from unit weights (geometry only)
    N_unit = np.einsum("ksi,ks,ksj->kij", H[..., :4], used.astype(float), H[..., :4])
    _, N_unit_inv, ok_u = _batch_solve(N_unit, np.zeros((n, 4)))
    pdop, gdop = _dops(N_unit_inv)
    pdop = np.where(ok_u, pdop, np.nan)
    gdop = np.where(ok_u, gdop, np.nan)
    flags |= np.where(good & (pdop > opts.max_pdop), FLAG_HIGH_PDOP, 0)

    pos = np.where(good[:, None], x[:, :3], np.nan)
    clock = np.where(good, x[:, 3] / C_M_S, np.nan)
    vel = np.full((n, 3), np.nan)
    drift = np.full(n, np.nan)
    vsource = "none"
    if opts.velocity:
        rr, vsource = _range_rates(obs, c)
        if rr is not None:
            vel, drift = _solve_velocity(rr, pos, sat.r_sat, sat.v_sat, sat.clk_rate, used & good[:, None],
                                         opts.sigma_range_rate_m_s, opts.raim_false_alarm, opts.raim_max_exclusions)
    flags |= np.where(np.isnan(drift), FLAG_NO_VELOCITY, 0)

    return SppSolution(
        sats=c.sats, time_tag=c.t_tag, time=c.t_tag - np.nan_to_num(clock), position_ecef_m=pos, clock_s=clock,
        velocity_ecef_m_s=vel, clock_drift_s_s=drift, n_sats=np.where(good, used.sum(1), 0), pdop=pdop, gdop=gdop,
        chi2=np.where(good, T, np.nan), residuals_m=np.where(used & good[:, None], v, np.nan),
        used=used & good[:, None], excluded=fix.excluded, iono_free=codes.use_if, elevation_deg=np.degrees(el),
        azimuth_deg=np.degrees(az), covariance=np.where(good[:, None, None], N_inv_all[:, :4, :4], np.nan),
        flags=flags, velocity_source=vsource, isb_systems=c.sys_list[1:],
        isb_m=np.where(good[:, None], x[:, 4:], np.nan) if n_isb else None, weighting=prob.weighting,
        variance_factor=fix.variance_factor, arc_excluded=fix.arc_excluded)


def spp(obs, ephemeris, options: SppOptions | None = None, *, epochs=None) -> SppSolution:
    """SppSolution: per-epoch position, clock, velocity, drift, DOPs, residuals and flags of one receiver.

    Args:
        obs: RinexObs (gnssatt.gnss.io.rinex_obs) of one receiver.
        ephemeris: a SatelliteEphemeris (gnssatt.gnss.ephemeris: BroadcastEphemeris or PreciseEphemeris).
        options: SppOptions (systems, ionosphere-free, weighting, RAIM, smoothing, ...); default SppOptions().
        epochs: optional index/mask of the epochs to solve (others are omitted from the result).
    Implements: see module docstring.
    """
    opts = options if options is not None else SppOptions()
    c = _columns(obs, opts.systems, epochs)
    P1, P2 = _band_codes(obs, c)
    weighting, ssi_rel = _weighting_and_cn0(obs, c, P1, opts.weighting)
    P2 = _screen_codes(obs, c, P1, P2)
    codes = _code_observables(obs, c, P1, P2, opts)
    sat = _satellite_states(ephemeris, c, codes)
    sigma_ure_m = opts.sigma_ure_m
    if sigma_ure_m is None:
        sigma_ure_m = 0.1 if "Precise" in type(ephemeris).__name__ else 1.0
    var0 = _a_priori_variance(codes, ssi_rel, weighting, opts)
    prob = _SppProblem(c, sat, var0, weighting, _klobuchar_of(ephemeris, opts.klobuchar), sigma_ure_m, opts)
    fix = _solve_batch(prob, _initial_state(obs, opts, len(c.sel), prob.p))
    return _final_solution(obs, prob, fix, codes)


def hatch_smooth(code_m, phase_m, slip, t: GpsTime, window_s: float, *, max_gap_s: float,
                 reset_threshold_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(smoothed code (n, m) m, samples in the filter (n, m)) by the Hatch filter over continuous phase arcs.

    P_s(k) = P(k) / N + (N - 1) / N (P_s(k-1) + Phi(k) - Phi(k-1)), N = min(samples so far, window_s / dt);
    the filter restarts at a loss of lock (`slip`), a gap longer than max_gap_s, a missing code or phase, or when
    the code departs from the prediction by more than reset_threshold_m (an undetected slip or a code-only 1 ms
    receiver clock jump). Used on the ionosphere-free code and phase there is no code-carrier divergence.
    Args: code_m, phase_m (n, m) in metres (phase = lambda x cycles); slip (n, m) bool; t (n,) epochs.
    Implements: Hatch (1982), "The synergism of GPS code and carrier measurements", eq. of the recursive filter;
    RTKLIB 2.4.3 `csmooth`.
    """
    n, m = code_m.shape
    out = np.full((n, m), np.nan)
    count = np.zeros((n, m), dtype=np.int64)
    prev_s = np.full(m, np.nan)
    prev_phi = np.full(m, np.nan)
    cnt = np.zeros(m, dtype=np.int64)
    dt = np.diff(t - t[0]) if n > 1 else np.zeros(0)
    step = float(np.median(dt)) if dt.size else 1.0
    n_max = max(1, int(round(window_s / max(step, 1e-9))))
    for k in range(n):
        P, phi = code_m[k], phase_m[k]
        ok = np.isfinite(P) & np.isfinite(phi)
        gap = (k == 0) or (dt[k - 1] > max_gap_s)
        cont = ok & np.isfinite(prev_s) & np.isfinite(prev_phi) & ~slip[k] & (not gap)
        pred = prev_s + (phi - prev_phi)
        cont &= np.abs(P - pred) < reset_threshold_m
        cnt = np.where(cont, np.minimum(cnt + 1, n_max), np.where(ok, 1, 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            sm = np.where(cont, P / cnt + (cnt - 1) / cnt * pred, np.where(ok, P, np.nan))
        out[k] = np.where(np.isfinite(P) & ~ok, P, sm)
        count[k] = np.where(ok, cnt, np.isfinite(P).astype(np.int64))
        prev_s = np.where(ok, sm, np.nan)
        prev_phi = np.where(ok, phi, np.nan)
    return out, count


def _smoothed_codes(obs, c: _Columns, P1, P_if, use_if, window_s):
    """(smoothed band-1 code, smoothed ionosphere-free code, samples), (n, m) each, for
    `SppOptions(smoothing_window_s=...)`."""
    sel, cols, sys_list, sys_of, t_tag = c.sel, c.cols, c.sys_list, c.sys_of, c.t_tag
    n, m = P1.shape
    L1 = np.full((n, m), np.nan)
    L2 = np.full((n, m), np.nan)
    slip = np.zeros((n, m), dtype=bool)
    for sysl in sys_list:
        mk = sys_of == sysl
        for band, arr in ((1, L1), (2, L2)):
            if (sysl, band) not in BAND_FREQ_HZ:        # GLONASS FDMA: no phase here (per-satellite wavelengths)
                continue
            lam = C_M_S / BAND_FREQ_HZ[(sysl, band)]
            for code in PHASE_PREFERENCE_BAND.get((sysl, band), ()):
                k = obs.code_index(code, sysl)
                if k is None:
                    continue
                v = obs.values[sel][:, cols[mk], k] * lam
                lli = obs.lli[sel][:, cols[mk], k]
                sub = arr[:, mk]
                fill = np.isnan(sub) & np.isfinite(v) & (v != 0.0)
                sub[fill] = v[fill]
                arr[:, mk] = sub
                s_sub = slip[:, mk]
                s_sub |= fill & (lli >= 0) & ((lli & 1) == 1)
                slip[:, mk] = s_sub
    gf = L1 - L2
    if n >= 3:
        d2 = gf[2:] - 2.0 * gf[1:-1] + gf[:-2]
        slip[2:] |= np.abs(d2) > GF_SLIP_M
    phi_if = _G1 * L1 - _G2 * L2
    step = np.diff(t_tag - t_tag[0]) if n > 1 else np.array([1.0])
    max_gap = 1.5 * float(np.median(step)) if step.size else 1.0
    p_if, c_if = hatch_smooth(np.where(use_if, P_if, np.nan), np.where(use_if, phi_if, np.nan), slip, t_tag,
                              window_s, max_gap_s=max_gap, reset_threshold_m=SMOOTH_RESET_M)
    p1, c1 = hatch_smooth(np.where(~use_if, P1, np.nan), np.where(~use_if, L1, np.nan), slip, t_tag,
                          window_s, max_gap_s=max_gap, reset_threshold_m=SMOOTH_RESET_M)
    count = np.where(use_if, c_if, c1)
    return np.where(use_if, P1, p1), np.where(use_if, p_if, P_if), np.maximum(count, 1)


def _range_rates(obs, c: _Columns) -> tuple[np.ndarray | None, str]:
    """(range rates (n, m) m/s from Doppler -lambda D, or from L1 phase rate, and the source name)."""
    sel, cols, sys_list, sys_of = c.sel, c.cols, c.sys_list, c.sys_of
    lam = C_M_S / FREQ_GPS_L1_HZ
    n, m = len(sel), len(cols)
    rr = np.full((n, m), np.nan)
    for sysl in sys_list:
        d, _ = select_code(obs, sysl, DOPPLER_PREFERENCE.get(sysl, ()))
        mk = sys_of == sysl
        rr[:, mk] = -lam * d[sel][:, cols[mk]]
    if np.isfinite(rr).any():
        return rr, "doppler"
    t_all = obs.time
    for sysl in sys_list:
        pr = _phase_rate_m_s(obs, sysl, t_all)
        mk = sys_of == sysl
        rr[:, mk] = pr[sel][:, cols[mk]]
    if np.isfinite(rr).any():
        return rr, "phase-rate"
    return None, "none"


def _solve_velocity(rr, pos, r_sat, v_sat, clk_rate, use, sigma, p_fa, max_excl):
    """(velocity (n, 3) m/s, clock drift (n,) s/s) from range rates by batched linear WLS with exclusion.

    Model (RTKLIB `resdop`, ECEF): rr = e . (v_s - v_r) + (omega/c)(v_s,y x_r + y_s v_r,x - v_s,x y_r - x_s v_r,y)
    + c (ddt_r - ddt_s), solved for v_r and c ddt_r; e from receiver to satellite.
    """
    from scipy.stats import chi2 as chi2_dist

    n, m = rr.shape
    d = r_sat - pos[:, None, :]
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    xr, yr = pos[:, None, 0], pos[:, None, 1]
    xs, ys = r_sat[..., 0], r_sat[..., 1]
    vsx, vsy = v_sat[..., 0], v_sat[..., 1]
    # Terms that do not depend on the unknowns: e . v_s + omega/c (v_s,y x_r - v_s,x y_r) - c ddt_s
    known = (np.einsum("nmi,nmi->nm", e, v_sat) + OMEGA_EARTH_RAD_S / C_M_S * (vsy * xr - vsx * yr)
             - C_M_S * clk_rate)
    # Unknown v_r: -e . v_r + omega/c (y_s v_r,x - x_s v_r,y)
    H = np.zeros((n, m, 4))
    H[..., 0] = -e[..., 0] + OMEGA_EARTH_RAD_S / C_M_S * ys
    H[..., 1] = -e[..., 1] - OMEGA_EARTH_RAD_S / C_M_S * xs
    H[..., 2] = -e[..., 2]
    H[..., 3] = 1.0
    y = rr - known
    u = use & np.isfinite(y) & np.all(np.isfinite(H), axis=-1)
    y0 = np.where(u, y, 0.0)
    H = np.where(np.isfinite(H), H, 0.0)
    sol = np.full((n, 4), np.nan)
    active = np.arange(n)
    uu = u.copy()
    for _round in range(max_excl + 1):
        w = uu[active].astype(float) / sigma ** 2
        Ha = H[active]
        N = np.einsum("ksi,ks,ksj->kij", Ha, w, Ha)
        b = np.einsum("ksi,ks,ks->ki", Ha, w, y0[active])
        xk, N_inv, ok = _batch_solve(N, b)
        ok &= uu[active].sum(1) >= 4
        sol[active] = np.where(ok[:, None], xk, np.nan)
        v = np.where(uu[active], y0[active] - np.einsum("ksi,ki->ks", Ha, np.nan_to_num(xk)), 0.0)
        T = np.sum(w * v * v, axis=1)
        dof = uu[active].sum(1) - 4
        thr = np.where(dof > 0, chi2_dist.ppf(1.0 - p_fa, np.maximum(dof, 1)), np.inf)
        bad = ok & (dof >= 2) & (T > thr)
        if _round == max_excl or not bad.any():
            break
        h = np.einsum("ksi,kij,ksj->ks", Ha, N_inv, Ha) * w
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(uu[active], np.abs(v) * np.sqrt(w) / np.sqrt(np.maximum(1.0 - h, 1e-6)), -np.inf)
        worst = np.argmax(s, axis=1)
        ab = active[bad]
        uu[ab, worst[bad]] = False
        active = ab
    return sol[:, :3], sol[:, 3] / C_M_S
