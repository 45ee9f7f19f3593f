"""Baseline-constrained integer ambiguity search for attitude: C-LAMBDA (one baseline of known length) and
MC-LAMBDA (two or more baselines of known body geometry, the attitude matrix as unknown).

Problem (Teunissen 2006, 2010; Park & Teunissen 2003; Buist 2007; Giorgi et al. 2010, 2012). Given a float
solution of double-difference ambiguities ``a_hat`` (n,) and baselines ``b_hat`` (3q,) with covariance
``[[Q_a, Q_ab], [Q_ba, Q_b]]``, find

    a_check = argmin_{a in Z^n}  ||a_hat - a||^2_{Q_a}  +  min_{B in Omega} ||b_hat(a) - vec(B)||^2_{Q_b|a}

with ``b_hat(a) = b_hat - Q_ba Q_a^-1 (a_hat - a)`` and ``Q_b|a = Q_b - Q_ba Q_a^-1 Q_ab``, where
``||x||^2_Q = x^T Q^-1 x`` and the constraint set Omega is
- q = 1 (C-LAMBDA): the sphere ``|b| = l``;
- q >= 2 (MC-LAMBDA): ``B = R F`` with ``F = [f_1 .. f_q]`` the known body-frame baselines and ``R`` a rotation
  (``R^T R = I``, det R = +1); ``R`` is ``R_ecef_from_body`` when ``b_hat`` is in ECEF.

Search (own formulation of the "search and shrink" of Teunissen 2010 / Giorgi et al. 2010 with node bounds).
After the LAMBDA reduction ``Q_z = L^T D L`` (z = Z^T a), write ``u_k = zb_k - z_k`` for the conditional
residuals of the MLAMBDA tree; they are independent with variances d_k, and conditioning b on the fixed levels
``z_{k..n-1}`` gives

    b_hat(z_{k:}) = b_hat - sum_{j>=k} g_j u_j,      Q_b|z_{k:} = Q_b - sum_{j>=k} d_j g_j g_j^T,
    G = [g_0 .. g_{n-1}] = Q_bz L^-1 D^-1,           Q_bz = Q_ba Z.

By the chain rule for the joint quadratic form of (z, b), every completion of a node at level k costs at least

    dist_k + min_{B in Omega} ||b_hat(z_{k:}) - vec(B)||^2_{Q_b|z_{k:}}
      >= dist_k + c_k(b_hat(z_{k:})) / lambda_max(Q_b|z_{k:}),

with ``dist_k`` the MLAMBDA partial squared norm and ``c_k`` a closed-form Euclidean distance to Omega
(sphere: (|b| - l)^2; two baselines: min over O(3) of ||B - R F||_F^2 = ||B||^2 + ||F||^2 - 2 ||B F^T||_*;
more: the sum of the per-baseline length terms). A node is pruned when this bound reaches the current radius
(the m-th best full cost found, or the start radius); for one baseline a node passing it is also checked against
a lower bound of the exact cost-to-go min_{|b| = l} ||b_hat(z_{k:}) - b||^2_{Q_b|z_{k:}} (the Lagrangian dual of the
trust-region problem, ``_sphere_dual_bound``). A leaf's exact cost is evaluated (sphere: the trust-region secular
equation; rotation: damped Newton on SO(3) from the orthogonal Procrustes / Wahba SVD solution and, for coplanar
baselines, its mirror images, ``rotation_starts``), and the radius is expanded x4 (search and expand, Teunissen
2010 sec. 5) until the best and the second-best candidates (or a ratio cap) are inside. The result is the exact
minimiser for C-LAMBDA and, for MC-LAMBDA, exact up to the rotation fit being the global one.

Input layout (what a single-difference attitude EKF hands over; see docs/design/ambiguity_resolution.md):
ambiguities are double differences ordered by blocks, one block per (baseline, signal), each block ordered by
its satellites with the reference satellite removed; ``b`` stacks the q baselines (3 each, ECEF metres) in the
platform's baseline order. ``FloatSolution`` carries this layout; ``single_epoch_float`` builds one from one
epoch of double-difference phase and code, ``float_from_single_differences`` from an EKF state.
Units: cycles (ambiguities), metres (baselines), cycles^2 / m^2 / m*cycles (covariances).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from scipy.stats import chi2 as _chi2

from gnssatt.gnss.rotations import skew

from gnssatt.estimation.lambda_search import (
    AmbiguitySearchError, check_covariance, decorrelate,
)

__all__ = [
    "DDBlock", "FloatSolution", "ConstrainedResult",
    "dd_geometry", "dd_operator", "single_epoch_float", "float_from_single_differences",
    "constrained_search", "constrained_search_float", "constrained_search_by_baselines", "sphere_fit",
    "rotation_fit",
    "rotation_starts",
]

#: Start radius: the chi-square quantile of the full objective's degrees of freedom (n + constraint residual
#: dof) at this probability; the search expands x4 from there, so this only sets the first guess.
START_RADIUS_PROBABILITY = 0.999
#: Stop looking for the second-best candidate beyond this multiple of the best cost: the reported ratio is then
#: a lower bound (``second_bounded``). Set it to the acceptance threshold of the ratio test you apply: the
#: search radius, and with it the cost (nodes grow like radius^((n-3)/2)), is capped there. 3 (RTKLIB's ratio
#: threshold) keeps a single-epoch L1 MC-LAMBDA search of 2 x 9 ambiguities below ~1000 nodes; 10 needs up to
#: ~1e6 (measured in bench/bench_lambda.py).
RATIO_CAP_DEFAULT = 3.0
#: Node budget over all expansions (about 10 us per node in this pure-Python search: ~3 s). When it runs out
#: while expanding for the second candidate, the result of the last complete radius is returned (second bounded).
CONSTRAINED_MAX_NODES_DEFAULT = 300_000


# ----------------------------------------------------------------------------------------------- layout ---
@dataclass(frozen=True)
class DDBlock:
    """One block of double differences: one baseline, one signal, satellites ``sats`` against ``ref_sat``."""

    baseline: int                 # index into the platform's baselines (0..q-1)
    signal: str                   # e.g. "L1C"; blocks of different signals have independent noise
    wavelength_m: float
    sats: tuple                   # (n_dd,) satellite ids of the double differences, ref removed
    ref_sat: object               # reference satellite id
    geometry: np.ndarray = field(repr=False)  # (n_dd, 3): d(DD range)/d(b) = -(e_s - e_ref), ECEF unit vectors

    @property
    def n_dd(self) -> int:
        return len(self.sats)


@dataclass(frozen=True)
class FloatSolution:
    """A float solution of DD ambiguities and baselines in the layout of the module docstring."""

    a_float_cyc: np.ndarray       # (n,)
    b_float_m: np.ndarray         # (3q,) ECEF
    Q_a: np.ndarray               # (n, n) cycles^2
    Q_b: np.ndarray               # (3q, 3q) m^2
    Q_ab: np.ndarray              # (n, 3q) cycles*m
    blocks: tuple                 # DDBlock per ambiguity block, in order

    @property
    def n_baselines(self) -> int:
        return self.b_float_m.size // 3

    def ambiguity_slices(self) -> list[slice]:
        """Slice of ``a_float_cyc`` for each block."""
        out, i = [], 0
        for blk in self.blocks:
            out.append(slice(i, i + blk.n_dd))
            i += blk.n_dd
        return out

    def baseline(self, i: int) -> "FloatSolution":
        """The marginal float solution of baseline ``i``: its ambiguity blocks and its 3 coordinates."""
        idx = np.concatenate([np.arange(s.start, s.stop) for s, blk in zip(self.ambiguity_slices(), self.blocks)
                              if blk.baseline == i])
        jb = np.arange(3 * i, 3 * i + 3)
        blocks = tuple(DDBlock(0, b.signal, b.wavelength_m, b.sats, b.ref_sat, b.geometry)
                       for b in self.blocks if b.baseline == i)
        return FloatSolution(self.a_float_cyc[idx], self.b_float_m[jb], self.Q_a[np.ix_(idx, idx)],
                             self.Q_b[np.ix_(jb, jb)], self.Q_ab[np.ix_(idx, jb)], blocks)


def dd_geometry(los_unit_ecef: np.ndarray, ref_index: int) -> np.ndarray:
    """Return the (n_sats - 1, 3) double-difference geometry rows ``-(e_s - e_ref)`` for s != ref.

    Args:
        los_unit_ecef: (n_sats, 3) unit vectors from the platform to each satellite, ECEF.
        ref_index: row of the reference satellite.

    The single-difference range (second antenna minus first) of a baseline b is ``-e_s . b`` for a distant
    satellite (plane wave), so the DD range is ``-(e_s - e_ref) . b``.
    """
    e = np.asarray(los_unit_ecef, float)
    return -(np.delete(e, ref_index, axis=0) - e[ref_index])


def dd_operator(n_sats: int, ref_index: int) -> np.ndarray:
    """Return the (n_sats - 1, n_sats) matrix D with ``DD = D SD``: row s is e_s - e_ref (s != ref)."""
    D = np.delete(np.eye(n_sats), ref_index, axis=0)
    D[:, ref_index] = -1.0
    return D


def _dd_noise_cov(blocks: list[DDBlock], antenna_pairs: list[tuple], sigma_by_signal: dict) -> np.ndarray:
    """Covariance (in the units of ``sigma_by_signal``, squared) of stacked DD blocks for undifferenced noise.

    The single difference of baseline i is (second antenna - first antenna), so with independent undifferenced
    noise of equal sigma on every antenna, Cov(SD_i(s), SD_j(t)) = sigma^2 [s == t] c_ij with
    c_ij = [2nd_i == 2nd_j] + [1st_i == 1st_j] - [2nd_i == 1st_j] - [1st_i == 2nd_j]; DD rows subtract the
    reference satellite. Different signals are independent.
    """
    sizes = [b.n_dd for b in blocks]
    n = sum(sizes)
    C = np.zeros((n, n))
    offs = np.cumsum([0] + sizes)
    for i, bi in enumerate(blocks):
        fi, si = antenna_pairs[bi.baseline]
        for j, bj in enumerate(blocks):
            if bi.signal != bj.signal:
                continue
            fj, sj = antenna_pairs[bj.baseline]
            c = (si == sj) + (fi == fj) - (si == fj) - (fi == sj)
            if c == 0:
                continue
            s_i = np.array(bi.sats, dtype=object)[:, None]
            s_j = np.array(bj.sats, dtype=object)[None, :]
            blk = ((s_i == s_j).astype(float) - (s_i == bj.ref_sat) - (bi.ref_sat == s_j)
                   + float(bi.ref_sat == bj.ref_sat))
            C[offs[i]:offs[i + 1], offs[j]:offs[j + 1]] = c * sigma_by_signal[bi.signal] ** 2 * blk
    return C


def single_epoch_float(blocks: list[DDBlock], phase_dd_cyc: list[np.ndarray], code_dd_m: list[np.ndarray],
                       antenna_pairs: list[tuple], sigma_phase_m: float | dict = 0.003,
                       sigma_code_m: float | dict = 0.3) -> FloatSolution:
    """Return the single-epoch weighted least-squares float solution of DD ambiguities and baselines.

    Model per block (baseline i, signal with wavelength lambda):  phase_dd_cyc = G b_i / lambda + a + e_phi,
    code_dd_m = G b_i + e_P, with G the block's ``geometry``.

    Args:
        blocks: DD blocks (see ``DDBlock``); every baseline 0..q-1 must appear.
        phase_dd_cyc, code_dd_m: per block, (n_dd,) observed DD carrier phase (cycles) and code (m).
        antenna_pairs: per baseline (first, second) antenna ids (baseline = second - first).
        sigma_phase_m, sigma_code_m: undifferenced (per antenna) noise sigma, metres; a float or a dict by
            signal. A single difference has sqrt(2) times these.

    Implements: the standard single-epoch DD float model (Teunissen 1995 sec. 2; Teunissen 2010 eq. 1-3).
    Neglects: troposphere/ionosphere (short baselines), multipath, phase-centre variations.
    """
    q = 1 + max(b.baseline for b in blocks)
    signals = {b.signal for b in blocks}
    sp = sigma_phase_m if isinstance(sigma_phase_m, dict) else {s: sigma_phase_m for s in signals}
    sc = sigma_code_m if isinstance(sigma_code_m, dict) else {s: sigma_code_m for s in signals}
    n = sum(b.n_dd for b in blocks)
    # phase rows in metres first (common covariance helper), scaled to cycles afterwards
    lam = np.concatenate([np.full(b.n_dd, b.wavelength_m) for b in blocks])
    C_phi = _dd_noise_cov(blocks, antenna_pairs, sp) / np.outer(lam, lam)
    C_code = _dd_noise_cov(blocks, antenna_pairs, sc)
    A = np.zeros((2 * n, n + 3 * q))
    off = 0
    for blk in blocks:
        rows = slice(off, off + blk.n_dd)
        cols_b = slice(n + 3 * blk.baseline, n + 3 * blk.baseline + 3)
        A[rows, off:off + blk.n_dd] = np.eye(blk.n_dd)
        A[rows, cols_b] = blk.geometry / blk.wavelength_m
        A[n + off:n + off + blk.n_dd, cols_b] = blk.geometry
        off += blk.n_dd
    y = np.concatenate([np.concatenate(phase_dd_cyc), np.concatenate(code_dd_m)])
    # weights: phase and code independent; W = blockdiag(C_phi, C_code)^-1 through Cholesky factors
    Wphi = np.linalg.inv(C_phi)
    Wcode = np.linalg.inv(C_code)
    N = A[:n].T @ Wphi @ A[:n] + A[n:].T @ Wcode @ A[n:]
    rhs = A[:n].T @ Wphi @ y[:n] + A[n:].T @ Wcode @ y[n:]
    Qx = np.linalg.inv(N)
    Qx = 0.5 * (Qx + Qx.T)
    x = Qx @ rhs
    return FloatSolution(a_float_cyc=x[:n], b_float_m=x[n:], Q_a=Qx[:n, :n], Q_b=Qx[n:, n:], Q_ab=Qx[:n, n:],
                         blocks=tuple(blocks))


def float_from_single_differences(x: np.ndarray, P: np.ndarray, sd_indices: list[np.ndarray],
                                  baseline_indices: list[np.ndarray], blocks: list[DDBlock],
                                  ref_positions: list[int]) -> FloatSolution:
    """Return the DD float solution from a single-difference EKF state.

    Args:
        x: (n_state,) EKF state, P: (n_state, n_state) its covariance.
        sd_indices: per block, (n_sats,) state indices of its single-difference ambiguities (cycles), in the
            order of the block's satellites with the reference *included* at ``ref_positions[i]``.
        baseline_indices: per baseline, the 3 state indices of its ECEF vector (metres).
        blocks: DD blocks (``sats`` without the reference, as ``dd_operator`` orders them).
        ref_positions: per block, the position of the reference satellite in ``sd_indices[i]``.

    Implements: a_dd = D a_sd, Q_a = D P_sd D^T, Q_ab = D P_sd,b (seed 000 sec. 2: "double-differences are
    formed from the float single-difference ambiguities and their associated covariance matrix").
    """
    n_state = x.size
    rows = []
    for idx, r in zip(sd_indices, ref_positions):
        D = dd_operator(len(idx), r)
        T = np.zeros((D.shape[0], n_state))
        T[:, np.asarray(idx)] = D
        rows.append(T)
    T = np.vstack(rows)
    jb = np.concatenate([np.asarray(i) for i in baseline_indices])
    return FloatSolution(a_float_cyc=T @ x, b_float_m=x[jb].copy(), Q_a=T @ P @ T.T, Q_b=P[np.ix_(jb, jb)].copy(),
                         Q_ab=T @ P[:, jb], blocks=tuple(blocks))


# ------------------------------------------------------------------------------------- constraint fits ---
def sphere_fit(b_hat_m: np.ndarray, W: np.ndarray, length_m: float) -> tuple[float, np.ndarray]:
    """Return ``(cost, b)``: ``min_{|b| = l} (b_hat - b)^T W (b_hat - b)`` and its minimiser.

    Args:
        b_hat_m: (3,) unconstrained baseline, metres. W: (3, 3) weight (inverse covariance), 1/m^2.
        length_m: the known length l.

    Implements: the trust-region secular equation (More & Sorensen 1983; Teunissen 2010 eq. 14): with
    W = V diag(w) V^T and c = V^T b_hat, b(mu) = V y, y_i = w_i c_i / (w_i + mu); the global minimiser is the
    unique root mu > -w_min of |y(mu)| = l, found by Newton on 1/|y(mu)| - 1/l safeguarded by bisection.
    """
    w, V = np.linalg.eigh(W)
    return _sphere_fit_eig(np.asarray(b_hat_m, float), w, V, length_m)


def _sphere_fit_eig(b_hat_m: np.ndarray, w: np.ndarray, V: np.ndarray, length_m: float) -> tuple[float, np.ndarray]:
    """``sphere_fit`` with W = V diag(w) V^T given (w ascending)."""
    c = V.T @ b_hat_m
    wc = w * c
    lo = -w[0]
    # |y(mu)| <= |w c| / (w_min + mu): an upper bracket where |y| <= l
    hi = -w[0] + float(np.linalg.norm(wc)) / length_m + 1e-300
    mu = 0.0 if lo < 0.0 < hi else 0.5 * (lo + hi)      # mu = 0 is the unconstrained b_hat
    for _ in range(100):
        den = w + mu
        if np.any(den <= 0.0):
            mu = 0.5 * (lo + hi)
            continue
        y = wc / den
        ny = float(np.linalg.norm(y))
        f = ny - length_m
        if f > 0.0:
            lo = mu
        else:
            hi = mu
        if abs(f) <= 1e-13 * length_m:
            break
        # Newton on phi(mu) = 1/|y| - 1/l (almost linear in mu): phi' = (sum y_i^2/(w_i+mu)) / |y|^3
        dphi = float(np.sum(y * y / den)) / ny ** 3
        step = (1.0 / ny - 1.0 / length_m) / dphi
        mu_new = mu + step
        mu = mu_new if lo < mu_new < hi else 0.5 * (lo + hi)
    y = wc / (w + mu)
    y *= length_m / np.linalg.norm(y)
    b = V @ y
    cr = c - y                                           # b_hat - b in the eigenbasis of W
    return float(np.sum(w * cr * cr)), b


def _sphere_dual_bound(b: list, w: list, Vt: list, length_m: float, iterations: int = 10) -> float:
    """A lower bound of ``min_{|x| = l} (b - x)^T W (b - x)``, W = V diag(w) V^T (w ascending, > 0), in plain
    floats (the C-LAMBDA node bound; numpy's per-call overhead dominates at 3 elements).

    Implements: the Lagrangian dual of the trust-region problem, g(mu) = sum_i mu w_i c_i^2 / (w_i + mu) - mu l^2
    for mu > -w_min, c = V^T b: every such mu gives g(mu) <= the minimum (weak duality; equal at the root of the
    secular equation, strong duality of the trust-region problem, More & Sorensen 1983). A few safeguarded
    Newton steps on 1/|y(mu)| - 1/l towards the root, then g at the last feasible mu.
    """
    c = [Vt[i][0] * b[0] + Vt[i][1] * b[1] + Vt[i][2] * b[2] for i in range(3)]
    wc = [w[i] * c[i] for i in range(3)]
    lo = -w[0]
    hi = -w[0] + math.sqrt(wc[0] * wc[0] + wc[1] * wc[1] + wc[2] * wc[2]) / length_m + 1e-300
    mu = 0.0 if lo < 0.0 < hi else 0.5 * (lo + hi)
    for _ in range(iterations):
        den = [w[i] + mu for i in range(3)]
        if den[0] <= 0.0:
            mu = 0.5 * (lo + hi)
            continue
        y = [wc[i] / den[i] for i in range(3)]
        ny = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
        if ny > length_m:
            lo = mu
        else:
            hi = mu
        if ny == 0.0:
            break
        dphi = (y[0] * y[0] / den[0] + y[1] * y[1] / den[1] + y[2] * y[2] / den[2]) / ny ** 3
        mu_new = mu + (1.0 / ny - 1.0 / length_m) / dphi
        mu = mu_new if lo < mu_new < hi else 0.5 * (lo + hi)
    if w[0] + mu <= 0.0:
        return 0.0
    g = sum(mu * w[i] * c[i] * c[i] / (w[i] + mu) for i in range(3)) - mu * length_m * length_m
    return max(g, 0.0)


def _metric_eig(w: np.ndarray, V: np.ndarray) -> np.ndarray:
    """(4, 3) float64 C-contiguous: row 0 = the eigenvalues w of W = V diag(w) V^T, rows 1-3 = V^T (the argument
    ``metric_eig`` of ``_sphere_dual_bound_nb``)."""
    return np.ascontiguousarray(np.vstack([np.asarray(w, np.float64), np.asarray(V, np.float64).T]))


@njit(cache=True, nogil=True)
def _sphere_dual_bound_nb(b0: float, b1: float, b2: float, metric_eig: np.ndarray, length_m: float, three: float,
                          iterations: int = 10) -> float:
    """``_sphere_dual_bound`` compiled, on the centre's scalars and the metric's eigen-decomposition
    ``metric_eig`` (4, 3) float64 (``_metric_eig``: row 0 = w ascending, rows 1-3 = V^T); the same IEEE
    operations in the same order, ``ny ** 3`` as pow(ny, three) with three = 3.0 given at run time, as Python
    computes it. The C-LAMBDA DFS calls it at every node (~250,000 calls in a 200-start ttff job's 12 sets):
    ~25 us in Python, ~2 us here (one array argument dispatches faster than twelve floats or a namedtuple).
    tests/estimation/test_constrained_few_satellites.py compares it with the Python one.

    Implements: the Lagrangian dual bound of the trust-region problem (More & Sorensen 1983), as
    ``_sphere_dual_bound``."""
    w0, w1, w2 = metric_eig[0, 0], metric_eig[0, 1], metric_eig[0, 2]
    v00, v01, v02 = metric_eig[1, 0], metric_eig[1, 1], metric_eig[1, 2]
    v10, v11, v12 = metric_eig[2, 0], metric_eig[2, 1], metric_eig[2, 2]
    v20, v21, v22 = metric_eig[3, 0], metric_eig[3, 1], metric_eig[3, 2]
    c0 = v00 * b0 + v01 * b1 + v02 * b2
    c1 = v10 * b0 + v11 * b1 + v12 * b2
    c2 = v20 * b0 + v21 * b1 + v22 * b2
    wc0, wc1, wc2 = w0 * c0, w1 * c1, w2 * c2
    lo = -w0
    hi = -w0 + math.sqrt(wc0 * wc0 + wc1 * wc1 + wc2 * wc2) / length_m + 1e-300
    mu = 0.0 if lo < 0.0 < hi else 0.5 * (lo + hi)
    for _ in range(iterations):
        d0, d1, d2 = w0 + mu, w1 + mu, w2 + mu
        if d0 <= 0.0:
            mu = 0.5 * (lo + hi)
            continue
        y0, y1, y2 = wc0 / d0, wc1 / d1, wc2 / d2
        ny = math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
        if ny > length_m:
            lo = mu
        else:
            hi = mu
        if ny == 0.0:
            break
        dphi = (y0 * y0 / d0 + y1 * y1 / d1 + y2 * y2 / d2) / math.pow(ny, three)
        mu_new = mu + (1.0 / ny - 1.0 / length_m) / dphi
        mu = mu_new if lo < mu_new < hi else 0.5 * (lo + hi)
    if w0 + mu <= 0.0:
        return 0.0
    g = (mu * w0 * c0 * c0 / (w0 + mu) + mu * w1 * c1 * c1 / (w1 + mu) + mu * w2 * c2 * c2 / (w2 + mu)
         - mu * length_m * length_m)
    return max(g, 0.0)


def _procrustes(B: np.ndarray, F: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Rotation R (det +1) minimising sum_i w_i |b_i - R f_i|^2 (Wahba; Markley 1988 SVD). B, F: (q, 3)."""
    M = (B * weights[:, None]).T @ F                    # sum_i w_i b_i f_i^T
    U, _, Vt = np.linalg.svd(M)
    s = np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0
    return U @ np.diag([1.0, 1.0, s]) @ Vt


def _exp_so3(theta: np.ndarray) -> np.ndarray:
    ang = float(np.linalg.norm(theta))
    if ang == 0.0:
        return np.eye(3)
    K = skew(theta / ang)
    return np.eye(3) + math.sin(ang) * K + (1.0 - math.cos(ang)) * (K @ K)


def _gauss_newton_rotation(bh: np.ndarray, W: np.ndarray, F: np.ndarray, R: np.ndarray,
                           iterations: int) -> tuple[float, np.ndarray]:
    """Damped Newton on SO(3) from R for min r^T W r, r = bh - vec(R F) (left perturbation exp([theta x]) R;
    Gauss-Newton where the Newton matrix is not positive definite): a step is halved until the cost does not
    increase (plain Gauss-Newton oscillated and converged slowly on large-residual problems: short baselines
    against their errors)."""
    def cost(Rm):
        r = bh - (F @ Rm.T).reshape(-1)
        return float(r @ W @ r)
    c = cost(R)
    for _ in range(iterations):
        RF = F @ R.T                                     # (q, 3) rows R f_i
        r = bh - RF.reshape(-1)
        J = np.vstack([skew(v) for v in RF])            # d r / d theta = [R f_i x]
        H = J.T @ W @ J
        g = J.T @ W @ r
        # Newton: the residual's curvature, r' = r + J theta - theta x (theta x R f_i) / 2 + ..., adds -M to
        # the Gauss-Newton matrix, M = sum_i sym(w_i v_i^T) - (w_i . v_i) I, w = W r, v_i = R f_i
        w = (W @ r).reshape(-1, 3)
        M = sum(0.5 * (np.outer(wi, vi) + np.outer(vi, wi)) - float(wi @ vi) * np.eye(3) for wi, vi in zip(w, RF))
        try:
            Hn = H - M
            theta = -np.linalg.solve(Hn, g) if np.linalg.eigvalsh(Hn)[0] > 0.0 else -np.linalg.solve(H, g)
        except np.linalg.LinAlgError:
            break
        if float(np.linalg.norm(theta)) < 1e-12:
            break
        for _ in range(12):
            R_new = _exp_so3(theta) @ R
            c_new = cost(R_new)
            if c_new <= c:
                break
            theta = 0.5 * theta
        else:
            break
        done = c - c_new <= 1e-14 * max(c, 1e-300) and float(np.linalg.norm(theta)) < 1e-9
        R, c = R_new, c_new
        if done:
            break
    return c, R


def _exp_so3_batch(theta: np.ndarray) -> np.ndarray:
    """(k, 3) rotation vectors -> (k, 3, 3) rotation matrices (Rodrigues)."""
    ang = np.linalg.norm(theta, axis=1)
    safe = np.where(ang > 0.0, ang, 1.0)
    K = skew(theta / safe[:, None])
    s, c = np.sin(ang)[:, None, None], (1.0 - np.cos(ang))[:, None, None]
    return np.eye(3) + s * K + c * (K @ K)


def _newton_rotation_batch(bh: np.ndarray, W: np.ndarray, F: np.ndarray, Rs: np.ndarray,
                           iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """``_gauss_newton_rotation`` from k starts at once (numpy over the starts): (costs (k,), R (k, 3, 3))."""
    q = F.shape[0]
    I3 = np.eye(3)

    def cost(Rm):
        r = bh - np.einsum("kij,qj->kqi", Rm, F).reshape(len(Rm), 3 * q)
        return np.einsum("ki,ij,kj->k", r, W, r), r

    c, r = cost(Rs)
    active = np.ones(len(Rs), bool)
    for _ in range(iterations):
        RF = np.einsum("kij,qj->kqi", Rs, F)                         # (k, q, 3)
        J = skew(RF).reshape(len(Rs), 3 * q, 3)               # d r / d theta = [R f_i x]
        WJ = W @ J                                                    # (k, 3q, 3)
        H = np.einsum("kai,kaj->kij", J, WJ)
        g = np.einsum("kai,ka->ki", WJ, r)
        w = (r @ W).reshape(len(Rs), q, 3)
        wv = np.einsum("kqi,kqj->kij", w, RF)
        M = 0.5 * (wv + np.swapaxes(wv, 1, 2)) - np.einsum("kqi,kqi->k", w, RF)[:, None, None] * I3
        Hn = H - M
        pd = np.linalg.eigvalsh(Hn)[:, 0] > 0.0
        Hs = np.where(pd[:, None, None], Hn, H)
        try:
            theta = -np.linalg.solve(Hs, g[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        theta[~active] = 0.0
        moved = np.zeros(len(Rs), bool)
        R_new, c_new, r_new = Rs, c, r
        todo = active & (np.linalg.norm(theta, axis=1) >= 1e-12)
        for _ in range(12):
            if not todo.any():
                break
            Rt = _exp_so3_batch(theta) @ Rs
            ct, rt = cost(Rt)
            ok = todo & (ct <= c)
            R_new = np.where(ok[:, None, None], Rt, R_new)
            c_new = np.where(ok, ct, c_new)
            r_new = np.where(ok[:, None], rt, r_new)
            moved |= ok
            todo &= ~ok
            theta[todo] *= 0.5
        done = ~moved | ((c - c_new <= 1e-14 * np.maximum(c, 1e-300)) & (np.linalg.norm(theta, axis=1) < 1e-9))
        Rs, c, r = R_new, c_new, r_new
        active &= ~done
        if not active.any():
            break
    return c, Rs


def rotation_starts(b_hat_m: np.ndarray, W: np.ndarray, body_baselines_m: np.ndarray) -> list[np.ndarray]:
    """Start rotations of ``rotation_fit``: the weighted Wahba / SVD solution R0, and, when the body baselines
    are coplanar (always for two), its mirror images across the planes normal to the eigenvectors e of the
    summed weight blocks: R = H_e R0 D, H_e = I - 2 e e^T (frame of b_hat), D = I - 2 n n^T (n normal to the
    baselines' plane in the body frame), a proper rotation with R f_i = H_e R0 f_i.

    Why: with an anisotropic W (baselines short against their errors, e.g. 10 cm CubeSat baselines with a
    poorly determined boresight component) the cost has a second basin at the configuration mirrored across
    the weak plane, which Gauss-Newton from R0 alone does not leave (a right integer vector then got 72
    instead of its 26 and lost to a wrong one: docs/ttff.md "Fewer satellites").
    """
    F = np.asarray(body_baselines_m, float).reshape(-1, 3)
    q = F.shape[0]
    B = np.asarray(b_hat_m, float).reshape(q, 3)
    wts = np.array([np.trace(W[3 * i:3 * i + 3, 3 * i:3 * i + 3]) for i in range(q)])
    R0 = _procrustes(B, F, wts)
    starts = [R0]
    _, sv, vt = np.linalg.svd(F)
    if q == 2 or (sv.size == 3 and sv[2] <= 1e-9 * sv[0]):
        n_body = vt[-1]
        D = np.eye(3) - 2.0 * np.outer(n_body, n_body)
        Wsum = sum(W[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(q))
        _, E = np.linalg.eigh(0.5 * (Wsum + Wsum.T))
        for e in E.T:
            starts.append((np.eye(3) - 2.0 * np.outer(e, e)) @ R0 @ D)
    return starts


def rotation_fit(b_hat_m: np.ndarray, W: np.ndarray, body_baselines_m: np.ndarray,
                 iterations: int = 8) -> tuple[float, np.ndarray]:
    """Return ``(cost, R)``: ``min_{R in SO(3)} r^T W r``, ``r = b_hat - vec(R F)``, and the minimising R.

    Args:
        b_hat_m: (3q,) stacked baselines (frame A), metres. W: (3q, 3q) weight, 1/m^2.
        body_baselines_m: (q, 3) the same baselines in the body frame, metres.
        iterations: Gauss-Newton iterations after each start.

    Returns:
        cost, R_a_from_body (3, 3) with b_i = R f_i.

    Implements: the weighted orthogonal Procrustes problem of MC-LAMBDA (Teunissen 2007; Giorgi et al. 2010
    eq. 9): Gauss-Newton with the left perturbation R <- exp([theta x]) R, d(R f)/d theta = -[R f x], from
    each of ``rotation_starts`` (the Wahba / SVD solution weighted per baseline by the trace of its W block and,
    for coplanar baselines, its mirror images across the weak planes); the lowest cost is returned.
    """
    F = np.asarray(body_baselines_m, float).reshape(-1, 3)
    bh = np.asarray(b_hat_m, float)
    W = np.asarray(W, float)
    c, R = _newton_rotation_batch(bh, W, F, np.array(rotation_starts(bh, W, F)), iterations)
    i = int(np.argmin(c))
    return float(c[i]), R[i]


# -------------------------------------------------------------------------------------------- search ---
@dataclass(frozen=True)
class ConstrainedResult:
    """Best candidates of a baseline-constrained integer search, best first."""

    fixed: np.ndarray          # (k, n) int64 DD ambiguities, cycles, k <= m candidates found, best first
    costs: np.ndarray          # (k,) full costs: ILS term + constrained baseline term
    ils_sqnorm: np.ndarray     # (k,) the ILS term ||a_hat - a||^2_Qa of each
    cost: float                # costs[0]
    second_cost: float         # costs[1], or the search radius (a lower bound) when second_bounded
    second_bounded: bool       # True: no second candidate inside the final radius; ratio is a lower bound
    ratio: float               # second_cost / cost
    b_fixed_m: np.ndarray      # (3q,) constrained baseline(s) of the best candidate, frame of b_hat
    b_unconstrained_m: np.ndarray  # (3q,) b_hat(a) of the best candidate (conditional LS, no constraint)
    R_from_body: np.ndarray | None  # (3, 3) frame-of-b_hat-from-body rotation (q >= 2), else None
    n_nodes: int
    n_leaves: int
    radius: float              # final search radius


def _bound_sphere(length_m: float):
    def bound(b):
        r = math.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]) - length_m
        return r * r
    return bound


def _bound_two_baselines(F: np.ndarray):
    """min over O(3) of ||B - R F||_F^2 = |B|^2 + |F|^2 - 2 ||B F^T||_* for q = 2, in closed form."""
    f1, f2 = F[0], F[1]
    g11, g12, g22 = float(f1 @ f1), float(f1 @ f2), float(f2 @ f2)
    detG = g11 * g22 - g12 * g12
    fF = g11 + g22

    def bound(b):
        x1, y1, z1, x2, y2, z2 = b
        h11 = x1 * x1 + y1 * y1 + z1 * z1
        h22 = x2 * x2 + y2 * y2 + z2 * z2
        h12 = x1 * x2 + y1 * y2 + z1 * z2
        # nonzero singular values of B F^T: square roots of the eigenvalues of X = (B^T B)(F^T F) (2x2);
        # their sum is sqrt(tr X + 2 sqrt(det X))
        trX = h11 * g11 + 2.0 * h12 * g12 + h22 * g22
        detX = max((h11 * h22 - h12 * h12) * detG, 0.0)
        nuc = math.sqrt(max(trX + 2.0 * math.sqrt(detX), 0.0))
        return max(h11 + h22 + fF - 2.0 * nuc, 0.0)
    return bound


def _bound_lengths(lengths: np.ndarray):
    ls = [float(v) for v in lengths]
    q = len(ls)

    def bound(b):
        s = 0.0
        for i in range(q):
            x, y, z = b[3 * i], b[3 * i + 1], b[3 * i + 2]
            r = math.sqrt(x * x + y * y + z * z) - ls[i]
            s += r * r
        return s
    return bound


def constrained_search(a_float_cyc: np.ndarray, Q_a: np.ndarray, b_float_m: np.ndarray, Q_b: np.ndarray,
                       Q_ab: np.ndarray, body_baselines_m: np.ndarray, m: int = 2,
                       start_radius: float | None = None, ratio_cap: float = RATIO_CAP_DEFAULT,
                       max_nodes: int = CONSTRAINED_MAX_NODES_DEFAULT) -> ConstrainedResult:
    """Return the m best integer vectors of the baseline-constrained ILS problem (C-LAMBDA / MC-LAMBDA).

    Args:
        a_float_cyc: (n,) float DD ambiguities, cycles. Q_a: (n, n) cycles^2.
        b_float_m: (3q,) float baselines stacked, metres (ECEF in the attitude filter).
        Q_b: (3q, 3q) m^2. Q_ab: (n, 3q) cycles*m.
        body_baselines_m: (q, 3) body-frame baselines; q = 1 uses only the length (C-LAMBDA), q >= 2 the
            full geometry with the rotation as unknown (MC-LAMBDA).
        m: candidates wanted (2 for the ratio).
        start_radius: first search radius of the full cost; default the 0.999 chi-square quantile of
            n + (1 if q == 1 else 3q - 3) degrees of freedom.
        ratio_cap: stop expanding for the second candidate once the radius reaches ratio_cap x best cost.
        max_nodes: cap on visited nodes over all expansions: ``AmbiguitySearchError`` if no candidate was found
            by then, otherwise the last complete radius's result with ``second_bounded``.

    Implements: C-LAMBDA (Teunissen 2006, 2010 "Integer least-squares theory for the GNSS compass", J. Geodesy
    84:433-447; Park & Teunissen 2003; Buist 2007) and MC-LAMBDA (Teunissen 2007; Giorgi, Teunissen, Verhagen &
    Buist 2010, 2012) with the node bounds of the module docstring and search-and-expand.
    """
    a = np.asarray(a_float_cyc, float).reshape(-1)
    bh = np.asarray(b_float_m, float).reshape(-1)
    F = np.asarray(body_baselines_m, float).reshape(-1, 3)
    n, q = a.size, F.shape[0]
    if bh.size != 3 * q:
        raise ValueError(f"b_float has {bh.size} values for {q} body baselines")
    Q_a = check_covariance(Q_a, "Q_a")
    Q_b = check_covariance(Q_b, "Q_b")
    Q_ab = np.asarray(Q_ab, float)
    if Q_ab.shape != (n, 3 * q):
        raise ValueError(f"Q_ab has shape {Q_ab.shape}, expected ({n}, {3 * q})")
    lengths = np.linalg.norm(F, axis=1)

    dec = decorrelate(Q_a)
    Zf = dec.Z.astype(float)
    zs = Zf.T @ a                                         # z = Z^T a
    Q_bz = Q_ab.T @ Zf                                    # Cov(b, z) = Q_ba Z
    # L is unit lower triangular with |L_ij| <= 1/2 (size-reduced), so its inverse is well conditioned; numpy's
    # inv is ~100x faster here than scipy's solve_triangular call overhead for n <= 40 (measured: 0.03 vs 10 ms)
    Linv = np.linalg.inv(dec.L)
    G = (Q_bz @ Linv) / dec.d                             # G = Q_bz L^-1 D^-1, columns g_k
    lam_max = [0.0] * (n + 1)
    eig_k: list = [None] * (n + 1)                        # q = 1: eigen-decomposition of W_k = (Q_b|z_{k:})^-1
    Qk = Q_b.copy()
    lam_max[n] = float(np.linalg.eigvalsh(Qk)[-1])
    for k in range(n - 1, -1, -1):
        Qk = Qk - dec.d[k] * np.outer(G[:, k], G[:, k])  # Q_b|z_{k:} = Q_b|z_{k+1:} - d_k g_k g_k^T
        lq, Vq = np.linalg.eigh(0.5 * (Qk + Qk.T))
        lam_max[k] = max(float(lq[-1]), 1e-300)
        if q == 1 and lq[0] > 0.0:
            eig_k[k] = (1.0 / lq[::-1], Vq[:, ::-1])       # W_k eigenvalues ascending
    # the fully conditioned covariance of the leaf, directly (better conditioned than the recursion)
    Ca = np.linalg.cholesky(Q_a)
    K = np.linalg.solve(Ca.T, np.linalg.solve(Ca, Q_ab)).T     # Q_ba Q_a^-1
    Q_cond = Q_b - K @ Q_ab
    Q_cond = 0.5 * (Q_cond + Q_cond.T)
    W_leaf = np.linalg.inv(Q_cond)
    W_leaf = 0.5 * (W_leaf + W_leaf.T)

    tight_fn = None
    if q == 1:
        bound_fn = _bound_sphere(float(lengths[0]))

        def leaf_fn(b):
            return sphere_fit(np.array(b), W_leaf, float(lengths[0]))

        # per level: the metric's eigen-decomposition as one (4, 3) array for the compiled bound
        eig_py = [None if e is None else _metric_eig(e[0], e[1]) for e in eig_k]
        l0 = float(lengths[0])

        def tight_fn(k, b):
            # a lower bound of min_{|b| = l} ||b_hat(z_{k:}) - b||^2_{Q_b|z_{k:}} (module docstring)
            e = eig_py[k]
            return 0.0 if e is None else _sphere_dual_bound_nb(b[0], b[1], b[2], e, l0, 3.0)
        dof = n + 1
    else:
        bound_fn = _bound_two_baselines(F) if q == 2 else _bound_lengths(lengths)

        def leaf_fn(b):
            return rotation_fit(np.array(b), W_leaf, F)
        dof = n + 3 * q - 3
    radius = float(start_radius) if start_radius is not None else _start_radius(dof)

    total_nodes = 0
    total_leaves = 0
    found: list = []
    while True:
        try:
            found_r, nodes, leaves = _constrained_dfs(zs, dec.L, dec.d, G, lam_max, bh, bound_fn, leaf_fn, radius,
                                                      m, max_nodes - total_nodes, tight_fn)
        except _BudgetExhausted as exc:
            total_nodes += exc.nodes
            if not found:
                raise AmbiguitySearchError(f"constrained search exceeded {max_nodes} nodes before finding a "
                                           f"candidate (n = {n}, radius {radius:.3g})") from None
            radius = prev_radius                          # keep the last complete search: second bounded
            break
        found = found_r
        prev_radius = radius
        total_nodes += nodes
        total_leaves += leaves
        if len(found) >= m:
            break
        if found and radius >= ratio_cap * found[0][0]:
            break
        if not found:
            radius *= 4.0
        else:
            radius = min(4.0 * radius, ratio_cap * found[0][0])
    found.sort(key=lambda t: t[0])
    costs = np.array([f[0] for f in found])
    ils = np.array([f[1] for f in found])
    z_fixed = np.array([f[2] for f in found], dtype=np.int64)
    fixed = z_fixed @ dec.Z_inv                            # a = Z^-T z
    best_fit = found[0][4]
    if q == 1:
        b_fixed, R = best_fit[1], None
    else:
        R = best_fit[1]
        b_fixed = (F @ R.T).reshape(-1)
    if len(found) >= 2:
        second, bounded = float(costs[1]), False
    else:
        second, bounded = radius, True
    ratio = second / costs[0] if costs[0] > 0 else math.inf
    return ConstrainedResult(fixed=fixed, costs=costs, ils_sqnorm=ils, cost=float(costs[0]), second_cost=second,
                             second_bounded=bounded, ratio=float(ratio), b_fixed_m=b_fixed,
                             b_unconstrained_m=np.array(found[0][3]), R_from_body=R, n_nodes=total_nodes,
                             n_leaves=total_leaves, radius=radius)


@functools.lru_cache(maxsize=256)
def _start_radius(dof: int) -> float:
    """Chi-square quantile START_RADIUS_PROBABILITY of ``dof`` degrees of freedom (cached: scipy.stats is slow)."""
    return float(_chi2.ppf(START_RADIUS_PROBABILITY, dof))


class _BudgetExhausted(Exception):
    def __init__(self, nodes: int):
        super().__init__(nodes)
        self.nodes = nodes


def _constrained_dfs(zs, L, d, G, lam_max, b_hat, bound_fn, leaf_fn, radius, m, max_nodes, tight_fn=None):
    """Depth-first MLAMBDA enumeration with the constrained node bound; returns the m best inside ``radius``.

    Each found entry is (cost, ils_sqnorm, z list, b_hat(z) list, leaf fit). Levels as in
    ``lambda_search.search``; at each node the conditional baseline b_k = b_{k+1} - g_k u_k is updated and the
    node is skipped (its siblings still visited) when dist + c(b_k)/lambda_max_k >= the radius, or, with
    ``tight_fn(k, b_k)`` (C-LAMBDA: the exact distance to the sphere in the metric of Q_b|z_{k:}, a lower bound
    of every completion by the chain rule), when dist + tight_fn >= the radius (inner levels only).
    """
    n = len(zs)
    zs = [float(v) for v in zs]
    Lt = [[float(v) for v in row] for row in L.T]          # Lt[k][i] = L[i, k]
    inv_d = [1.0 / float(v) for v in d]
    Gt = [[float(v) for v in G[:, k]] for k in range(n)]
    inv_lam = [1.0 / v for v in lam_max]
    p = len(b_hat)
    floor = math.floor
    dist = [0.0] * (n + 1)
    bv: list[list[float]] = [[0.0] * p for _ in range(n + 1)]
    bv[n] = [float(v) for v in b_hat]
    zb = [0.0] * n
    z = [0] * n
    step = [0] * n
    found: list[tuple] = []
    max_dist = radius
    nodes = leaves = 0
    k = n - 1
    zb[k] = zs[k]
    z[k] = floor(zb[k] + 0.5)
    y = zb[k] - z[k]
    step[k] = 1 if y > 0.0 else -1
    while True:
        nodes += 1
        if nodes > max_nodes:
            raise _BudgetExhausted(nodes)
        new_dist = dist[k + 1] + y * y * inv_d[k]
        if new_dist >= max_dist:                           # ILS part alone too large: no sibling can do better
            if k == n - 1:
                break
            k += 1
            z[k] += step[k]
            y = zb[k] - z[k]
            step[k] = -step[k] - (1 if step[k] > 0 else -1)
            continue
        g = Gt[k]
        bp = bv[k + 1]
        b = [bp[i] - g[i] * y for i in range(p)]           # b_hat(z_{k:}) = b_hat(z_{k+1:}) - g_k u_k
        if new_dist + bound_fn(b) * inv_lam[k] < max_dist and (
                tight_fn is None or k == 0 or new_dist + tight_fn(k, b) < max_dist):
            if k != 0:
                dist[k] = new_dist
                bv[k] = b
                k -= 1
                lt = Lt[k]
                s = 0.0
                for i in range(k + 1, n):
                    s += lt[i] * (z[i] - zb[i])
                zb[k] = zs[k] + s
                z[k] = floor(zb[k] + 0.5)
                y = zb[k] - z[k]
                step[k] = 1 if y > 0.0 else -1
                continue
            leaves += 1
            cfit = leaf_fn(b)
            cost = new_dist + cfit[0]
            if cost < max_dist:
                if len(found) < m:
                    found.append((cost, new_dist, z.copy(), b, cfit))
                else:
                    imax = max(range(len(found)), key=lambda i: found[i][0])
                    found[imax] = (cost, new_dist, z.copy(), b, cfit)
                if len(found) == m:
                    max_dist = max(f[0] for f in found)
        # next sibling on this level (zig-zag)
        z[k] += step[k]
        y = zb[k] - z[k]
        step[k] = -step[k] - (1 if step[k] > 0 else -1)
    return found, nodes, leaves


def constrained_search_float(sol: FloatSolution, body_baselines_m: np.ndarray, **kwargs) -> ConstrainedResult:
    """``constrained_search`` on a ``FloatSolution`` (ambiguities of all its blocks, all its baselines)."""
    return constrained_search(sol.a_float_cyc, sol.Q_a, sol.b_float_m, sol.Q_b, sol.Q_ab, body_baselines_m,
                              **kwargs)


def constrained_search_by_baselines(a_float_cyc: np.ndarray, Q_a: np.ndarray, b_float_m: np.ndarray,
                                    Q_b: np.ndarray, Q_ab: np.ndarray, body_baselines_m: np.ndarray,
                                    rows_by_baseline: list, m_first: int = 3, ratio_cap: float = RATIO_CAP_DEFAULT,
                                    max_nodes: int = CONSTRAINED_MAX_NODES_DEFAULT,
                                    max_candidates: int = 200) -> ConstrainedResult:
    """Return the two best integer vectors of the MC-LAMBDA problem (q >= 2), exactly, from per-baseline C-LAMBDA
    candidate lists.

    Args:
        a_float_cyc .. body_baselines_m: as ``constrained_search``.
        rows_by_baseline: per baseline i, the indices of ``a_float_cyc`` that belong to it (a partition).
        m_first: C-LAMBDA candidates per baseline of the first pass.
        ratio_cap: the second candidate is looked for up to ratio_cap x the best cost (beyond: ``second_bounded``).
        max_nodes: budget of each C-LAMBDA search. max_candidates: per baseline; more inside the bound ->
            ``AmbiguitySearchError`` (the minimiser could not be proven).

    Bound (exactness). With x = (a, b) and J(a) = min_{R in SO(3)} ||x_hat - (a, vec(R F))||^2_{Q_x}, the
    Schur complement gives ||x||^2_{Q_x} >= ||x_i||^2_{Q_{x_i}} for the marginal x_i = (a_i, b_i) of baseline i,
    and {R f_i} is the sphere |b_i| = l_i, so J(a) >= C_i(a_i), the C-LAMBDA cost of baseline i on its own
    marginal float. Every joint candidate with J < r therefore has C_i(a_i) < r on every baseline: after a
    first pass gives the best J_1 and second J_2, each baseline's C-LAMBDA list is completed up to
    r = min(J_2, ratio_cap J_1) and every combination with max_i C_i < r is evaluated exactly (rotation_fit).

    Implements: MC-LAMBDA (Teunissen 2007; Giorgi, Teunissen, Verhagen & Buist 2010, 2012) by
    per-baseline C-LAMBDA (Teunissen 2010) with the marginal bound above (own formulation, cf. the
    "search and shrink" of Giorgi et al. 2010 sec. 4).
    """
    import itertools

    a_hat = np.asarray(a_float_cyc, float).reshape(-1)
    bh = np.asarray(b_float_m, float).reshape(-1)
    F = np.asarray(body_baselines_m, float).reshape(-1, 3)
    q, n = F.shape[0], a_hat.size
    if q < 2 or len(rows_by_baseline) != q:
        raise ValueError("need q >= 2 baselines and one row set per baseline")
    Q_a = check_covariance(Q_a, "Q_a")
    Q_b = check_covariance(Q_b, "Q_b")
    Q_ab = np.asarray(Q_ab, float)
    rows = [np.asarray(r, np.int64) for r in rows_by_baseline]
    C = np.linalg.cholesky(Q_a)
    K = np.linalg.solve(C.T, np.linalg.solve(C, Q_ab)).T                # Q_ba Q_a^-1 (3q, n)
    Qc = Q_b - K @ Q_ab
    W = np.linalg.inv(0.5 * (Qc + Qc.T))
    W = 0.5 * (W + W.T)
    nodes = leaves = 0
    joint: dict = {}

    def marginal(i, m, start_radius=None, cap=ratio_cap):
        r = rows[i]
        jb = np.arange(3 * i, 3 * i + 3)
        return constrained_search(a_hat[r], Q_a[np.ix_(r, r)], bh[jb], Q_b[np.ix_(jb, jb)], Q_ab[np.ix_(r, jb)],
                                  F[i:i + 1], m=m, start_radius=start_radius, ratio_cap=cap, max_nodes=max_nodes)

    def evaluate(combo, bound=math.inf):
        key = tuple(tuple(int(v) for v in c) for c in combo)
        if key in joint:
            return
        a = np.empty(n)
        for r, vec in zip(rows, combo):
            a[r] = vec
        da = a_hat - a
        y = np.linalg.solve(C, da)
        if float(y @ y) >= bound:              # J >= its ILS part >= bound: neither best nor second below bound
            return
        b = bh - K @ da
        c_rot, R = rotation_fit(b, W, F)
        joint[key] = (float(y @ y) + c_rot, float(y @ y), a, b, R)

    lists = []
    for i in range(q):
        res = marginal(i, m_first)
        nodes += res.n_nodes
        leaves += res.n_leaves
        complete = res.radius if res.fixed.shape[0] < m_first else float(res.costs[-1])
        lists.append([list(zip(res.costs, res.fixed)), complete])
    for combo in itertools.product(*[[v for _, v in lst] for lst, _ in lists]):
        evaluate(combo)
    best = sorted(joint.values(), key=lambda t: t[0])
    bound = min(best[1][0] if len(best) > 1 else math.inf, ratio_cap * best[0][0])
    for i in range(q):
        lst, complete = lists[i]
        if complete >= bound:
            continue
        c0 = float(lst[0][0])
        cap = max(bound / c0 * (1.0 + 1e-9), 1.0) if c0 > 0 else math.inf
        m = len(lst)
        while complete < bound:                  # more candidates until the list is complete up to the bound
            m = 2 * m
            if m > max_candidates:
                raise AmbiguitySearchError(f"more than {max_candidates} C-LAMBDA candidates of baseline {i} below "
                                           f"the joint bound {bound:.3g}")
            res = marginal(i, m, cap=cap)
            nodes += res.n_nodes
            leaves += res.n_leaves
            complete = res.radius if res.fixed.shape[0] < m else float(res.costs[-1])
            if complete < bound and res.fixed.shape[0] < m:
                raise AmbiguitySearchError(f"C-LAMBDA of baseline {i} ran out of nodes below the joint bound")
        lists[i] = [list(zip(res.costs, res.fixed)), bound]
    pruned = [[v for c, v in lst if c < bound] for lst, _ in lists]
    cost_of = [{tuple(int(x) for x in v): float(c) for c, v in lst} for lst, _ in lists]
    for combo in itertools.product(*pruned):
        if max(cost_of[i][tuple(int(x) for x in v)] for i, v in enumerate(combo)) < bound:
            evaluate(combo, bound)
    best = sorted(joint.values(), key=lambda t: t[0])
    cost = best[0][0]
    if len(best) > 1 and best[1][0] < ratio_cap * cost:
        second, bounded = best[1][0], False
    else:
        second, bounded = ratio_cap * cost, True
    top = best[:2] if not bounded else best[:1]
    R = best[0][4]
    return ConstrainedResult(fixed=np.array([np.rint(t[2]).astype(np.int64) for t in top]),
                             costs=np.array([t[0] for t in top]), ils_sqnorm=np.array([t[1] for t in top]),
                             cost=float(cost), second_cost=float(second), second_bounded=bounded,
                             ratio=float(second / cost) if cost > 0 else math.inf,
                             b_fixed_m=(F @ R.T).reshape(-1), b_unconstrained_m=best[0][3], R_from_body=R,
                             n_nodes=nodes, n_leaves=leaves, radius=float(bound))
