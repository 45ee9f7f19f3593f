"""Every epoch solved on its own: double differences of one epoch, a weighted float solution, and an integer search
with its validation, checked against the truth.

Two methods:
- ``"lambda"`` (seed 000 sec. 2, the paper's method): per baseline, MLAMBDA on that baseline's DD ambiguities,
  the baseline conditioned on the best integers, accepted when its length is within 3 cm of the known length
  (Table 2); the ratio is only reported (as the paper does).
- ``"constrained"`` (issue 7): MC-LAMBDA over all baselines at once with the body geometry (C-LAMBDA for one
  baseline), accepted when the ratio of the constrained objective reaches ``min_ratio`` and the integer-
  conditioned (unconstrained) baselines pass the length test and, with two or more baselines, the angle test.

Float model (per baseline j, signal f, satellite s, reference r; Teunissen 1995 sec. 2):
    DD phase (cycles) = -(u_s - u_r) . b_j / lambda_f + a,    DD code (m) = -(u_s - u_r) . b_j,
after removing the differential receiver clock estimated from the code single differences with the partial
(1 - rho_dot / c) (as gnssatt.attitude.filter does, so free-running receiver clocks need no resampling). Noise:
undifferenced sigma per antenna and satellite, sigma0 * 10^((45 - C/N0) / 20) clipped to [0.5, 4] x sigma0
(``weighting="cn0"``; thermal noise grows as 1/sqrt(C/N0)), single and double differences with their exact
correlations (shared antennas and reference satellites).

Neglects: differential troposphere/ionosphere (baselines of metres), multipath and phase-centre variations in the
stochastic model (they are what the validation has to survive).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gnssatt.estimation.ar_validation import geometric_tolerance_m
from gnssatt.estimation.constrained_search import DDBlock, FloatSolution
from gnssatt.gnss.constants import C_M_S

__all__ = ["SingleEpochOptions", "EpochProblem", "EpochOutcome", "epoch_problem", "solve_lambda",
           "solve_constrained", "WRONG_FIX_DEG"]

#: Without truth integers, a fix whose baseline direction is further than this from the truth is wrong: a wrong
#: integer moves a metre baseline by about one wavelength (19-24 cm) -> ~10 deg, while correct fixes with 50 mm
#: p-p differential PCV stay below ~1.5 deg.
WRONG_FIX_DEG = 3.0


@dataclass(frozen=True)
class SingleEpochOptions:
    """Settings of the single-epoch solution (defaults: seed 000 Tables 1-2 where they apply)."""

    sigma_phase_m: float = 0.003           # undifferenced, at 45 dB-Hz (Table 1: 3 mm)
    sigma_code_m: float = 0.30             # undifferenced, at 45 dB-Hz (Table 1: 30 cm)
    weighting: str = "cn0"                 # cn0 | none
    cn0_mask_dbhz: tuple = (("L1", 35.0), ("L2", 30.0))   # Table 2
    elevation_mask_local_deg: float = -90.0               # Table 2 (spacecraft: none)
    min_sats: int = 4                      # satellites with phase on a baseline (attitude filter ar_min_sats)
    min_dd: int = 6                        # DD ambiguities of a baseline over all signals (ar_min_dd)
    # the constrained search: the joint problem over all baselines with the body geometry has 3 unknowns (the
    # rotation) besides the integers; 3 DDs (4 satellites) per baseline already give each baseline's float from
    # the code and, once fixed, a baseline determined by its phase alone (see docs/ttff.md "Fewer satellites")
    min_dd_constrained: int = 3
    max_length_error_m: float = 0.03       # Table 2
    min_ratio_constrained: float = 1.5     # ratio of the constrained objective (see docs/ttff.md)
    # a baseline with at most few_dd_max DDs over the attempt's signals (7 satellites on one frequency) needs
    # min_ratio_few_dd: with few ambiguities a given ratio means a higher failure rate (the fixed-failure-rate
    # ratio test's critical value grows as the ambiguity count falls, Verhagen & Teunissen 2013, J Geod 87)
    # (baselines shorter than few_dd_min_length_m keep min_ratio_constrained: there one wrong cycle, 19-24 cm, moves
    # the baseline by more than its length and the length and angle tests catch it; the 10 cm CubeSat set had no
    # wrong fix in 4800 epochs without the rule, docs/ttff.md "Fewer satellites")
    few_dd_max: int = 6
    min_ratio_few_dd: float = 2.0
    few_dd_min_length_m: float = 0.5
    constrained_candidates: int = 3        # C-LAMBDA candidates per baseline combined by the MC-LAMBDA objective
    constrained_ratio_cap: float = 4.0    # C-LAMBDA expands its radius up to this x the best cost
    constrained_max_nodes: int = 50_000    # budget of one C-LAMBDA search (~0.5 s); exhausted -> not fixed
    constrained_joint_ratio_cap: float = 2.0  # MC-LAMBDA: the second joint candidate up to this x the best
    constrained_max_candidates: int = 200  # per baseline below the joint bound; more -> not fixed
    phase_sigma_factor: tuple = ()         # per signal, x sigma_phase_m, e.g. (("L2", 1.5),)
    geometric_tol_sigmas: float = 3.0      # length/angle tolerance max(tol, this x sigma of b_hat(a)); 0: tol only
    first_signal_fallback: bool = True     # several signals, not accepted: first signal alone, then round the rest
    max_angle_error_m: float = 0.06        # angle test: atan(this / shorter baseline) (6 cm: 3.3 deg at 1.05 m)
    other_signal_max_frac_cyc: float = 0.25  # the rest must lie this close to integers given the fixed baselines

    def cn0_mask(self, signal: str) -> float:
        return dict(self.cn0_mask_dbhz).get(signal, -math.inf)

    def usability(self, method: str) -> tuple[int, int]:
        """(satellites with phase per baseline and signal, DDs per baseline over all signals) a baseline needs to
        be attempted by ``method`` ("lambda": the paper's ar_min_sats / ar_min_dd; "constrained": fewer DDs)."""
        if method == "constrained":
            return self.min_sats, self.min_dd_constrained
        if method == "lambda":
            return self.min_sats, self.min_dd
        raise ValueError(f"unknown single-epoch method {method!r}")


@dataclass
class EpochProblem:
    """One epoch, one configuration: the DD float solution and what the truth says."""

    k: int
    sol: FloatSolution
    block_rows: list                      # per block, (n_dd,) row indices into sol.a_float_cyc
    truth_dd: list                        # per block, (n_dd,) truth integers or None
    b_true_ecef_m: np.ndarray | None      # (q, 3) or None
    n_sats: np.ndarray                    # (q,) satellites with phase per baseline
    usable: np.ndarray                    # (q,) bool: enough satellites / DDs for an attempt by ``method``
    method: str = "lambda"                # whose usability rule built the problem (SingleEpochOptions.usability)


@dataclass
class EpochOutcome:
    """Per baseline (q,): accepted, correct (True/False, or None without truth), ratio, fixed baseline."""

    method: str
    accepted: np.ndarray
    correct: list
    best_correct: list                    # the best candidate right, whether accepted or not (None: no truth)
    ratio: np.ndarray
    b_fixed_ecef_m: np.ndarray            # (q, 3), NaN where not attempted
    n_nodes: int = 0
    detail: list = field(default_factory=list)


def _var_factor(cn0: np.ndarray, weighting: str) -> np.ndarray:
    if weighting != "cn0":
        return np.ones_like(cn0)
    # sigma x 10^((45 - C/N0)/20) clipped to [0.5, 4]  ->  variance factor in [0.25, 16]
    return np.clip(10.0 ** ((45.0 - np.nan_to_num(cn0, nan=45.0)) / 10.0), 0.25, 16.0)


def epoch_problem(ss, k: int, signals: list[str], opts: SingleEpochOptions,
                  method: str = "lambda") -> EpochProblem | None:
    """EpochProblem of epoch k of a StudySet for `signals` (a subset of ss.pobs.signals), or None when no
    baseline has enough data for ``method`` (its rule: ``opts.usability(method)``; only the baselines usable by
    it enter the float solution).

    The reference satellite of every block is the satellite with the highest C/N0 (weakest of the antennas)
    among those with phase on every baseline and signal; if none is common, each block takes its own best.
    """
    pobs, geom = ss.pobs, ss.geom
    sig_k = [pobs.signals.index(s) for s in signals]
    q = len(ss.bl_idx)
    ants = sorted({a for pair in ss.bl_idx for a in pair})
    gv = geom.valid[k] & (geom.elevation_local_rad[k] >= math.radians(opts.elevation_mask_local_deg))
    if not gv.any():
        return None
    u = np.where(gv[:, None], geom.los_ecef[k], 0.0)
    cfac = 1.0 - geom.range_rate_m_s[k] / C_M_S
    lam = pobs.wavelength_m
    # per antenna, satellite, signal: usable phase + code above the C/N0 mask
    ok = np.zeros((pobs.code_m.shape[0], pobs.code_m.shape[2], len(signals)), bool)
    for i, f in enumerate(sig_k):
        cn = pobs.cn0_dbhz[:, k, :, f]
        ok[..., i] = (np.isfinite(pobs.code_m[:, k, :, f]) & np.isfinite(pobs.phase_m[:, k, :, f])
                      & ~(np.nan_to_num(cn, nan=np.inf) < opts.cn0_mask(signals[i]))
                      & ~((np.maximum(pobs.lli[:, k, :, f], 0) & 2).astype(bool)) & gv[None, :])
    ok &= pobs.present[:, k][:, None, None]
    min_sats, min_dd = opts.usability(method)
    both = np.stack([ok[a] & ok[b] for a, b in ss.bl_idx])            # (q, n_sat, n_sig)
    common = both.all(axis=(0, 2))
    cn_min = np.nanmin(np.where(np.isfinite(pobs.cn0_dbhz[ants][:, k][..., sig_k]),
                                pobs.cn0_dbhz[ants][:, k][..., sig_k], 99.0), axis=(0, 2))
    ref_common = int(np.argmax(np.where(common, cn_min, -np.inf))) if common.any() else None
    # differential clock per baseline from the first signal's code (median), removed with the partial cfac
    blocks, phase_dd, code_dd, var_p, var_c, truth_dd, rows = [], [], [], [], [], [], []
    n_sats = np.zeros(q, np.int64)
    usable = np.zeros(q, bool)
    off = 0
    keys = []        # per block: (baseline, signal index, sats incl. ref, ref position)
    for j, (a, b) in enumerate(ss.bl_idx):
        sats_j = np.flatnonzero(both[j].any(axis=1))
        n_sats[j] = int(both[j].all(axis=1).sum()) if len(signals) > 1 else sats_j.size
        sdc0 = pobs.code_m[b, k, :, sig_k[0]] - pobs.code_m[a, k, :, sig_k[0]]
        m0 = both[j, :, 0] & np.isfinite(sdc0)
        if m0.sum() < 2:
            continue
        clk = float(np.median(sdc0[m0] / cfac[m0]))
        n_dd_j = 0
        cand = []
        for i, f in enumerate(sig_k):
            sats = np.flatnonzero(both[j, :, i])
            if sats.size < min_sats:
                continue
            if ref_common is not None and both[j, ref_common, i]:
                r = ref_common
            else:
                r = int(sats[np.argmax(cn_min[sats])])
            cand.append((i, f, sats, r))
            n_dd_j += sats.size - 1
        if n_dd_j < min_dd or not cand:
            continue
        usable[j] = True
        for i, f, sats, r in cand:
            others = sats[sats != r]
            sdp = (pobs.phase_m[b, k, :, f] - pobs.phase_m[a, k, :, f]) - cfac * clk
            sdc = (pobs.code_m[b, k, :, f] - pobs.code_m[a, k, :, f]) - cfac * clk
            geo = -(u[others] - u[r])
            blk = DDBlock(j, signals[i], float(lam[f]), tuple(pobs.sats[s] for s in others), pobs.sats[r], geo)
            blocks.append(blk)
            phase_dd.append((sdp[others] - sdp[r]) / lam[f])
            code_dd.append(sdc[others] - sdc[r])
            keys.append((j, a, b, f, others, r))
            rows.append(np.arange(off, off + others.size))
            off += others.size
            if ss.truth is not None and ss.truth.n_cyc is not None:
                N = ss.truth.n_cyc[:, k, :, f]
                sd_n = N[b] - N[a]
                t = sd_n[others] - sd_n[r]
                truth_dd.append(np.round(t).astype(np.int64) if np.all(np.isfinite(t)) else None)
            else:
                truth_dd.append(None)
    if not blocks:
        return None
    Cp, Cc = _dd_covariance(pobs, k, signals, sig_k, keys, rows, blocks, opts)
    sol = _float_solution(blocks, rows, phase_dd, code_dd, Cp, Cc, q)
    if sol is None:
        return None
    b_true = None
    if ss.truth is not None and ss.truth.ok[k]:
        b_true = ss.body_baselines_m @ ss.truth.R_body_from_ecef[k]       # rows: R^T f_j (ECEF)
    return EpochProblem(k, sol, rows, truth_dd, b_true, n_sats, usable, method)


def _dd_covariance(pobs, k: int, signals: list[str], sig_k: list[int], keys: list, rows: list, blocks: list,
                   opts: SingleEpochOptions) -> tuple[np.ndarray, np.ndarray]:
    """Covariances (Cp in cycles^2, Cc in m^2) of the stacked DD rows of epoch k, with the exact correlations of
    shared antennas and reference satellites (module docstring, "Noise").

    Implements: Cov(DD) = D Cov(SD) D^T, Cov(SD_i(s), SD_j(t)) = delta_st sum over shared antennas of
    (+1 same role, -1 opposite role) var_ant(s); var_ant from ``_var_factor`` (C/N0 weighting).
    """
    n = sum(r.size for r in rows)
    Cp = np.zeros((n, n))
    Cc = np.zeros((n, n))
    fac = {}
    for idx, (j, a, b, f, others, r) in enumerate(keys):
        for ant in (a, b):
            if (ant, f) not in fac:
                fac[(ant, f)] = _var_factor(pobs.cn0_dbhz[ant, k, :, f], opts.weighting)
    for p_i, (ji, ai, bi, fi, oi, ri) in enumerate(keys):
        for p_j, (jj, aj, bj, fj, oj, rj) in enumerate(keys):
            if fi != fj or p_j < p_i:
                continue
            # Cov(SD_i(s), SD_j(t)) = delta_st sum over shared antennas (+ same role, - opposite role) var_ant(s)
            shared = []
            for x, sx in ((ai, -1.0), (bi, 1.0)):
                for y, sy in ((aj, -1.0), (bj, 1.0)):
                    if x == y:
                        shared.append((x, sx * sy))
            if not shared:
                continue
            si = np.concatenate([oi, [ri]])
            sj = np.concatenate([oj, [rj]])
            # DD_i = SD_i(o) - SD_i(r): rows = [I, -1] over si
            same = (si[:, None] == sj[None, :]).astype(float)
            vf = np.zeros(si.size)
            for ant, sgn in shared:
                vf = vf + sgn * fac[(ant, fi)][si]
            Csd = same * vf[:, None]                                    # Cov(SD_i(si), SD_j(sj)) / sigma0^2
            Di = np.hstack([np.eye(oi.size), -np.ones((oi.size, 1))])
            Dj = np.hstack([np.eye(oj.size), -np.ones((oj.size, 1))])
            blk = Di @ Csd @ Dj.T
            ri_, rj_ = rows[p_i], rows[p_j]
            sfac = dict(opts.phase_sigma_factor).get(signals[sig_k.index(fi)], 1.0)
            Cp[np.ix_(ri_, rj_)] = blk * (opts.sigma_phase_m * sfac) ** 2
            Cc[np.ix_(ri_, rj_)] = blk * opts.sigma_code_m ** 2
            if p_j != p_i:
                Cp[np.ix_(rj_, ri_)] = Cp[np.ix_(ri_, rj_)].T
                Cc[np.ix_(rj_, ri_)] = Cc[np.ix_(ri_, rj_)].T
    lam_rows = np.concatenate([np.full(blk.n_dd, blk.wavelength_m) for blk in blocks])
    Cp = Cp / np.outer(lam_rows, lam_rows)
    return Cp, Cc


def _float_solution(blocks: list, rows: list, phase_dd: list, code_dd: list, Cp: np.ndarray, Cc: np.ndarray,
                    q: int) -> FloatSolution | None:
    """Weighted least-squares float solution (a, b) of the stacked DD phase (cycles) and code (m) rows, or None
    when the normal matrix is singular.

    Implements: the float model of the module docstring (Teunissen 1995 sec. 2), x = N^-1 A^T W y with
    N = A_p^T Wp A_p + A_c^T Wc A_c.
    """
    n = sum(r.size for r in rows)
    q_used = q
    A_p = np.zeros((n, n + 3 * q_used))
    A_c = np.zeros((n, n + 3 * q_used))
    for blk, rr in zip(blocks, rows):
        cb = slice(n + 3 * blk.baseline, n + 3 * blk.baseline + 3)
        A_p[rr, rr] = 1.0
        A_p[rr, cb] = blk.geometry / blk.wavelength_m
        A_c[rr, cb] = blk.geometry
    Wp = np.linalg.inv(Cp)
    Wc = np.linalg.inv(Cc)
    N = A_p.T @ Wp @ A_p + A_c.T @ Wc @ A_c
    y_p = np.concatenate(phase_dd)
    y_c = np.concatenate(code_dd)
    rhs = A_p.T @ Wp @ y_p + A_c.T @ Wc @ y_c
    # a baseline without blocks has no rows: keep it out of the normal matrix by a tiny prior (never used)
    for j in range(q):
        if not any(blk.baseline == j for blk in blocks):
            N[n + 3 * j:n + 3 * j + 3, n + 3 * j:n + 3 * j + 3] += np.eye(3) * 1e-6
    try:
        Qx = np.linalg.inv(N)
    except np.linalg.LinAlgError:
        return None
    Qx = 0.5 * (Qx + Qx.T)
    x = Qx @ rhs
    return FloatSolution(a_float_cyc=x[:n], b_float_m=x[n:], Q_a=Qx[:n, :n], Q_b=Qx[n:, n:], Q_ab=Qx[:n, n:],
                         blocks=tuple(blocks))


def _usable_for(prob: EpochProblem, method: str, opts: SingleEpochOptions) -> np.ndarray:
    """(q,) bool: baselines of ``prob`` that ``method`` may attempt (usable when built and enough DDs for its rule,
    whichever method's rule built the problem)."""
    _, min_dd = opts.usability(method)
    n_dd = np.zeros(prob.usable.size, np.int64)
    for blk in prob.sol.blocks:
        n_dd[blk.baseline] += blk.n_dd
    return prob.usable & (n_dd >= min_dd)


def _angle_deg(u: np.ndarray, v: np.ndarray) -> float:
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(u, v))), float(np.dot(u, v))))


