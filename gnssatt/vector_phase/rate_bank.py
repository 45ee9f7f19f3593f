"""Multi-hypothesis start of the vector-phase EKF (issue 20): a bank of filters from several initial angular
rates, kept as a Gaussian sum (Alspach and Sorenson 1972) until one member is clearly the best.

Why: with exactly seven satellites and 1-3 mm of phase noise the batch (smoother) cost of the first tens of
seconds has a second minimum reached from the same known start by a different early rate (a pitch about 50 deg
off): over 30 / 60 / 120 s its cost is 3.6 / 13.7 / 38.7 above the truth's minimum (docs/vector_phase.md
"A second minimum, not a linearisation failure"). One filter from zero rate falls into it in one run of four to six and
cannot leave it; the data resolve it only later, so the choice is deferred to them.
Members: the single filter itself (zero rate, sigma0 = sigma_rate0_deg_s: the null hypothesis) and 27 filters from
the initial rates {-step, 0, +step}^3 (body axes), each with sigma step / 2 and prior weight w_i ~ N(omega_i; 0,
sigma0^2 - (step / 2)^2) (the 27 approximate the single filter's N(0, sigma0^2) prior). Cost of a member: -2 ln w_i
+ sum_k (nu_k^T S_k^-1 nu_k + ln det S_k), its innovations nu_k and their covariance S_k (the iterated update's,
ekf._Filter.update): -2 ln of its posterior weight up to a common constant. The single filter counts as the zero-
rate member (w = 1, unnormalised like the others: normalised, the members' share of the prior mass, 1/8 here, held
the single filter in a wrong minimum in one run of 16 at 3 mm, seed 12). Each epoch a member is dropped when its
cost exceeds the best's by more than hypothesis_prune_cost (default 13.8 = 2 ln 1000: 1000 to 1 against it), or
when it is within hypothesis_merge_sigma (Mahalanobis, attitude and rate) of a better member or of the single
filter (the same minimum). The single filter is only ever dropped by cost, so where it is right (8 or more
satellites: one minimum) the result is the single filter's. After hypothesis_max_epochs the best is kept and the
start reported ambiguous (Solution.warnings, Solution.start_hypotheses).
Reported covariance (hypothesis_mixture_covariance, default on): at every epoch where more than one member lived, the
kept member's state with the Gaussian sum's covariance about it, sum_i w_i (P_i + d_i d_i^T) (w_i ~ exp(-cost_i / 2)
at that epoch, d_i the member's state minus the kept one's): the spread of the posterior, not only its curvature at
one member. 7 satellites, 3 mm, seeds 0-7: error/sigma 1.12 / 1.30 / 0.97 -> 1.08 / 1.14 / 0.94 (docs/vector_phase.md).
"""
from __future__ import annotations

from dataclasses import replace
from itertools import product

import numpy as np

from gnssatt.vector_phase.ekf_filter import EkfOptions, _Run
from gnssatt.vector_phase.phase_model import AntennaMount, ReceiverState
from gnssatt.vector_phase.rotation import error_rotvec_body
from gnssatt.vector_phase.solution import Solution

__all__ = ["bank_solve", "initial_rates_deg_s"]


def initial_rates_deg_s(step_deg_s: float) -> np.ndarray:
    """(27, 3) initial body rates of the members besides the single filter, deg/s: {-step, 0, +step}^3, zero
    first."""
    grid = np.array(sorted(product((0.0, -1.0, 1.0), repeat=3), key=lambda v: np.count_nonzero(v)))
    return grid * step_deg_s


def _prior_costs(rates_deg_s: np.ndarray, opt: EkfOptions) -> np.ndarray:
    """-2 ln w_i of the members centred on rates_deg_s (n, 3): Gaussian-sum weights of the rate prior (w = 1 at
    zero rate)."""
    var = max(opt.sigma_rate0_deg_s ** 2 - (opt.rate_hypotheses_step_deg_s / 2) ** 2, 1e-6)
    return np.sum(rates_deg_s ** 2, axis=1) / var


def _distance2(a: _Run, b: _Run) -> float:
    """Squared Mahalanobis distance of a's attitude and rate from b's, with b's covariance."""
    d = np.r_[error_rotvec_body(a.f.R, b.f.R), a.f.w - b.f.w]
    return float(d @ np.linalg.solve(b.f.P[4:10, 4:10], d))


def _prune(members: list, costs: dict, opt: EkfOptions, single) -> list:
    """Members kept: within the prune cost of the best, and not inside a better member's or the single filter's
    merge distance (the single filter is dropped only by cost)."""
    best = min(costs[id(m)] for m in members)
    alive = [m for m in members if costs[id(m)] - best <= opt.hypothesis_prune_cost]
    anchor = [single] if single in alive else []
    kept = list(anchor)
    for m in sorted(alive, key=lambda m: costs[id(m)]):
        if m is single or any(_distance2(m, k) < opt.hypothesis_merge_sigma ** 2 for k in kept):
            continue
        kept.append(m)
    return kept


def _copy_rows(src: Solution, dst: Solution, n: int) -> None:
    """Rows [0, n) of src into dst."""
    for name in ("position_ecef_m", "clock_cyc", "R_body_from_ecef", "P", "rank", "condition",
                 "null_rotation_body", "n_sats", "residuals_cyc", "valid"):
        getattr(dst, name)[:n] = getattr(src, name)[:n]
    dst.observability[:n] = src.observability[:n]


