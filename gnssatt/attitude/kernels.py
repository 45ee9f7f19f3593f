"""Compiled (numba) kernels of the attitude filter's per-epoch quality control: the median-referenced triple
differences and the white-noise / C/N0-growth estimators of gnssatt.attitude.filter.run_filter.

Each kernel does, in one call, what the filter did with a few dozen numpy calls on arrays of a few dozen elements,
and gives the same bits: the same element-wise IEEE operations, sums in numpy's pairwise order (`np_sum`),
medians from sorted values as numpy computes them, and ``x ** 2`` of a numpy scalar through the C library's pow
(math.pow with the exponent given at run time, see POW2: numpy's scalar power calls pow, while x * x differs
from it in the last bit for ~1 value in 1000).
Transcendental functions of arrays (log, exp) stay in numpy. tests/attitude/test_attitude_kernels.py compares
every kernel with the numpy code it replaces on random inputs.

Specification: the readable numpy form in gnssatt.attitude.reference_noise (white-noise and C/N0-growth
estimators: update_white_noise, update_cn0_growth; docs/attitude.md noise model) and reference_update
(measurement_rows: seed 000 eq. 1 in sparse-row form); tests/attitude/test_attitude_kernels.py and the
reference tests check each kernel against them with tolerances in physical units.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gnssatt.attitude.qc_records import TripleDifferences, WhiteNoise
from gnssatt.attitude.update_records import StateLayout, UpdateObs, UsedRows

__all__ = ["POW2", "np_sum", "count_pairs_masked", "masked_median_axis1", "measurement_rows", "cn0_growth_samples", "cn0_growth_update", "white_noise_update",
           "warm_up"]

#: the exponent of the squares below, passed to the kernels at run time (a compile-time 2.0 would let LLVM turn
#: pow(x, 2.0) into x * x, not what numpy's scalar power computes)
POW2 = 2.0


@njit(cache=True, nogil=True)
def _pairwise_block(a, lo, n):
    """numpy's pairwise_sum of a[lo:lo + n] for n <= 128: sequential below 8, else 8 partial sums."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True, nogil=True)
def np_sum(a):
    """Sum of a contiguous 1-D float64 array in numpy's pairwise order (numpy's pairwise_sum: 8 partial sums in
    blocks of up to 128, above that the halves split at a multiple of 8, left + right), so it equals ndarray.sum()
    bit for bit. The halving is an explicit stack (numba's cache does not load recursive functions safely)."""
    n = a.size
    if n <= 128:
        return _pairwise_block(a, 0, n)
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    state = np.zeros(64, np.int64)          # 0 new, 1 left half pending, 2 right half pending
    left = np.empty(64)
    top = 0
    los[0], ns[0], state[0] = 0, n, 0
    v = 0.0
    have_v = False
    while True:
        if not have_v:
            lo, m = los[top], ns[top]
            if m <= 128:
                v = _pairwise_block(a, lo, m)
                have_v = True
                top -= 1
            else:
                n2 = m // 2
                n2 -= n2 % 8
                state[top] = 1
                top += 1
                los[top], ns[top], state[top] = lo, n2, 0
        else:
            if top < 0:
                return v
            if state[top] == 1:
                left[top] = v
                state[top] = 2
                have_v = False
                lo, m = los[top], ns[top]
                n2 = m // 2
                n2 -= n2 % 8
                top += 1
                los[top], ns[top], state[top] = lo + n2, m - n2, 0
            else:
                v = left[top] + v
                top -= 1


@njit(cache=True, nogil=True)
def _median_sorted(srt, n):
    """np.median of the n sorted values srt[:n] (mean of the two middle ones as (a + b) / 2 for even n)."""
    h = n // 2
    if n % 2:
        return srt[h]
    return (srt[h - 1] + srt[h]) / 2.0