def _judge(prob: EpochProblem, j: int, fixed_rows: dict, b_fix: np.ndarray):
    """True/False/None: the integers of baseline j against the truth integers, else the direction vs truth."""
    truths = [(i, t) for i, (blk, t) in enumerate(zip(prob.sol.blocks, prob.truth_dd)) if blk.baseline == j]
    if truths and all(t is not None for _, t in truths):
        # NaN: an ambiguity left float (partial fixing); every fixed one must equal the truth
        return all(np.array_equal(np.asarray(fixed_rows[i], float)[np.isfinite(fixed_rows[i])],
                                  np.asarray(t, float)[np.isfinite(fixed_rows[i])]) for i, t in truths)
    if prob.b_true_ecef_m is not None and np.all(np.isfinite(b_fix)):
        return _angle_deg(b_fix, prob.b_true_ecef_m[j]) < WRONG_FIX_DEG
    return None


def solve_lambda(prob: EpochProblem, body_baselines_m: np.ndarray, opts: SingleEpochOptions) -> EpochOutcome:
    """EpochOutcome of the paper's method: per baseline MLAMBDA + length validation (seed 000 sec. 2, Table 2)."""
    from gnssatt.estimation.ar_validation import baseline_length_test, fixed_baseline
    from gnssatt.estimation.lambda_search import AmbiguitySearchError, mlambda

    q = body_baselines_m.shape[0]
    acc = np.zeros(q, bool)
    correct: list = [None] * q
    best_ok: list = [None] * q
    ratio = np.full(q, np.nan)
    bfix = np.full((q, 3), np.nan)
    nodes = 0
    detail = [""] * q
    usable = _usable_for(prob, "lambda", opts)
    for j in range(q):
        if not usable[j]:
            detail[j] = "too few satellites"
            continue
        sub = prob.sol.baseline(j)
        try:
            r = mlambda(sub.a_float_cyc, sub.Q_a, m=2)
        except (AmbiguitySearchError, ValueError, OverflowError, np.linalg.LinAlgError) as exc:
            detail[j] = f"search failed: {exc}"
            continue
        nodes += r.n_nodes
        a_fix = r.fixed[0]
        b, _ = fixed_baseline(sub.b_float_m, sub.a_float_cyc, sub.Q_ab.T, sub.Q_a, a_fix)
        bfix[j] = b
        ratio[j] = r.ratio
        _, passed = baseline_length_test(b, float(np.linalg.norm(body_baselines_m[j])), opts.max_length_error_m)
        # map the sub-solution's rows back to blocks of the full problem
        rows_j, off = {}, 0
        for i, blk in enumerate(prob.sol.blocks):
            if blk.baseline == j:
                rows_j[i] = a_fix[off:off + blk.n_dd]
                off += blk.n_dd
        ok = _judge(prob, j, rows_j, b)
        best_ok[j] = ok
        acc[j] = bool(passed)
        correct[j] = ok if acc[j] else None
        if not acc[j]:
            detail[j] = f"length {np.linalg.norm(b):.4f} m"
    return EpochOutcome("lambda", acc, correct, best_ok, ratio, bfix, nodes, detail)


