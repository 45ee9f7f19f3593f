"""GPS fault detection and isolation by a bank of snapshot processors (seed 002 sec. 3.1, Fig. 1 part b).

Processor 0 uses every satellite; processor p excludes satellite p (p != the reference). With J_p the minimum
of eq. 2 on processor p and J*_p its threshold (mu_p = (m_p - 1)(n - 1) - 3 degrees of freedom, kappa ~ 3):
the paper's J* = mu_p + kappa sigma_p with sigma_p = sqrt(2 mu_p) ("gaussian"), or by default ("chi2") the
chi-square quantile with the tail probability of a normal kappa-sigma test, P(chi2_mu > J*) = Q(kappa). With
mu = 7-17 the chi-square's right tail at mu + 3 sigma is 0.8-1.1 %, not Q(3) = 0.13 %; the simulated clean
costs follow chi2_mu (mean J / mu 1.01, variance of (J - mu) / sigma 1.00), so the exact quantile, not a larger
kappa, gives the false-alarm rate kappa stands for.
- J_0 < J*_0: no detectable fault, theta* = theta_0;
- else, if J_q < J*_q for a satellite q (the lowest J_q / J*_q when several): a fault on q, theta* = theta_q;
- if J_p > J*_p for every p: the reference satellite may be the faulty one, so the test is repeated with the
  next satellite (by elevation) as the reference; if that fails too the epoch gives no GPS attitude.
The antenna of an isolated fault is the baseline whose residual of the excluded satellite stands out (more
than `ANTENNA_RATIO` times the others); when all baselines see it alike, the master antenna.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2, norm

from gnssatt.gyro.snapshot import EpochPhases, SnapshotFit, fit_attitude

__all__ = ["BankResult", "THRESHOLD_MODELS", "threshold", "run_bank"]

ANTENNA_RATIO = 3.0      # a residual 3x the other baselines' points at that baseline's antenna


THRESHOLD_MODELS = ("chi2", "gaussian")


def threshold(mu: int, kappa: float, model: str = "chi2") -> float:
    """J* for mu degrees of freedom: "gaussian" mu + kappa sqrt(2 mu) (seed 002 sec. 3.1); "chi2" the quantile
    chi2_mu^-1(1 - Q(kappa)), Q the standard normal tail (the same false-alarm probability at any mu)."""
    if model == "gaussian":
        return mu + kappa * np.sqrt(2.0 * mu)
    if model != "chi2":
        raise ValueError(f"threshold model {model!r}: expected one of {THRESHOLD_MODELS}")
    return float(chi2.isf(norm.sf(kappa), mu))


@dataclass
class BankResult:
    """One epoch of the bank: the chosen fit, the detection, the isolated satellite and every processor's cost."""

    fit: SnapshotFit | None
    detected: bool
    excluded: int | None                 # satellite index isolated (None: no fault or not isolated)
    antenna: int | None                  # antenna index of the isolated fault (0 = master), None if unknown
    ref: int
    costs: list = field(default_factory=list)   # (ref, excluded or -1, J, dof, threshold)


def _processors(Z, ep, B, R0, ref, thr, candidates):
    full = fit_attitude(Z, ep, B, R0, candidates, ref)
    costs = [(ref, -1, full.J, full.dof, thr(full.dof))]
    fits = {}
    for p in candidates:
        if p == ref:
            continue
        sub = [s for s in candidates if s != p]
        if len(sub) < 4 or (len(sub) - 1) * len(B) - 3 < 1:
            continue
        f = fit_attitude(Z, ep, B, R0, sub, ref)        # from the prior: the full fit may hold the fault
        fits[p] = f
        costs.append((ref, p, f.J, f.dof, thr(f.dof)))
    return full, fits, costs


def _antenna_of(fit: SnapshotFit, ep: EpochPhases, Z, B, p: int) -> int:
    """Antenna index of the fault on satellite p: the baseline whose residual stands out, else the master."""
    lam = ep.wavelength_m
    y = Z[p] - Z[fit.ref]
    g = ep.los_ecef[p] - ep.los_ecef[fit.ref]
    r = np.abs(y + (g @ fit.R_body_from_ecef.T @ B.T) / lam)          # (n-1,) cycles
    order = np.argsort(r)[::-1]
    if len(r) > 1 and r[order[0]] > ANTENNA_RATIO * max(r[order[1]], 1e-9):
        return int(order[0]) + 1
    return 0


def run_bank(Z: np.ndarray, ep: EpochPhases, B: np.ndarray, R0: np.ndarray, refs: list[int], kappa: float,
             enabled: bool = True, model: str = "chi2") -> BankResult:
    """The bank on one epoch. Z: integer-corrected single differences (snapshot.integer_corrected) relative to
    refs[0]; refs: reference satellites to try in order (highest elevation first); model: see `threshold`."""
    def thr(mu):
        return threshold(mu, kappa, model)

    candidates = list(range(len(ep.sats)))
    costs_all = []
    for ref in refs[:2]:
        full, fits, costs = _processors(Z, ep, B, R0, ref, thr, candidates)
        costs_all += costs
        if not enabled or full.J < thr(full.dof):
            return BankResult(full, False, None, None, ref, costs_all)
        below = [(f.J / thr(f.dof), p) for p, f in fits.items() if f.J < thr(f.dof)]
        if below:
            _, q = min(below)
            return BankResult(fits[q], True, q, _antenna_of(fits[q], ep, Z, B, q), ref, costs_all)
    return BankResult(None, True, None, None, refs[0], costs_all)