def _record(members: list, costs: dict, n_members: int, epoch: int) -> dict:
    """Solution.start_hypotheses: how the bank ended (members[0] is the best)."""
    best = members[0]
    others = members[1:]
    diff_deg = [float(np.degrees(np.linalg.norm(error_rotvec_body(m.f.R, best.f.R)))) for m in others]
    return {"members": n_members, "decided_epoch": epoch, "remaining": len(members),
            "ambiguous": bool(others), "cost_above_best": [float(costs[id(m)] - costs[id(best)]) for m in others],
            "attitude_difference_deg": diff_deg}


def bank_solve(obs, mount: AntennaMount, initial: ReceiverState, opt: EkfOptions, progress=None) -> Solution:
    """Solution of the best member of the bank (module docstring) over PhaseObservations obs."""
    n_ep = len(obs.t_gps_s)
    window = min(n_ep, max(opt.hypothesis_max_epochs, 1))
    member_opt = replace(opt, sigma_rate0_deg_s=opt.rate_hypotheses_step_deg_s / 2, rate_hypotheses_step_deg_s=0.0)
    rates = initial_rates_deg_s(opt.rate_hypotheses_step_deg_s)

    def rows():
        return Solution.empty(obs.t_gps_s[:window], obs.sats, "ekf")
    single = _Run(obs, mount, initial, replace(opt, rate_hypotheses_step_deg_s=0.0), rows())
    members = [single] + [_Run(obs, mount, initial, member_opt, rows(), np.radians(r)) for r in rates]
    single.label = "single filter (zero rate)"
    for m, r in zip(members[1:], rates):
        m.label = f"initial rate ({r[0]:g}, {r[1]:g}, {r[2]:g}) deg/s"
    prior = dict(zip(map(id, members), np.r_[0.0, _prior_costs(rates, opt)]))
    n_total = len(members)
    full = Solution.empty(obs.t_gps_s, obs.sats, "ekf")
    record, history = None, []
    for k in range(n_ep):
        if record is None and k == window:
            record = _decide(members, prior, n_total, k - 1, full, history, opt)
            members = members[:1]
        for m in members:
            m.step(k)
        if record is None:
            costs = {id(m): m.f.cost + prior[id(m)] for m in members}
            members = _prune(members, costs, opt, single)
            history.append(_snapshot(members, costs, k))
            if len(members) == 1:
                record = _decide(members, prior, n_total, k, full, history, opt)
        if progress is not None and k % 50 == 0:
            progress(k / n_ep)
    if record is None:
        record = _decide(members, prior, n_total, n_ep - 1, full, history, opt)
    full.start_hypotheses = record
    if record["ambiguous"]:
        full.warnings.append(
            f"start ambiguous: {record['remaining']} of {record['members']} initial-rate hypotheses still fit the "
            f"phases at epoch {record['decided_epoch']} (cost within {opt.hypothesis_prune_cost:g} of the best; "
            f"attitudes up to {max(record['attitude_difference_deg']):.1f} deg apart); the best is reported")
    return full


def _snapshot(members: list, costs: dict, k: int) -> dict:
    """The living members' states at epoch k (after pruning): cost, position, clock, attitude, 7 x 7 covariance."""
    return {id(m): (costs[id(m)], m.sol.position_ecef_m[k].copy(), m.sol.clock_cyc[k], m.sol.R_body_from_ecef[k].copy(),
                    m.sol.P[k].copy(), bool(m.sol.valid[k])) for m in members}


def mixture_covariance(entries: list, ref) -> np.ndarray:
    """7 x 7 covariance of a Gaussian sum about the reported state ref = (position, clock, R_body_from_ecef):
    sum_i w_i (P_i + d_i d_i^T), d_i = x_i - ref, w_i ~ exp(-cost_i / 2) (Alspach and Sorenson 1972; the
    mean-square error of ref under the mixture posterior). entries: (cost, position, clock, R, P) per member."""
    costs = np.array([e[0] for e in entries])
    w = np.exp(-(costs - costs.min()) / 2)
    w /= w.sum()
    out = np.zeros((7, 7))
    for wi, (_, r, b, R, P) in zip(w, entries):
        d = np.r_[r - ref[0], b - ref[1], error_rotvec_body(R, ref[2])]
        out += wi * (P + np.outer(d, d))
    return out


def _mix_rows(best, full: Solution, history: list, opt: EkfOptions) -> int:
    """Rows of full while several members lived: the Gaussian-sum covariance about the kept member's state. Returns
    the number of such rows."""
    if not opt.hypothesis_mixture_covariance:
        return 0
    n = 0
    for k, snap in enumerate(history):
        mine = snap.get(id(best))
        if mine is None or len(snap) < 2 or not full.valid[k]:
            continue
        entries = [e[:5] for e in snap.values() if e[5]]
        full.P[k] = mixture_covariance(entries, (mine[1], mine[2], mine[3]))
        n += 1
    return n


def _decide(members: list, prior: dict, n_members: int, epoch: int, full: Solution, history: list,
            opt: EkfOptions) -> dict:
    """Keep the best member from here on: its rows so far into full, then it writes full itself."""
    costs = {id(m): m.f.cost + prior[id(m)] for m in members}
    members.sort(key=lambda m: costs[id(m)])
    record = _record(members, costs, n_members, epoch)
    record["kept"] = members[0].label
    best = members[0]
    _copy_rows(best.sol, full, epoch + 1)
    record["mixture_covariance_epochs"] = _mix_rows(best, full, history, opt)
    best.sol, best.row0 = full, 0
    return record