def _pair_search(sol: FloatSolution, rows_by_bl: list, cands: list, body_baselines_m: np.ndarray):
    """Best two joint candidates over the product of the per-baseline candidate lists: (costs (k,), a (k, n)).

    The joint objective of MC-LAMBDA, ||a_hat - a||^2_Qa + min_R ||b_hat(a) - vec(R F)||^2_{Q_b|a} (Teunissen
    2007; Giorgi et al. 2010), is evaluated exactly for every combination of the baselines' C-LAMBDA candidates.
    """
    import itertools

    from gnssatt.estimation.constrained_search import rotation_fit

    a_hat = sol.a_float_cyc
    C = np.linalg.cholesky(sol.Q_a)
    K = np.linalg.solve(C.T, np.linalg.solve(C, sol.Q_ab)).T             # Q_ba Q_a^-1  (3q, n)
    Qc = sol.Q_b - K @ sol.Q_ab
    W = np.linalg.inv(0.5 * (Qc + Qc.T))
    W = 0.5 * (W + W.T)
    out = []
    for combo in itertools.product(*cands):
        a = np.empty(a_hat.size)
        for rows, vec in zip(rows_by_bl, combo):
            a[rows] = vec
        da = a_hat - a
        y = np.linalg.solve(C, da)
        ils = float(y @ y)
        b = sol.b_float_m - K @ da
        cR, R = rotation_fit(b, W, body_baselines_m)
        out.append((ils + cR, a, b, body_baselines_m @ R.T))
    out.sort(key=lambda t: t[0])
    return out