@njit(cache=True, nogil=True)
def masked_median_axis1(a, ok):
    """(n0, n2) median over axis 1 of a (n0, n1, n2) where ok and not NaN, NaN where none:
    gnssatt.attitude.fastops.nanmedian1 of np.where(ok, a, nan) (= np.nanmedian(axis=1); 0.5 * (lo + hi) of the
    sorted values, as there)."""
    n0, n1, n2 = a.shape
    out = np.empty((n0, n2))
    buf = np.empty(n1)
    for i in range(n0):
        for f in range(n2):
            n = 0
            for s in range(n1):
                if ok[i, s, f] and not np.isnan(a[i, s, f]):
                    buf[n] = a[i, s, f]
                    n += 1
            if n == 0:
                out[i, f] = np.nan
                continue
            srt = np.sort(buf[:n])
            lo = max((n - 1) // 2, 0)
            hi = max(n // 2, 0)
            out[i, f] = 0.5 * (srt[lo] + srt[hi])
    return out


@njit(cache=True, nogil=True)
def cn0_growth_samples(td_c, td_p, ok_c, ok_p, mc, mp, lw, lam):
    """Samples of the C/N0-growth regression per (signal f, observable kk = 0 code / 1 phase), group g = 2 f + kk:
    (x (N,) = ln C/N0 factor, r (N,) = |TD - median TD|, offsets (2 n_sig + 1,)), group g = x[off[g]:off[g + 1]].

    The selection of run_filter's gamma estimator: TDs passing the test mask, the median (NaN -> 0) removed,
    kept when 0 < r < 5 m (code) or < one wavelength (phase); baseline-major, then satellite, as numpy's boolean
    indexing orders them.
    """
    n_bl, n_sat, n_sig = td_c.shape
    xs = np.empty(2 * n_bl * n_sat * n_sig)
    rs = np.empty(2 * n_bl * n_sat * n_sig)
    off = np.zeros(2 * n_sig + 1, np.int64)
    p = 0
    for f in range(n_sig):
        for kk in range(2):
            td = td_c if kk == 0 else td_p
            ok = ok_c if kk == 0 else ok_p
            mref = mc if kk == 0 else mp
            big = 5.0 if kk == 0 else lam[f]
            for j in range(n_bl):
                m = mref[j, f]
                if np.isnan(m):
                    m = 0.0
                for s in range(n_sat):
                    if ok[j, s, f]:
                        r = np.abs(td[j, s, f] - m)
                        if r < big and r > 0:
                            xs[p] = lw[j, s, f]
                            rs[p] = r
                            p += 1
            off[2 * f + kk + 1] = p
    return xs[:p], rs[:p], off


@njit(cache=True, nogil=True)
def cn0_growth_update(xs, ys, off, mom, gam_n, gamma, noise_epochs, min_epochs, min_var, pow2):
    """In place: the pooled moments (mean x, mean y, mean x^2, mean x y; exponential memory noise_epochs) of each
    group with >= 3 samples (y = ln r), and the exponent gamma = clip(2 cov(x, y) / var(x), 0, 1.5) once
    min_epochs have been seen and var(x) > min_var: run_filter's C/N0-growth estimator (E ln|e| = ln sigma +
    const for Gaussian e; variance ~ factor^gamma). pow2: POW2."""
    n_sig = mom.shape[1]
    for f in range(n_sig):
        for kk in range(2):
            g = 2 * f + kk
            o0, o1 = off[g], off[g + 1]
            nx = o1 - o0
            if nx < 3:
                continue
            x = xs[o0:o1]
            y = ys[o0:o1]
            a = 1.0 / min(gam_n[kk, f] + 1.0, noise_epochs)
            m0 = np_sum(x) / nx
            m1 = np_sum(y) / nx
            m2 = np_sum(x * x) / nx
            m3 = np_sum(x * y) / nx
            mom[kk, f, 0] += a * (m0 - mom[kk, f, 0])
            mom[kk, f, 1] += a * (m1 - mom[kk, f, 1])
            mom[kk, f, 2] += a * (m2 - mom[kk, f, 2])
            mom[kk, f, 3] += a * (m3 - mom[kk, f, 3])
            gam_n[kk, f] += 1
            vx = mom[kk, f, 2] - math.pow(mom[kk, f, 0], pow2)
            if gam_n[kk, f] >= min_epochs and vx > min_var:
                v = 2.0 * (mom[kk, f, 3] - mom[kk, f, 0] * mom[kk, f, 1]) / vx
                if v < 0.0:
                    v = 0.0
                if v > 1.5:
                    v = 1.5
                gamma[kk, f] = v


@njit(cache=True, nogil=True)
def white_noise_update(td: TripleDifferences, weights, est: WhiteNoise, pow2):
    """In place on est (when est.enabled): the per-signal white-noise variance of one SD from the median-referenced
    TDs td normalised by sqrt(C/N0 factor^gamma) (weights (2, bl, sat, sig) of code, phase; MAD / 0.6745 = sigma
    of a TD = sqrt(2) sigma of an SD), exponentially weighted over est.memory_epochs, for signals with >= 3 code
    and >= 3 phase TDs. pow2: POW2.

    Specification: gnssatt.attitude.reference_noise.update_white_noise (docs/attitude.md noise model).
    """
    code_m, phase_m, code_ok, phase_ok, median_code_m, median_phase_m = td
    var_code_m2, var_phase_m2, n_white, memory_epochs, enabled = est
    if not enabled:
        return
    wfac_c, wfac_p = weights[0], weights[1]
    n_bl, n_sat, n_sig = code_m.shape
    bc = np.empty(n_bl * n_sat)
    bp = np.empty(n_bl * n_sat)
    for f in range(n_sig):
        nc = 0
        npp = 0
        for j in range(n_bl):
            m_c = median_code_m[j, f]
            if np.isnan(m_c):
                m_c = 0.0
            m_p = median_phase_m[j, f]
            if np.isnan(m_p):
                m_p = 0.0
            for s in range(n_sat):
                if code_ok[j, s, f]:
                    bc[nc] = np.abs((code_m[j, s, f] - m_c) / np.sqrt(wfac_c[j, s, f]))
                    nc += 1
                if phase_ok[j, s, f]:
                    bp[npp] = np.abs((phase_m[j, s, f] - m_p) / np.sqrt(wfac_p[j, s, f]))
                    npp += 1
        if npp >= 3 and nc >= 3:
            a = 1.0 / min(n_white[f] + 1.0, memory_epochs)
            vp = math.pow(_median_sorted(np.sort(bp[:npp]), npp) / 0.6745, pow2) / 2.0
            vc = math.pow(_median_sorted(np.sort(bc[:nc]), nc) / 0.6745, pow2) / 2.0
            var_phase_m2[f] += a * (vp - var_phase_m2[f])
            var_code_m2[f] += a * (vc - var_code_m2[f])
            n_white[f] += 1


@njit(cache=True, nogil=True)
def count_pairs_masked(first, second, mask, n_first, n_second):
    """(n_first,) number of distinct `second` values paired with each `first` value among the rows where mask:
    gnssatt.attitude.fastops.count_pairs(first[mask], second[mask], n_first, n_second) (satellites per baseline)."""
    occ = np.zeros((n_first, n_second), np.bool_)
    out = np.zeros(n_first, np.int64)
    for i in range(first.size):
        if mask[i] and not occ[first[i], second[i]]:
            occ[first[i], second[i]] = True
            out[first[i]] += 1
    return out


@njit(cache=True, nogil=True)
def measurement_rows(rows: UsedRows, layout: StateLayout, obs: UpdateObs):
    """(cols (m, 5) int64, coef (m, 5), z (m,)) of the update: the code rows, then the phase rows of `rows` in
    sparse-row form (gnssatt.estimation.ekf.joseph_update_sparse): baseline -u (3), clock partial 1 - rho_dot / c on
    the code / phase clock, then the code bias of signals 2.. (coefficient 1; no term for signal 1) or the ambiguity
    (coefficient lambda); z = clock-corrected SD code, SD phase - PCV. Records: gnssatt.attitude.update_records.

    Specification: gnssatt.attitude.reference_update.measurement_rows (seed 000 eq. 1).
    """
    jc, sc, fc, jp, sp, fp = rows
    b_idx, clk, pclk, bias, amb_index, n_fixed_part = layout
    u, clock_factor, wavelength_m, sdc_c_m, sdp_c_m, pcv_m, cn0_dbhz, el_e_rad, el_w_rad = obs
    mc_n = jc.size
    m = mc_n + jp.size
    n_sig = sdc_c_m.shape[2]
    cols = np.full((m, 5), -1, np.int64)
    coef = np.zeros((m, 5))
    z = np.empty(m)
    for r in range(m):
        if r < mc_n:
            j, s, f = jc[r], sc[r], fc[r]
        else:
            j, s, f = jp[r - mc_n], sp[r - mc_n], fp[r - mc_n]
        for a in range(3):
            cols[r, a] = b_idx[j, a]
            coef[r, a] = -u[s, a]
        coef[r, 3] = clock_factor[s]
        if r < mc_n:
            cols[r, 3] = clk[j]
            if n_sig > 1:
                cols[r, 4] = bias[j, f]
                coef[r, 4] = 1.0
            z[r] = sdc_c_m[j, s, f]
        else:
            cols[r, 3] = pclk[j, f]
            cols[r, 4] = amb_index[j, s, f]
            coef[r, 4] = wavelength_m[s, f]
            z[r] = sdp_c_m[j, s, f] - pcv_m[j, s, f]
    return cols, coef, z


def warm_up() -> None:
    """Compile (or load from the cache) every kernel once on tiny inputs."""
    td = np.zeros((1, 3, 2))
    ok = np.ones((1, 3, 2), bool)
    m = masked_median_axis1(td, ok)
    masked_median_axis1(np.zeros((1, 3))[:, :, None], ok[:, :, :1])       # the epoch clock's call
    count_pairs_masked(np.zeros(2, np.int64), np.ones(2, np.int64), np.ones(2, np.bool_), 1, 2)
    i0 = np.zeros(1, np.int64)
    idx2 = np.zeros((1, 2), np.int64)
    rows = UsedRows(jc=i0, sc=i0, fc=i0, jp=i0, sp=i0, fp=i0)
    layout = StateLayout(b_idx=np.zeros((1, 3), np.int64), clk=i0, pclk=idx2, bias=idx2,
                         amb_index=np.zeros((1, 3, 2), np.int64), n_fixed_part=8)
    el = np.ones((1, 3))
    obs = UpdateObs(u=np.ones((3, 3)), clock_factor=np.ones(3), wavelength_m=np.ones((3, 2)), sdc_c_m=td, sdp_c_m=td,
                    pcv_m=td, cn0_dbhz=td, el_e_rad=el, el_w_rad=el)
    measurement_rows(tuple(rows), tuple(layout), tuple(obs))
    xs, rs, off = cn0_growth_samples(td, td, ok, ok, m, m, td, np.ones(2))
    cn0_growth_update(xs, rs, off, np.zeros((2, 2, 4)), np.zeros((2, 2)), np.ones((2, 2)), 300.0, 10, 0.05, POW2)
    est = WhiteNoise(var_code_m2=np.ones(2), var_phase_m2=np.ones(2), n_white=np.zeros(2), memory_epochs=300.0,
                     enabled=True)
    white_noise_update((td, td, ok, ok, m, m), np.ones((2,) + td.shape), tuple(est), POW2)
