"""Yaw of a satellite from differential observations with a known baseline (seed 004 eq. 9): per-epoch yaw (or
one yaw offset from a model per block of epochs) and one constant per station arc, by Gauss-Newton.

Model of row k (epoch t, group g):  d_k = a_k cos(yaw_t) + b_k sin(yaw_t) + c_k + A_g + eps_k,
yaw_t = base_t + theta_block(t)  (base: 0 for per-epoch yaw, the attitude model for "offset" blocks).
The normal equations have a diagonal theta block, so the arc constants are solved from the Schur complement
S = N_AA - N_At N_tt^-1 N_tA (n_groups x n_groups) and the yaw variance is
var(theta_j) = 1/N_jj + m_j^T S^-1 m_j / N_jj^2 (m_j: row j of N_tA), all vectorised with numpy.

Initial values: arc constants from the model yaw, then a grid search of every block's theta on the circle
(the cost is a quadratic form in cos, sin), alternated with the arc constants, before Gauss-Newton.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.satyaw.attitude_models import R_ecef_from_body, wrap_deg
from gnssatt.satyaw.differential import DiffObs, SatGeometry, observability, yaw_coefficients

__all__ = ["YawOptions", "YawEstimate", "estimate_yaw", "ar1_inflation"]


@dataclass(frozen=True)
class YawOptions:
    """block_s: None = one yaw per epoch; float = one yaw offset from the model per block of that length
    (s); 0 = a single offset over the whole span (short spans, seed 004's 'known model' check).
    prior_sigma_deg: sigma of a prior on theta (per-epoch: towards the model; None = no prior).
    iterations: Gauss-Newton iterations; grid_step_deg: initial grid search step.
    systematic_m: RMS of slowly varying differential errors (residual multipath, the change of unmodelled PCV,
    inter-signal bias drift) that a yaw offset over a short block cannot be told from; added to the sigma of
    offset blocks as systematic_m / RMS(dd/dyaw about its arc means). 0.3 mm: same-frequency differential
    multipath nearly cancels (seed 004 sec. 3.2), and in simulations with 0.3 mm RMS of it the sigma then
    bounds the error (tests/satyaw/test_estimators.py). Per-epoch yaw averages such errors over stations."""

    block_s: float | None = None
    prior_sigma_deg: float | None = None
    iterations: int = 8
    grid_step_deg: float = 1.0
    alternations: int = 4
    min_stations: int = 1
    systematic_m: float = 0.0003


@dataclass
class YawEstimate:
    """Per-epoch results (T,): yaw_deg, sigma_yaw_deg (NaN where unobserved), model_yaw_deg, n_stations,
    observability; offsets_m (n_groups,) arc constants; residual_m (n,) per row; sigma0 (a posteriori unit
    weight); block (T,) block index; ar1_factor: time-correlation inflation applied to block sigmas."""

    yaw_deg: np.ndarray
    sigma_yaw_deg: np.ndarray
    model_yaw_deg: np.ndarray
    n_stations: np.ndarray
    observability: np.ndarray
    offsets_m: np.ndarray
    residual_m: np.ndarray
    sigma0: float
    block: np.ndarray
    ar1_factor: float


def ar1_inflation(residual, group, epoch) -> float:
    """sqrt((1 + rho) / (1 - rho)) of the lag-one autocorrelation rho of the residuals within groups: the
    variance inflation of a mean of AR(1) errors (Bayley & Hammersley 1946), >= 1."""
    r = np.asarray(residual)
    g = np.asarray(group)
    order = np.lexsort((epoch, g))
    r, g = r[order], g[order]
    same = g[1:] == g[:-1]
    if same.sum() < 10:
        return 1.0
    rho = float(np.sum(r[1:][same] * r[:-1][same]) / max(np.sum(r[1:][same] ** 2), 1e-300))
    rho = min(max(rho, 0.0), 0.99)
    return float(np.sqrt((1 + rho) / (1 - rho)))


def _blocks(geom: SatGeometry, opts: YawOptions) -> np.ndarray:
    t = geom.t_s
    if opts.block_s is None:
        return np.arange(len(t))
    if opts.block_s <= 0:
        return np.zeros(len(t), dtype=np.int64)
    return np.floor((t - t[0]) / opts.block_s).astype(np.int64)


def _rotated(a, b, base_rad):
    """Coefficients of cos(theta), sin(theta) when yaw = base + theta."""
    cb, sb = np.cos(base_rad), np.sin(base_rad)
    return a * cb + b * sb, b * cb - a * sb


def _grid_theta(y, w, a2, b2, blk, n_blocks, step_deg):
    """theta (n_blocks,) minimising sum w (y - a2 cos - b2 sin)^2 per block on a grid."""
    s = [np.bincount(blk, w * v, n_blocks) for v in (a2 * y, b2 * y, a2 * a2, a2 * b2, b2 * b2)]
    th = np.radians(np.arange(-180.0, 180.0, step_deg))
    c, sn = np.cos(th)[None, :], np.sin(th)[None, :]
    cost = (-2 * (s[0][:, None] * c + s[1][:, None] * sn) + s[2][:, None] * c * c
            + 2 * s[3][:, None] * c * sn + s[4][:, None] * sn * sn)
    return th[np.argmin(cost, axis=1)]


def _offsets(r, w, grp, n_groups):
    return np.bincount(grp, w * r, n_groups) / np.maximum(np.bincount(grp, w, n_groups), 1e-300)


def _normal(obs: DiffObs, r, J, w, blk, n_blocks, prior_w):
    """Blocks of the normal equations: D (n_blocks,), coupling entries, N_AA (n_groups,), right-hand sides."""
    n_g = obs.n_groups
    D = np.bincount(blk, w * J * J, n_blocks) + prior_w
    key = blk * n_g + obs.group
    uk, inv = np.unique(key, return_inverse=True)
    m_val = np.bincount(inv, w * J, len(uk))
    m_blk, m_grp = uk // n_g, uk % n_g
    naa = np.bincount(obs.group, w, n_g)
    rt = np.bincount(blk, w * J * r, n_blocks)
    ra = np.bincount(obs.group, w * r, n_g)
    return D, (m_blk, m_grp, m_val), naa, rt, ra


def _inverse(S, need_inverse: bool):
    """S^-1 (dense) when needed, else a solver; Cholesky, or the pseudo-inverse when S is singular (a
    constant the data cannot separate from the yaw, e.g. one station with per-epoch yaw)."""
    from scipy.linalg import LinAlgError, cho_factor, cho_solve

    try:
        f = cho_factor(S, lower=True, check_finite=False)
        if np.min(np.abs(np.diag(f[0]))) ** 2 < 1e-12 * np.max(np.abs(np.diag(S))):
            raise LinAlgError("near singular")
        if need_inverse:
            return cho_solve(f, np.eye(len(S)), check_finite=False)
        return lambda b: cho_solve(f, b, check_finite=False)
    except (LinAlgError, ValueError):
        return np.linalg.pinv(S, rcond=1e-12, hermitian=True)


def _schur(D, coup, naa, rt, ra, need_inverse: bool = False):
    """Solve for (d_theta, d_A); returns them with S^-1 (dense), 1/D and M = sqrt(1/D) N_tA (sparse)."""
    from scipy import sparse

    m_blk, m_grp, m_val = coup
    n_g = len(naa)
    Dinv = np.where(D > 0, 1.0 / np.where(D > 0, D, 1.0), 0.0)
    M = sparse.csr_matrix((m_val * np.sqrt(Dinv[m_blk]), (m_blk, m_grp)), shape=(len(D), n_g))
    S = np.diag(naa) - (M.T @ M).toarray()                      # S = N_AA - N_At N_tt^-1 N_tA
    rhs = ra - M.T @ (np.sqrt(Dinv) * rt)
    S_inv = _inverse(S, need_inverse)
    dA = S_inv(rhs) if callable(S_inv) else S_inv @ rhs
    dth = Dinv * rt - np.sqrt(Dinv) * (M @ dA)                  # N_tt^-1 (r_t - N_tA dA)
    return dth, dA, S_inv, Dinv, M


def _theta_variance(Dinv, S_inv, M, chunk: int = 4096):
    """diag of (N^-1)_tt = 1/D + diag(M S^-1 M^T) / D, in chunks of blocks (memory chunk x n_groups)."""
    var = Dinv.copy()
    for i in range(0, M.shape[0], chunk):
        Mi = M[i:i + chunk]
        var[i:i + chunk] += np.asarray((Mi @ S_inv) * Mi.toarray()).sum(axis=1) * Dinv[i:i + chunk]
    return var


def estimate_yaw(obs: DiffObs, geom: SatGeometry, baseline_body_m, model_yaw_deg,
                 options: YawOptions | None = None, *, pcv_m=None) -> YawEstimate:
    """YawEstimate of one satellite from `obs` with the baseline fixed (seed 004 eq. 9).

    Args:
        obs: differential rows; geom: per-epoch geometry; baseline_body_m: (3,) main -> aux antenna, body frame;
        model_yaw_deg: (T,) the attitude model's yaw (the base of offset blocks, the start of per-epoch yaw);
        pcv_m: (n,) differential PCV corrections subtracted from the phase rows (None: none).
    """
    opts = options or YawOptions()
    T = len(geom.t_s)
    blk_t = _blocks(geom, opts)
    n_blocks = int(blk_t.max()) + 1 if T else 0
    blk = blk_t[obs.epoch]
    y = obs.value_m - (0.0 if pcv_m is None else np.where(obs.is_code, 0.0, pcv_m))
    w = 1.0 / obs.sigma_m ** 2
    a, b, c = yaw_coefficients(geom.R_orbital_from_ecef[obs.epoch], obs.los_ecef, baseline_body_m, obs.k)
    per_epoch = opts.block_s is None
    base = np.radians(np.zeros(T) if per_epoch else np.asarray(model_yaw_deg, dtype=np.float64))
    a2, b2 = _rotated(a, b, base[obs.epoch])
    theta = np.radians(np.asarray(model_yaw_deg, dtype=np.float64)) if per_epoch else np.zeros(n_blocks)
    prior_w = 0.0 if opts.prior_sigma_deg is None else 1.0 / np.radians(opts.prior_sigma_deg) ** 2
    theta_prior = theta.copy()
    off = _offsets(y - c - a2 * np.cos(theta[blk]) - b2 * np.sin(theta[blk]), w, obs.group, obs.n_groups)
    for _ in range(opts.alternations):
        theta = _grid_theta(y - c - off[obs.group], w, a2, b2, blk, n_blocks, opts.grid_step_deg)
        off = _offsets(y - c - a2 * np.cos(theta[blk]) - b2 * np.sin(theta[blk]), w, obs.group, obs.n_groups)
    for _ in range(opts.iterations):
        f = a2 * np.cos(theta[blk]) + b2 * np.sin(theta[blk]) + c
        r = y - f - off[obs.group]
        J = -a2 * np.sin(theta[blk]) + b2 * np.cos(theta[blk])
        D, coup, naa, rt, ra = _normal(obs, r, J, w, blk, n_blocks, prior_w)
        rt = rt - prior_w * (theta - theta_prior)
        dth, dA, _, _, _ = _schur(D, coup, naa, rt, ra)
        theta = theta + np.clip(dth, -0.5, 0.5)
        off = off + dA
        if np.nanmax(np.abs(dth), initial=0.0) < 1e-7:       # 6e-6 deg
            break
    f = a2 * np.cos(theta[blk]) + b2 * np.sin(theta[blk]) + c
    r = y - f - off[obs.group]
    J = -a2 * np.sin(theta[blk]) + b2 * np.cos(theta[blk])
    D, coup, naa, rt, ra = _normal(obs, r, J, w, blk, n_blocks, prior_w)
    _, _, S_inv, Dinv, M = _schur(D, coup, naa, rt, ra, need_inverse=True)
    var = _theta_variance(Dinv, S_inv, M)
    n_par = n_blocks + obs.n_groups
    dof = max(len(r) - n_par, 1)
    sigma0 = float(np.sqrt(np.sum(w * r * r) / dof))
    ar1 = 1.0 if per_epoch else ar1_inflation(r, obs.group, obs.epoch)
    sig = np.degrees(np.sqrt(np.maximum(var, 0.0))) * sigma0 * ar1
    if not per_epoch and opts.systematic_m > 0:
        ph = ~obs.is_code
        Jc = J[ph] - (np.bincount(obs.group[ph], J[ph], obs.n_groups) /
                      np.maximum(np.bincount(obs.group[ph], None, obs.n_groups), 1))[obs.group[ph]]
        g = np.sqrt(np.bincount(blk[ph], Jc ** 2, n_blocks) / np.maximum(np.bincount(blk[ph], None, n_blocks), 1))
        with np.errstate(divide="ignore"):
            sys_deg = np.degrees(np.where(g > 0, opts.systematic_m / g, np.inf))
        sig = np.sqrt(sig ** 2 + sys_deg ** 2)
    yaw = wrap_deg(np.degrees(base + theta[blk_t]))
    n_sta = _stations_per_epoch(obs, T)
    R_eb = R_ecef_from_body(geom.R_orbital_from_ecef[obs.epoch], yaw[obs.epoch])
    obs_k = observability(obs.los_ecef, R_eb, baseline_body_m)
    rms_obs = np.sqrt(np.bincount(obs.epoch, obs_k ** 2, T) / np.maximum(np.bincount(obs.epoch, None, T), 1))
    seen = (np.bincount(obs.epoch, None, T) > 0) & (n_sta >= opts.min_stations) & (D[blk_t] > 0)
    sigma = np.where(seen, sig[blk_t], np.nan)
    yaw = np.where(seen, yaw, np.nan)
    return YawEstimate(yaw, sigma, wrap_deg(model_yaw_deg), n_sta, rms_obs, off, r, sigma0, blk_t, ar1)


def _stations_per_epoch(obs: DiffObs, T: int) -> np.ndarray:
    key = np.unique(obs.epoch * (len(obs.stations) + 1) + obs.station)
    return np.bincount(key // (len(obs.stations) + 1), None, T).astype(np.int64)