def solve_constrained(prob: EpochProblem, body_baselines_m: np.ndarray, opts: SingleEpochOptions) -> EpochOutcome:
    """EpochOutcome of the body-constrained search over every usable baseline, accepted by the ratio of the
    constrained objective plus the length (and angle) tests on the integer-conditioned baselines.

    One baseline: C-LAMBDA (gnssatt.estimation.constrained_search, exact). Two or more: C-LAMBDA per baseline for
    its ``constrained_candidates`` best candidates, then the exact MC-LAMBDA objective over the product of these
    lists (best and second best -> ratio). A joint minimiser whose baseline part is not among its baseline's
    candidates would be missed; the candidates are the baseline's best under its own length constraint, which
    the right integers nearly always are (measured in bench/bench_ttff.py: "best right").
    """
    from gnssatt.estimation.lambda_search import AmbiguitySearchError

    q = body_baselines_m.shape[0]
    acc = np.zeros(q, bool)
    correct: list = [None] * q
    best_ok: list = [None] * q
    ratio = np.full(q, np.nan)
    bfix = np.full((q, 3), np.nan)
    usable = _usable_for(prob, "constrained", opts)
    use = [j for j in range(q) if usable[j]]
    detail = ["too few satellites" if not usable[j] else "" for j in range(q)]
    if not use:
        return EpochOutcome("constrained", acc, correct, best_ok, ratio, bfix, 0, detail)
    sol = prob.sol
    blk_keep = [i for i, blk in enumerate(sol.blocks) if blk.baseline in set(use)]
    ia = np.concatenate([prob.block_rows[i] for i in blk_keep])
    ib = np.concatenate([np.arange(3 * j, 3 * j + 3) for j in use])
    sub = FloatSolution(sol.a_float_cyc[ia], sol.b_float_m[ib], sol.Q_a[np.ix_(ia, ia)], sol.Q_b[np.ix_(ib, ib)],
                        sol.Q_ab[np.ix_(ia, ib)], tuple(sol.blocks[i] for i in blk_keep))
    pos_of = {}
    off = 0
    for i in blk_keep:
        pos_of[i] = np.arange(off, off + sol.blocks[i].n_dd)
        off += sol.blocks[i].n_dd
    F = body_baselines_m[use]
    nodes = 0
    try:
        try:
            att = _attempt(sub, use, F, opts)
            nodes = att.nodes
        except (AmbiguitySearchError, ValueError, OverflowError, np.linalg.LinAlgError) as exc:
            att = _Attempt(np.full(sub.a_float_cyc.size, np.nan), np.full((len(use), 3), np.nan),
                           np.full((len(use), 3), np.nan), math.nan, False, 0, f"search failed: {str(exc)[:80]}")
        signals = list(dict.fromkeys(blk.signal for blk in sub.blocks))
        if not att.passed and len(signals) > 1 and opts.first_signal_fallback:
            # the first signal alone, the others' integers then from the fixed baselines (see module docstring)
            first = np.array([blk.signal == signals[0] for blk in sub.blocks])
            if all(any(f and blk.baseline == j for f, blk in zip(first, sub.blocks)) for j in use):
                ra = np.concatenate([np.arange(s.start, s.stop) for s, f in zip(sub.ambiguity_slices(), first) if f])
                sub1 = FloatSolution(sub.a_float_cyc[ra], sub.b_float_m, sub.Q_a[np.ix_(ra, ra)], sub.Q_b,
                                     sub.Q_ab[ra], tuple(b for b, f in zip(sub.blocks, first) if f))
                att1 = _attempt(sub1, use, F, opts)
                nodes += att1.nodes
                if att1.passed:
                    a_all, why = _complete_other_signals(sub, ra, att1.a_best, att1.b_constrained.reshape(-1),
                                                         opts.other_signal_max_frac_cyc)
                    att1.passed = a_all is not None
                    att1.why = why
                    if a_all is not None:
                        att1.a_best = a_all
                        att = att1
    except (AmbiguitySearchError, ValueError, OverflowError, np.linalg.LinAlgError) as exc:
        for j in use:
            detail[j] = f"search failed: {str(exc)[:80]}"
        return EpochOutcome("constrained", acc, correct, best_ok, ratio, bfix, nodes, detail)
    for pos, j in enumerate(use):
        bfix[j] = att.B[pos]
        ratio[j] = att.ratio
        rows_j = {i: att.a_best[pos_of[i]] for i in blk_keep if sol.blocks[i].baseline == j}
        ok = _judge(prob, j, rows_j, att.B[pos]) if np.all(np.isfinite(att.B[pos])) else None
        best_ok[j] = ok
        acc[j] = att.passed
        correct[j] = ok if att.passed else None
        if not att.passed:
            detail[j] = att.why
    return EpochOutcome("constrained", acc, correct, best_ok, ratio, bfix, nodes, detail)


