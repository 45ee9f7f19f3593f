"""Consider (Schmidt) covariance of the attitude for what the product knows it does not model: the antennas'
uncalibrated phase-centre offsets and the offset-like part of their uncalibrated phase-centre variations.

A constant error of a body baseline (the phase centres are not where platform.json puts the antennas) is absorbed
whole into the estimated baselines and shows in no residual; the attitude then carries a constant error
delta theta ~ delta b_perp / |b|. The Schmidt-Kalman "consider" treatment (Schmidt 1966; e.g. Tapley, Schutz & Born
2004, Statistical Orbit Determination, sec. 6.3) adds its covariance to the reported one without estimating it:

    P_theta += G (R^T C_body R) G^T

C_body (per baseline, body frame) the covariance of the phase-centre baseline about the body one, R body <- ECEF
and G the QUEST covariance Jacobian of gnssatt.attitude.solution.attitude_from_baselines (a body-vector error
delta is the ECEF baseline error R^T delta; "ml" uses QUEST's G). Per antenna, in its antenna frame (z boresight):

    C_ant = diag(h, h, v) / n_sig,  h = pco_sigma^2 + (KAPPA_H pcv_rms)^2,  v = pco_sigma^2 + (KAPPA_V pcv_rms)^2

pco_sigma_mm and pcv_rms_mm from platform.json (docs/formats/platform_antenna_uncertainty.md, per antenna, the
declared uncertainty), n_sig the signals in use (their offsets taken independent, equally weighted). KAPPA_H / V:
the offset-like part of a smooth random PCV pattern of RMS pcv_rms over the upper hemisphere, per axis: the
least-squares fit of [1, e_x, e_y, e_z] (the clock and an offset's signature) over the sky above a 10 deg mask,
solid-angle weighted (what a pass averaging over the sky absorbs); 0.84 / 1.34 for the low-order pattern family of
gnssatt/sim/observables.pcv_grid_mm (tests/attitude/test_antenna_consider.py recomputes them; 3.46 vertical would be
a pattern made of the offset signature alone). C_body = R_b_a C_a R_a_b + R_b_b C_b R_b_b^T (two antennas
independent); two baselines sharing an antenna share its term, with the sign of its place in each (a>b is b - a),
so the attitude sees one antenna's offset once, not once per baseline. A calibrated baseline
(calibration.calibrated_baselines) removes the baseline's term (it is the phase-centre vector); a PCV map of the
baseline removes the PCV part (the offsets stay).

Default where platform.json declares neither field: DEFAULT_PCO_SIGMA_MM 1.0, DEFAULT_PCV_RMS_MM 1.0 - the
individual departure of a patch from its type: position differences of up to 1 cm up and below 4 mm horizontally
between type-mean and individual calibrations (Sensors 2021, 21(14) 4639, introduction, citing its refs 1, 12),
read as ~3 sigma. It assumes antennas of one type and orientation (their type pattern cancels in the single
difference); mixed types need declared values.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.solution import attitude_from_baselines, euler_and_sigma
from gnssatt.gnss import rotations as rot
from gnssatt.gnss.geometry import R_antenna_from_body

__all__ = ["KAPPA_H", "KAPPA_V", "DEFAULT_PCO_SIGMA_MM", "DEFAULT_PCV_RMS_MM", "antenna_frame_variance_m2",
           "baseline_consider_body_m2", "consider_theta_rad2", "attitude_consider"]

KAPPA_H = 0.84
KAPPA_V = 1.34
DEFAULT_PCO_SIGMA_MM = 1.0
DEFAULT_PCV_RMS_MM = 1.0


def _per_signal(value, signals: list[str], default: float) -> np.ndarray:
    """Declared sigma (mm) per signal in use: a number for all, or {signal: number} ("L1" serves "G:L1")."""
    if value is None:
        return np.full(len(signals), default)
    if isinstance(value, dict):
        return np.array([float(value.get(s, value.get(s.split(":")[-1], default))) for s in signals])
    return np.full(len(signals), float(value))


def antenna_frame_variance_m2(antenna, signals: list[str], with_pcv: bool = True) -> np.ndarray:
    """(3,) variance (m^2) of one antenna's phase centre along antenna x, y, z (module doc)."""
    declared = antenna.pco_sigma_mm is not None or antenna.pcv_rms_mm is not None
    pco = _per_signal(antenna.pco_sigma_mm, signals, 0.0 if declared else DEFAULT_PCO_SIGMA_MM)
    pcv = _per_signal(antenna.pcv_rms_mm, signals, 0.0 if declared else DEFAULT_PCV_RMS_MM) * with_pcv
    n = max(len(signals), 1)
    h = float(np.sum(pco ** 2 + (KAPPA_H * pcv) ** 2)) / n ** 2
    v = float(np.sum(pco ** 2 + (KAPPA_V * pcv) ** 2)) / n ** 2
    return np.array([h, h, v]) * 1e-6


