"""Fig. 2 after the ambiguity branch, beyond the paper: the fix monitor, which withdraws a fix whose phases stop
fitting, and the recount of the fixed baselines.

Implements: a post-fit residual test of the fixed phases (RMS above FIX_CHECK_SIGMAS noise sigmas and
FIX_CHECK_MIN_M for FIX_CHECK_EPOCHS epochs in a row: a wrong fix or an undetected slip; docs/attitude.md), the
withdrawal of partners queued by the angle test (boxes/validation.py), and the "fix_lost" events; seed 000 sec. 2
"if the ambiguity resolution was not successful, another attempt is done after the next measurement update"
follows, as the baseline restarts as float.
"""
from __future__ import annotations

import math

import numpy as np

from gnssatt.attitude.filter_state import FIX_CHECK_EPOCHS, FIX_CHECK_MIN_M, FIX_CHECK_SIGMAS, EpochData, FilterRun
from gnssatt.attitude.update_kernels import phase_row_stats


def fix_monitor(run: FilterRun, ep: EpochData) -> None:
    """Withdraw suspect fixes (restart as float), then recount which baselines hold a fixed ambiguity
    (run.ever_fixed) and the fixed satellites used (ep.n_fixed_used)."""
    st, k, n_bl = run.st, ep.k, run.n_bl
    if ep.mp_n:
        if ep.ar_changed:
            _, ep.n_fixed_post, _, ep.n_fix_rows, ep.ms_fix = phase_row_stats(
                ep.jp, ep.sp, ep.cols, ep.mc_n, st.amb_fixed, st.n_fixed_part, ep.post, n_bl, run.n_sat)
        lim = max(FIX_CHECK_SIGMAS * math.sqrt(max(ep.vp_f.tolist())), FIX_CHECK_MIN_M)
        for j in range(n_bl):
            if ep.n_fix_rows[j] >= 4:
                rms = np.sqrt(ep.ms_fix[j])
                run.bad_fix[j] = run.bad_fix[j] + 1 if rms > lim else 0
                if run.bad_fix[j] >= FIX_CHECK_EPOCHS:
                    reset_baseline(run, k, j, f"post-fit phase RMS {rms * 1e3:.1f} mm > {lim * 1e3:.1f} mm "
                                              f"for {FIX_CHECK_EPOCHS} epochs")
                    ep.mp_n = 0          # the state no longer matches this epoch's rows
    # partners withdrawn by the angle test (after the monitor: the state layout changes)
    for j2, why in run.pending_reset.items():
        if st.baseline_has_fix(j2):
            reset_baseline(run, k, j2, why)
            ep.mp_n = 0
    run.pending_reset.clear()
    _recount_fixed(run, ep)


def _recount_fixed(run: FilterRun, ep: EpochData) -> None:
    """run.ever_fixed after AR and the monitor; "fix_lost" for baselines that held a fix and hold none now."""
    st = run.st
    had_fix = run.ever_fixed
    if ep.mp_n and not ep.ar_changed:
        run.ever_fixed = ep.has_fix                    # st.amb_fixed as measurement_update saw it
    else:
        run.ever_fixed = np.zeros(run.n_bl, bool)
        run.ever_fixed[st.amb_key[st.amb_fixed, 0]] = True
    lost = had_fix & ~run.ever_fixed
    if lost.any():
        for j in np.flatnonzero(lost):
            run.events.add(ep.k, "fix_lost", j, detail="no fixed ambiguity left (slips, gaps or setting satellites)")
    if ep.mp_n and ep.ar_changed:
        ep.n_fixed_used = ep.n_fixed_post             # after AR (a reset above leaves the count before AR)


def reset_baseline(run: FilterRun, k: int, j: int, why: str) -> None:
    """Withdraw every ambiguity of baseline j (restart as float) and its baseline covariance (back to Table 1's
    sigma0): it learnt from the suspect integers too, and would otherwise re-fix the same ones."""
    st, s = run.st, run.s
    drop = np.flatnonzero(st.amb_key[:, 0] == j) + st.n_fixed_part
    st.remove_ambiguities(drop, k)
    bi = run.b_idx[j]
    st.P[bi, :] = 0.0
    st.P[:, bi] = 0.0
    st.P[bi, bi] = max(s.table1.sigma0_baseline_m, 1.2 * run.lengths[j]) ** 2
    run.bad_fix[j] = 0
    if run.adapter is not None:
        run.adapter.reset()
    run.events.add(k, "fix_reset", j, detail=f"{why}: ambiguities restart")
    run.mark_segment_start(k)