@dataclass
class _Attempt:
    a_best: np.ndarray          # (n,) best integers of the FloatSolution searched
    B: np.ndarray               # (q, 3) integer-conditioned (unconstrained) baselines b_hat(a)
    b_constrained: np.ndarray   # (q, 3) constrained baselines of the best candidate (R F, or on the sphere)
    ratio: float
    passed: bool
    nodes: int
    why: str


def _attempt(sub: FloatSolution, use: list, F: np.ndarray, opts: SingleEpochOptions) -> _Attempt:
    """The constrained search on ``sub`` (baselines ``use``, body vectors F) and its validation: ratio of the
    constrained objective (``min_ratio_few_dd`` when a baseline of ``few_dd_min_length_m`` or longer has
    ``few_dd_max`` DDs or fewer), length and angle tests on b_hat(a) with ``geometric_tolerance_m``."""
    from gnssatt.estimation.ar_validation import baseline_angle_test, baseline_length_test
    from gnssatt.estimation.constrained_search import constrained_search, constrained_search_by_baselines

    rows_by_bl = []
    for pos in range(len(use)):
        rows_by_bl.append(np.concatenate([np.arange(s.start, s.stop) for s, blk in
                                          zip(sub.ambiguity_slices(), sub.blocks) if blk.baseline == use[pos]]))
    nodes = 0
    if len(use) == 1:
        res = constrained_search(sub.a_float_cyc, sub.Q_a, sub.b_float_m, sub.Q_b, sub.Q_ab, F, m=2,
                                 ratio_cap=opts.constrained_ratio_cap, max_nodes=opts.constrained_max_nodes)
        nodes = res.n_nodes
        a_best = res.fixed[0]
        B = res.b_unconstrained_m.reshape(-1, 3)
        Bc = res.b_fixed_m.reshape(-1, 3)
        rt = res.ratio
    else:
        res = constrained_search_by_baselines(sub.a_float_cyc, sub.Q_a, sub.b_float_m, sub.Q_b, sub.Q_ab, F,
                                              rows_by_bl, m_first=opts.constrained_candidates,
                                              ratio_cap=opts.constrained_joint_ratio_cap,
                                              max_nodes=opts.constrained_max_nodes,
                                              max_candidates=opts.constrained_max_candidates)
        nodes = res.n_nodes
        a_best = res.fixed[0]
        B = res.b_unconstrained_m.reshape(-1, 3)
        Bc = res.b_fixed_m.reshape(-1, 3)
        rt = res.ratio
    lengths = np.linalg.norm(F, axis=1)
    tol = geometric_tolerance_m(sub, opts.max_length_error_m, opts.geometric_tol_sigmas)
    _, len_ok = baseline_length_test(B, lengths, tol)
    ang_ok = True
    if len(use) >= 2:
        tol_a = tol * (opts.max_angle_error_m / opts.max_length_error_m)
        _, ao = baseline_angle_test(B, F, tol_m=tol_a)
        ang_ok = bool(np.all(ao))
    dd_per_baseline = [sum(blk.n_dd for blk in sub.blocks if blk.baseline == j) for j in use]
    few = any(dd <= opts.few_dd_max and length >= opts.few_dd_min_length_m
              for dd, length in zip(dd_per_baseline, np.linalg.norm(F, axis=1)))
    min_ratio = opts.min_ratio_few_dd if few else opts.min_ratio_constrained
    passed = bool(rt >= max(min_ratio, opts.min_ratio_constrained) and ang_ok and np.all(len_ok))
    why = "" if passed else (f"ratio {rt:.2f}" + ("" if np.all(len_ok) else ", length") + ("" if ang_ok else ", angle"))
    return _Attempt(np.asarray(a_best, float), B, np.asarray(Bc, float).reshape(-1, 3), float(rt), passed, nodes, why)