def _antenna_body_m2(ant, signals: list[str], with_pcv: bool) -> np.ndarray:
    """(3, 3) body-frame covariance (m^2) of one antenna's phase centre about its platform.json position."""
    R = R_antenna_from_body(ant.boresight_body)
    return R.T @ np.diag(antenna_frame_variance_m2(ant, signals, with_pcv)) @ R


def baseline_consider_body_m2(platform, baselines: list[tuple[str, str]], signals: list[str],
                              calibration=None) -> tuple[np.ndarray, dict]:
    """((3 n_bl, 3 n_bl) body-frame covariance of the phase-centre baselines about the body ones, info) (module
    doc). Baseline a>b is b - a, so its error is e_b - e_a: two baselines sharing an antenna are correlated,
    cov(j, k) = sum over shared antennas s of sign_j(s) sign_k(s) C_s (sign -1 where s is first, +1 second); a
    calibrated baseline has no row or column, a PCV map keeps only the offsets in that baseline's antennas."""
    cal_b = getattr(calibration, "calibrated_baselines", {}) or {}
    maps = getattr(calibration, "pcv_maps", {}) or {}
    n_bl = len(baselines)
    out = np.zeros((3 * n_bl, 3 * n_bl))
    removed, terms = [], []          # per baseline {antenna: (sign, with_pcv)}
    for (a, b) in baselines:
        if (a, b) in cal_b:
            removed.append(f"{a}>{b}: calibrated baseline")
            terms.append({})
            continue
        with_pcv = not any(x == a and y == b for (x, y, _f) in maps)
        if not with_pcv:
            removed.append(f"{a}>{b}: PCV map (offsets kept)")
        terms.append({a: (-1.0, with_pcv), b: (1.0, with_pcv)})
    for j in range(n_bl):
        for k in range(n_bl):
            for name in terms[j].keys() & terms[k].keys():   # the error both see: the PCV part only if neither maps it
                (sj, pj), (sk, pk) = terms[j][name], terms[k][name]
                out[3 * j:3 * j + 3, 3 * k:3 * k + 3] += sj * sk * _antenna_body_m2(
                    platform.antennas[name], signals, pj and pk)
    declared = {k: {"pco_sigma_mm": v.pco_sigma_mm, "pcv_rms_mm": v.pcv_rms_mm} for k, v in platform.antennas.items()}
    defaulted = [k for k, v in declared.items() if v["pco_sigma_mm"] is None and v["pcv_rms_mm"] is None]
    info = {"method": "Schmidt consider: uncalibrated PCO and the offset-like part of the PCV (docs/attitude.md)",
            "declared": declared, "defaults_applied_to": defaulted,
            "default": {"pco_sigma_mm": DEFAULT_PCO_SIGMA_MM, "pcv_rms_mm": DEFAULT_PCV_RMS_MM},
            "kappa_h_v": [KAPPA_H, KAPPA_V], "removed": removed,
            "baseline_sigma_mm": [np.sqrt(np.diag(out[3 * j:3 * j + 3, 3 * j:3 * j + 3]) * 1e6).round(4).tolist()
                                  for j in range(n_bl)]}
    return out, info


def consider_theta_rad2(q_body_from_ecef: np.ndarray, b_ecef_m: np.ndarray, C_body_m2: np.ndarray,
                        b_body_m: np.ndarray, method: str = "quest") -> np.ndarray:
    """(n, 3, 3) attitude covariance (rad^2, body small rotation) of the body baselines' covariance C_body_m2
    (3 n_bl, 3 n_bl) for n epochs of estimated baselines b_ecef_m (n, n_bl, 3) (module doc)."""
    n, n_bl, _ = b_ecef_m.shape
    R = rot.quat_to_dcm(q_body_from_ecef)                                       # body <- ecef
    Rt_blocks = np.zeros((n, 3 * n_bl, 3 * n_bl))
    for j in range(n_bl):
        Rt_blocks[:, 3 * j:3 * j + 3, 3 * j:3 * j + 3] = np.swapaxes(R, -1, -2)
    P = Rt_blocks @ C_body_m2 @ np.swapaxes(Rt_blocks, -1, -2)
    _, P_th = attitude_from_baselines(b_ecef_m, P, b_body_m, "quest" if method == "ml" else method)
    return P_th


def attitude_consider(platform, baselines: list[tuple[str, str]], signals: list[str], settings, q_body_from_ecef,
                      b_ecef_m: np.ndarray, b_body_m: np.ndarray, R_body_from_ref: np.ndarray):
    """(P_theta term (n, 3, 3) rad^2, its yaw / pitch / roll sigmas (n, 3) deg, summary.json "antenna_consider")
    for the attitude epochs of process(): baseline_consider_body_m2 through consider_theta_rad2."""
    C_body, info = baseline_consider_body_m2(platform, baselines, signals, settings.calibration)
    P_c = consider_theta_rad2(q_body_from_ecef, b_ecef_m, C_body, b_body_m, settings.attitude_method)
    _, _, _, cy, cp, cr = euler_and_sigma(R_body_from_ref, P_c)
    info["attitude_sigma_deg_median"] = [float(np.median(x)) if x.size else None for x in (cy, cp, cr)]
    return P_c, np.stack([cy, cp, cr], 1), info
