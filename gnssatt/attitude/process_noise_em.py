"""The quiet level (floor) of the smoother's omega random walk estimated from the pass (smoothing.noise_em_iterations).

smoother_adaptive_noise gives the second forward pass a per-epoch omega random-walk rate (rad^2/s^3)

    Q_k(s) = G_k + s F,     F = noise_floor x Table 1's rate x I,  G_k = gain alpha_j alpha_j^T (the manoeuvres)

with s = 1 (gnssatt.attitude.smoother.adaptive_noise_profile). Here s is chosen by maximum likelihood, by the
expectation-maximisation of Shumway & Stoffer (1982, J. Time Ser. Anal. 3(4) 253-264, their M-step for Q): with the
omega increments of the smoothed pass, w_k = omega_k - A_k x_k-1 (A_k the omega rows of the transition matrix: I
without the acceleration state), their smoothed mean and covariance

    w^_k = omega_k|N - A_k x_k-1|N
    V_k  = P_k|N[w,w] + A_k P_k-1|N A_k^T - L_k A_k^T - A_k L_k^T,     L_k = (P_k|N C_k-1^T)[w, :]

(the lag-one smoothed covariance cov(x_k, x_k-1 | N) = P_k|N C_k-1^T, de Jong & Mackinnon 1988, Biometrika 75(3);
checked against the batch posterior in tests/attitude/test_process_noise_em.py) and E_k = w^_k w^_k^T + V_k, the
expected complete-data log-likelihood in s is

    J(s) = - 1/2 sum_k [ log det (Q_k(s) dt_k) + tr((Q_k(s) dt_k)^-1 E_k) ]              (EM objective)

over the links inside the all-fixed runs. Its stationarity condition dJ/ds = 0 is

    sum_k tr(Q_k^-1 F Q_k^-1 w^_k w^_k^T) / dt_k = sum_k tr(Q_k^-1 F Q_k^-1 (Q_k dt_k - V_k)) / dt_k

(the data's increments against their predicted covariance Q dt - V: covariance matching, Mehra 1972 IEEE TAC
17(5) for the innovation form), and at the maximum-likelihood s both hold. The EM step s <- argmax J is slow when
each increment is poorly observed (V_k ~ Q_k dt_k, the case here: one epoch's increment of a 0.005 deg/s per
sqrt(s) walk against a 0.1-0.3 deg attitude per epoch; docs/attitude.md: 3 EM iterations moved it by < 10 %), so
the update used is the ratio of the two sides of the matching condition, s <- s r, which has the same fixed point
and moves to it in a few filter runs where the data are informative (measured: r stays at 0.18-0.28 while s falls
from 1 to 0.1 on the simulated passes, so there it stops at the bound). Each new s needs a new forward pass and
smoother (the increments' covariances are those of the model that produced them).

Safeguards: s is bounded to [1 / bound, bound] x the configured floor (settings.smoothing.noise_em_bound); the
estimate uses only links inside all-fixed runs (float epochs carry ambiguities the recorded sub-state does not);
with fewer than 100 links, or fewer than MIN_EFFECTIVE_LINKS effective ones, or a ratio within 2 sampling sigmas
of 1 (1 / sqrt(effective links) in log), the floor stays where it is.
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.smoother import rts_smooth

__all__ = ["omega_increment_moments", "floor_scale_ratio", "em_objective", "floor_passes", "MIN_EFFECTIVE_LINKS"]


def omega_increment_moments(sd: dict, start: np.ndarray, use: np.ndarray):
    """(w^ (m, 3) rad/s, V (m, 3, 3) rad^2/s^2, k (m,) epoch index) of the smoothed omega increments into the epochs k
    that link to k-1 (not start[k]) with use[k] and use[k-1] (module doc; RTS with its gains on the recorded
    sub-state, linear in omega, so the additive recursion serves both baseline updates)."""
    xs, Ps, C = rts_smooth(sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start, gains=True)
    n = xs.shape[0]
    k = np.arange(1, n)
    ok = ~start[1:] & use[1:] & use[:-1] & np.isfinite(C[:-1]).all((1, 2)) & np.isfinite(xs[1:]).all(1) \
        & np.isfinite(xs[:-1]).all(1)
    k = k[ok]
    A = sd["Phi"][k, 0:3, :]                                         # (m, 3, n_sub)
    w_hat = xs[k, 0:3] - np.einsum("kab,kb->ka", A, xs[k - 1])
    L = np.einsum("kab,kcb->kac", Ps[k], C[k - 1])[:, 0:3, :]        # cov(omega_k, x_k-1 | N)
    APA = np.einsum("kab,kbc,kdc->kad", A, Ps[k - 1], A)
    LA = np.einsum("kab,kcb->kac", L, A)
    V = Ps[k, 0:3, 0:3] + APA - LA - np.swapaxes(LA, 1, 2)
    return w_hat, 0.5 * (V + np.swapaxes(V, 1, 2)), k


def _eig_frame(q_omega: np.ndarray, f_rate: float):
    """(eigenvalues of G_k = q_omega_k - f_rate I (m, 3), clipped at 0; eigenvectors (m, 3, 3))."""
    g, U = np.linalg.eigh(q_omega - f_rate * np.eye(3))
    return np.maximum(g, 0.0), U


def floor_scale_ratio(w_hat, V, q_omega, dt_s, f_rate: float) -> tuple[float, float]:
    """(r, effective links) of the matching condition (module doc) at the current Q_k = q_omega (m, 3, 3) whose
    floor part is f_rate I: r = sum w^T Q^-1 F Q^-1 w / dt over sum tr(Q^-1 F Q^-1 (Q dt - V)) / dt; r = 1 at the
    maximum-likelihood floor, the next floor is r x the current one. Effective links: the denominator over the
    floor's share of one link (how many increments' worth of information the ratio has)."""
    g, U = _eig_frame(q_omega, f_rate)
    lam = g + f_rate                                                 # eigenvalues of Q_k (m, 3)
    wu = np.einsum("kab,ka->kb", U, w_hat)                          # w in the eigenframe
    Vu = np.einsum("kab,kac,kcd->kbd", U, V, U)
    wt = f_rate / lam ** 2 / dt_s[:, None]                           # diag of Q^-1 F Q^-1 / dt
    num = float(np.sum(wt * wu ** 2))
    den = float(np.sum(wt * (lam * dt_s[:, None] - np.einsum("kii->ki", Vu))))
    if not den > 0:
        return float("nan"), 0.0
    return num / den, den / 3.0


def em_objective(s: np.ndarray, w_hat, V, q_omega, dt_s, f_rate: float) -> np.ndarray:
    """-2 J(s) (module doc) for each floor scale s (p,): the EM objective with the E-step of the current model."""
    g, U = _eig_frame(q_omega, f_rate)
    E = np.einsum("ka,kb->kab", w_hat, w_hat) + V
    e = np.einsum("kab,kac,kcb->kb", U, E, U)                       # diag of U^T E U (m, 3)
    out = []
    for si in np.atleast_1d(s):
        lam = (g + si * f_rate) * dt_s[:, None]
        out.append(float(np.sum(np.log(lam) + e / lam)))
    return np.array(out)


#: fewest effective links (module doc: floor_scale_ratio) for which the ratio's log is treated as normal with sigma
#: 1 / sqrt(n_eff) (measured on the linear-Gaussian model: relative std 0.103 at n_eff 95)
MIN_EFFECTIVE_LINKS = 10.0


def _significant(r: float, n_eff: float) -> bool:
    """The floor moves only where the data reject it: n_eff >= MIN_EFFECTIVE_LINKS and |log r| > 2 / sqrt(n_eff)
    (2 sampling sigmas). With the angular-acceleration state, for one, the omega walk is hardly observed
    (n_eff 1-6 on the slews) and its ratio says nothing."""
    return n_eff >= MIN_EFFECTIVE_LINKS and abs(np.log(r)) > 2.0 / np.sqrt(n_eff)


def floor_passes(fr1, rerun, settings):
    """(the last forward pass, info) of smoother_adaptive_noise with the floor estimated (module doc): pass 2 with the
    configured floor (rerun(q_omega) -> FilterResult, a whole filter run), then up to
    settings.smoothing.noise_em_iterations re-runs, each with floor x r of the last one's matching ratio, bounded;
    stops where r is not significant (_significant) or the bounded floor moves by < 5 %. fr1: the first pass (Table 1),
    whose smoothed angular acceleration keeps setting G_k."""
    from gnssatt.attitude.smoother import adaptive_noise_profile, fixed_runs

    sm = settings.smoothing
    f0 = sm.noise_floor * float(fr1.smoother_data["q_omega"])
    lo, hi = 1.0 / sm.noise_em_bound, sm.noise_em_bound
    Qw, info, run = adaptive_noise_profile(fr1, settings, 1.0, with_runs=True)
    fr, s, hist = rerun(Qw), 1.0, []
    if sm.noise_em_iterations == 0:
        return fr, info
    for it in range(sm.noise_em_iterations + 1):
        fixed_all, start = fixed_runs(fr)
        w, V, k = omega_increment_moments(fr.smoother_data, start, fixed_all & run)
        if k.size < 100:                      # too few links to say anything: keep the floor
            break
        r, n_eff = floor_scale_ratio(w, V, Qw[k], np.nan_to_num(fr.smoother_data["dt_s"][k], nan=1.0), s * f0)
        hist.append({"floor_scale": s, "ratio": r, "effective_links": n_eff, "links": int(k.size)})
        if not (np.isfinite(r) and r > 0) or not _significant(r, n_eff):
            break
        s_new = float(np.clip(s * r, lo, hi))
        if it == sm.noise_em_iterations or abs(np.log(s_new / s)) < 0.05:
            break
        s = s_new
        Qw, info, run = adaptive_noise_profile(fr1, settings, s, with_runs=True)
        fr = rerun(Qw)
    info["noise_em"] = {"method": "floor of the omega random walk by covariance matching of the smoothed omega "
                                  "increments (the EM / maximum-likelihood stationarity condition, "
                                  "gnssatt.attitude.process_noise_em)", "iterations": hist, "floor_scale": s,
                        "bounds": [lo, hi]}
    return fr, info
