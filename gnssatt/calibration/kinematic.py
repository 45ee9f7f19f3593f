"""Epoch-wise least squares of fixed single-difference carrier phases, and integer fixing by rounding from a
predicted baseline. Two uses (gnssatt.calibration.extract):
- with the attitude filter's kinematic mode (the default producer): the prediction is the filter's own fixed
  baseline, so the integers are the filter's; the least squares only screens the samples (10 cm gate) and, on
  the held-out set's epoch-wise comparison, solves the PCV-corrected epochs;
- the "reference-aided-ablation" producer, kept ONLY as an ablation of seed 000 sec. 3.1: the prediction is the
  reference attitude times the a priori body baseline, and the baselines are these epoch-wise least squares.

Single differences (second minus first antenna, same receiver time tag, metres):
    SD_i = -e_i . b + (c - rhodot_i) dt_21 + lambda (N_i + beta) + dPCV_i + noise,
e_i the unit line of sight, b the ECEF baseline, dt_21 the differential receiver clock, rhodot_i the range rate
(the receivers sample the ranges at their own true times, so a clock difference of dt moves each range by
-rhodot dt: up to 8 km/s x 0.6 us = 5 mm on a LEO), beta the fractional phase-bias difference (common).
With kappa = c dt_21 taken from the code single differences (to ~1 m, so kappa rhodot / c is known to < 0.03 mm),
    y_i = SD_i + kappa rhodot_i / c - lambda n_i = -e_i . b + c_e + dPCV_i + noise
with one constant c_e per epoch and signal (c_e = kappa + lambda (k + beta)).

Ambiguities. The prediction (the filter's fixed baseline, or in the ablation the reference attitude and the a
priori baseline) gives -e . b to within the baseline error and the PCV (a few cm, well under half an L1 cycle);
per epoch z_i = (SD_i + kappa rhodot_i / c + e_i . b_pred - corr_i)
/ lambda = N_i + (kappa + lambda beta) / lambda + small, so after removing the circular weighted mean phi of z at
the epoch, n_i = round(z_i - phi) are the single-difference integers up to one integer common to the epoch, which
c_e absorbs. Wrong integers show as residuals of a good fraction of a cycle and are rejected by the gate below.

Baselines. Per epoch, weighted least squares of y = -e . b + c_sig with b (3) and one constant per signal;
residuals beyond `gate_m` are removed one (the worst) per epoch and round, up to `max_rejections` rounds.
In the ablation this stands in for the seed 000 sec. 3.1 kinematic mode in its limit of unbounded baseline process
noise (every epoch independent; the filter uses 100 cm per 1 s).

Implements: seed 000 sec. 2 eq. 1 (single-difference phase model) and sec. 3.1 (kinematic baselines); the
clock/range-rate coupling of the receivers' sampling times.
Neglects: tropospheric and ionospheric single differences (metre baselines), the antenna-to-antenna line-of-sight
difference (< 1e-7 rad), phase wind-up differences (parallel antennas).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.gnss.constants import C_M_S

#: 10 cm: beyond the tails of an uncalibrated single difference (PCV up to +-35 mm + multipath + L2 noise up to
#: ~25 mm at the antenna horizon), so the gate only removes gross errors. A gate inside those tails clips them
#: asymmetrically about the model without maps and pulls the samples towards zero PCV: 5 cm removed 1.7 % of the
#: L2 samples of the 30-set bench campaign (48 of 1.3 M on L1) and put +0.52 mm into the calibrated baseline's x
#: (docs/BENCHMARKS.md "Calibration"); 10 and 15 cm keep the same samples to 0.001 %.
DEFAULT_GATE_M = 0.10
DEFAULT_MAX_REJECTIONS = 3
MIN_SATS = 4  # satellites with a phase at an epoch for a baseline solution (3 + one clock per signal)


def clock_from_code_m(code_sd_m: np.ndarray, los_ecef: np.ndarray, b_pred_ecef_m: np.ndarray) -> np.ndarray:
    """(n_ep,) kappa = c dt_21 (m) per epoch: median over satellites and signals of code SD + e . b_pred.

    Args:
        code_sd_m: (n_ep, n_sat, n_sig) code single differences, m (NaN where absent).
        los_ecef: (n_ep, n_sat, 3) unit lines of sight; b_pred_ecef_m: (n_ep, 3) predicted baseline.
    The median keeps a multipath outlier out; receiver code biases (dm) remain, harmless here (see module doc).
    """
    proj = np.einsum("esk,ek->es", los_ecef, b_pred_ecef_m)
    z = code_sd_m + proj[..., None]
    z = z.reshape(z.shape[0], -1)
    with np.errstate(all="ignore"):
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanmedian(z, axis=1)


def fix_integers(z_cyc: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """(n_ep, n) integers n = round(z - phi_e) (NaN where z is NaN), phi_e the weighted circular mean of z at the
    epoch: single-difference ambiguities up to one integer common to each epoch.

    Args:
        z_cyc: (n_ep, n) predicted-minus-observed phases in cycles (N + common + small).
        weight: (n_ep, n) non-negative weights.
    """
    ok = np.isfinite(z_cyc) & (weight > 0)
    zz = np.where(ok, z_cyc, 0.0)
    ww = np.where(ok, weight, 0.0)
    s = np.sum(ww * np.exp(2j * np.pi * zz), axis=1)
    phi = np.angle(s) / (2 * np.pi)
    return np.where(ok, np.round(z_cyc - phi[:, None]), np.nan)


@dataclass
class EpochSolution:
    """Per epoch: x (n_ep, n_par) parameters, cov (n_ep, n_par, n_par), used (n_ep, n_obs) bool samples kept,
    residual (n_ep, n_obs) m (NaN where not used), ok (n_ep,) solution exists."""

    x: np.ndarray
    cov: np.ndarray
    used: np.ndarray
    residual: np.ndarray
    ok: np.ndarray


def epoch_lsq(y: np.ndarray, H: np.ndarray, w: np.ndarray, *, gate: float = DEFAULT_GATE_M,
              max_rejections: int = DEFAULT_MAX_REJECTIONS, min_obs: int = 5,
              regularize_cols: np.ndarray | None = None) -> EpochSolution:
    """EpochSolution of independent weighted least squares per epoch, with residual gating.

    Args:
        y: (n_ep, n_obs) observations (NaN = absent); H: (n_ep, n_obs, n_par) design; w: (n_ep, n_obs) weights.
        gate: |residual| above which the worst sample of an epoch is removed and the epoch re-solved.
        min_obs: samples needed for a solution.
        regularize_cols: (n_par,) bool, parameters given a tiny prior (1e-9 of the mean information) so that
            an epoch without any sample of a signal still solves (its constant is then 0 and meaningless).
    Implements: x = (H^T W H)^-1 H^T W y, cov = (H^T W H)^-1 per epoch.
    """
    n_ep, n_obs, n_par = H.shape
    used = np.isfinite(y) & np.isfinite(w) & (w > 0) & np.isfinite(H).all(-1)
    yy = np.where(used, y, 0.0)
    HH = np.where(used[..., None], H, 0.0)
    x = np.full((n_ep, n_par), np.nan)
    cov = np.full((n_ep, n_par, n_par), np.nan)
    res = np.full((n_ep, n_obs), np.nan)
    ok = np.zeros(n_ep, bool)
    for _ in range(max_rejections + 1):
        ww = np.where(used, w, 0.0)
        N = np.einsum("eoi,eo,eoj->eij", HH, ww, HH)
        if regularize_cols is not None:
            scale = np.maximum(np.einsum("eii->e", N) / n_par, 1.0)
            N = N + np.einsum("e,ij->eij", 1e-9 * scale, np.diag(regularize_cols.astype(float)))
        rhs = np.einsum("eoi,eo,eo->ei", HH, ww, yy)
        enough = used.sum(1) >= min_obs
        with np.errstate(all="ignore"):
            cond_ok = enough & (np.linalg.cond(np.where(enough[:, None, None], N, np.eye(n_par))) < 1e12)
        Ns = np.where(cond_ok[:, None, None], N, np.eye(n_par))
        Ninv = np.linalg.inv(Ns)
        xe = np.einsum("eij,ej->ei", Ninv, np.where(cond_ok[:, None], rhs, 0.0))
        v = np.where(used, yy - np.einsum("eoi,ei->eo", HH, xe), np.nan)
        x = np.where(cond_ok[:, None], xe, np.nan)
        cov = np.where(cond_ok[:, None, None], Ninv, np.nan)
        res = v
        ok = cond_ok
        absv = np.where(used & cond_ok[:, None], np.abs(v), -1.0)
        worst = np.argmax(absv, axis=1)
        bad = absv[np.arange(n_ep), worst] > gate
        if not np.any(bad):
            break
        used[np.flatnonzero(bad), worst[bad]] = False
    # a solution whose remaining residuals still exceed the gate is not used
    still = np.any(used & (np.abs(np.nan_to_num(res)) > gate), axis=1)
    ok = ok & ~still
    x[~ok] = np.nan
    cov[~ok] = np.nan
    return EpochSolution(x, cov, used & ok[:, None], np.where(used & ok[:, None], res, np.nan), ok)


@dataclass
class BaselineFix:
    """One baseline over a set: per epoch ECEF baseline (n_ep, 3), covariance (n_ep, 3, 3), ok (n_ep,) and the
    fixed samples y (n_ep, n_sat, n_sig) m (NaN where not used) with weights (n_ep, n_sat, n_sig)."""

    b_ecef_m: np.ndarray
    cov_ecef_m2: np.ndarray
    ok: np.ndarray
    y_m: np.ndarray
    weight: np.ndarray
    residual_m: np.ndarray


@dataclass(frozen=True)
class BaselineObservations:
    """The single-differenced observations of one baseline over a set (second antenna minus first).

    phase_sd_m, code_sd_m: (n_ep, n_sat, n_sig) single differences, m.
    los_ecef: (n_ep, n_sat, 3) unit LOS; range_rate_m_s: (n_ep, n_sat).
    wavelength_m, sigma_phase_m: (n_sig,).
    variance_factor: (n_ep, n_sat, n_sig) multiplies sigma_phase_m^2 per sample (C/N0 weighting), or None.
    """

    phase_sd_m: np.ndarray
    code_sd_m: np.ndarray
    los_ecef: np.ndarray
    range_rate_m_s: np.ndarray
    wavelength_m: np.ndarray
    sigma_phase_m: np.ndarray
    variance_factor: np.ndarray | None = None


def solve_baseline(obs: BaselineObservations, b_pred_ecef_m: np.ndarray, *,
                   correction_m: np.ndarray | None = None, gate_m: float = DEFAULT_GATE_M,
                   max_rejections: int = DEFAULT_MAX_REJECTIONS, fix_pred_ecef_m: np.ndarray | None = None,
                   fix_correction_m: np.ndarray | None = None) -> BaselineFix:
    """BaselineFix of one baseline: integers fixed with the prediction, then epoch-wise least squares.

    Args:
        obs: the baseline's single differences, geometry and phase noise (BaselineObservations).
        b_pred_ecef_m: (n_ep, 3) predicted baseline (reference attitude x body baseline), NaN where none.
        correction_m: (n_ep, n_sat, n_sig) PCV correction subtracted from the phases before the solution, or None.
        fix_pred_ecef_m, fix_correction_m: prediction used only to fix the integers (default: the above).
    """
    phase_sd_m, code_sd_m, los_ecef = obs.phase_sd_m, obs.code_sd_m, obs.los_ecef
    range_rate_m_s, wavelength_m, sigma_phase_m = obs.range_rate_m_s, obs.wavelength_m, obs.sigma_phase_m
    variance_factor = obs.variance_factor
    n_ep, n_sat, n_sig = phase_sd_m.shape
    kappa = clock_from_code_m(code_sd_m, los_ecef, b_pred_ecef_m)
    rate_term = (kappa[:, None] * range_rate_m_s / C_M_S)[..., None]  # (n_ep, n_sat, 1)
    ph = phase_sd_m + rate_term
    fp = b_pred_ecef_m if fix_pred_ecef_m is None else fix_pred_ecef_m
    fc = correction_m if fix_correction_m is None else fix_correction_m
    proj = np.einsum("esk,ek->es", los_ecef, fp)[..., None]
    w = np.broadcast_to(1.0 / sigma_phase_m ** 2, ph.shape).copy()
    if variance_factor is not None:
        w = w / np.where(np.isfinite(variance_factor) & (variance_factor > 0), variance_factor, 1.0)
    w[~np.isfinite(ph)] = 0.0
    ints = np.full(ph.shape, np.nan)
    for k in range(n_sig):
        z = (ph[..., k] + proj[..., 0] - (0.0 if fc is None else np.nan_to_num(fc[..., k]))) / wavelength_m[k]
        ints[..., k] = fix_integers(z, w[..., k])
    y = ph - ints * wavelength_m
    if correction_m is not None:
        y = y - np.nan_to_num(correction_m)
    # design: y = -e . b + c_sig
    H = np.zeros((n_ep, n_sat, n_sig, 3 + n_sig))
    H[..., :3] = -los_ecef[:, :, None, :]
    for k in range(n_sig):
        H[:, :, k, 3 + k] = 1.0
    ok_kappa = np.isfinite(kappa) & np.isfinite(b_pred_ecef_m).all(-1)
    y = np.where(ok_kappa[:, None, None], y, np.nan)
    sol = epoch_lsq(y.reshape(n_ep, -1), H.reshape(n_ep, -1, 3 + n_sig), w.reshape(n_ep, -1), gate=gate_m,
                    max_rejections=max_rejections, min_obs=MIN_SATS + n_sig,
                    regularize_cols=np.array([False] * 3 + [True] * n_sig))
    # at least MIN_SATS distinct satellites
    used = sol.used.reshape(n_ep, n_sat, n_sig)
    enough = used.any(-1).sum(-1) >= MIN_SATS
    ok = sol.ok & enough
    b = np.where(ok[:, None], sol.x[:, :3], np.nan)
    cov = np.where(ok[:, None, None], sol.cov[:, :3, :3], np.nan)
    keep = used & ok[:, None, None]
    return BaselineFix(b, cov, ok, np.where(keep, y, np.nan), np.where(keep, w, 0.0),
                       np.where(keep, sol.residual.reshape(n_ep, n_sat, n_sig), np.nan))


__all__ = ["clock_from_code_m", "fix_integers", "EpochSolution", "epoch_lsq", "BaselineFix", "BaselineObservations",
           "solve_baseline",
           "DEFAULT_GATE_M"]