def _complete_other_signals(sol: FloatSolution, fixed_rows: np.ndarray, a_fixed: np.ndarray, b_fixed_m: np.ndarray,
                            max_frac_cyc: float) -> tuple[np.ndarray | None, str]:
    """All integers of ``sol`` from those of ``fixed_rows`` and the fixed baselines: the other ambiguities
    conditioned on (a_fixed, b_fixed) and rounded; NaN (left float) where one lies ``max_frac_cyc`` or further
    from its integer (partial fixing: the baselines are fixed by the first signal already).

    Implements: the conditional mean of a Gaussian vector, a_o|c = a_o - Q_oc Q_cc^-1 (c_hat - c) with
    c = (a_fixed, b) (Teunissen 1995 eq. 4 with the baseline added to the conditioning set); with the baseline
    known to mm the other frequency's DD ambiguities are determined to a fraction of a cycle.
    """
    n = sol.a_float_cyc.size
    other = np.setdiff1d(np.arange(n), fixed_rows)
    x_hat = np.concatenate([sol.a_float_cyc, sol.b_float_m])
    Q = np.block([[sol.Q_a, sol.Q_ab], [sol.Q_ab.T, sol.Q_b]])
    c_idx = np.concatenate([fixed_rows, n + np.arange(sol.b_float_m.size)])
    c_fix = np.concatenate([a_fixed, b_fixed_m])
    Qcc = Q[np.ix_(c_idx, c_idx)]
    Qoc = Q[np.ix_(other, c_idx)]
    a_o = x_hat[other] - Qoc @ np.linalg.solve(Qcc, x_hat[c_idx] - c_fix)
    r = np.round(a_o)
    keep = np.abs(a_o - r) < max_frac_cyc
    out = np.empty(n)
    out[fixed_rows] = a_fixed
    out[other] = np.where(keep, r, np.nan)
    return out, ""
