"""Fig. 2 box "ambiguity resolution": integer fixing of the float SD ambiguities of each baseline and the
"pseudo"-measurement update that constrains them.

Implements: seed 000 sec. 2 (double differences of the float SD ambiguities and their covariance, integers by
MLAMBDA (Chang, Yang & Zhou 2005; gnssatt.attitude.ambiguity), validated (boxes/validation.py), then the DD
integers as observations with zero variance (here PSEUDO_VAR_CYC2, Joseph form)); MC-LAMBDA of all baselines
together when ambiguity_search is "constrained"; newcomers on a fixed baseline rounded to integers against the
fixed reference of their signal; omega reset when a fix turns its baseline (OMEGA_RESET_TURN_DEG).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.ambiguity import first_fix_groups, resolve_first_fix, resolve_joint_constrained
from gnssatt.attitude.boxes.validation import validate_first_fix
from gnssatt.attitude.fastops import clip as _clip
from gnssatt.attitude.filter_state import (DEG, OMEGA_RESET_TURN_DEG, PSEUDO_VAR_CYC2, EpochData, FilterRun,
                                           FilterState)
from gnssatt.attitude.update_kernels import fix_newcomers
from gnssatt.attitude.update_records import FixState
from gnssatt.estimation.ekf import joseph_update_sparse


def ambiguity_resolution(run: FilterRun, ep: EpochData) -> None:
    """Per baseline with enough used satellites and float ambiguities: a first fix (no fixed signal yet) or the
    newcomers' rounding (already fixed); sets ep.ar_changed, run.first_data / first_fix, the AR ratio output."""
    s, k = run.s, ep.k
    joint_ar = _joint_first_fix(run, ep)
    for j in range(run.n_bl):
        if ep.n_used[j] and run.first_data[j] < 0:
            run.first_data[j] = k
        if not ep.pa[j] or ep.n_used[j] < s.ambiguity.min_sats or not ep.n_unfixed[j]:
            continue
        if not ep.has_fix[j]:                                  # no signal of baseline j fixed yet
            _first_fix(run, ep, j, joint_ar)
        else:
            _fix_newcomers(run, ep, j)


def _phase_rows_of(ep: EpochData, j: int):
    """(state index, signal, local elevation) of the phase rows of baseline j."""
    sel_j = ep.jp == j
    return ep.cols[ep.mc_n:, 4][sel_j], ep.fp[sel_j], ep.el_loc[ep.sp[sel_j]]


def _joint_first_fix(run: FilterRun, ep: EpochData) -> dict:
    """ambiguity_search "constrained": one MC-LAMBDA first fix of all baselines together (accepted outcomes by
    baseline), when nothing is fixed yet and at least two baselines have enough DDs."""
    s = run.s
    if not (s.ambiguity.ambiguity_search == "constrained" and run.n_bl >= 2 and ep.mp_n and not run.st.amb_fixed.any()):
        return {}
    gb = {}
    for j in range(run.n_bl):
        if ep.pa[j] and ep.n_used[j] >= s.ambiguity.min_sats:
            idx_j, sig_j, el_j = _phase_rows_of(ep, j)
            gb[j] = first_fix_groups(idx_j, sig_j, el_j, run.n_sig)
    gb = {j: g for j, g in gb.items() if g and sum(x.size - 1 for x, _ in g) >= s.ambiguity.min_dd}
    if len(gb) < 2:
        return {}
    return {j: o for j, o in resolve_joint_constrained(run.st.x, run.st.P, gb, run.b_idx, run.body_baselines_m,
                                                       s).items() if o.accepted}


def _first_fix(run: FilterRun, ep: EpochData, j: int, joint_ar: dict) -> None:
    """MLAMBDA on the DDs of baseline j's float ambiguities, validation, and on acceptance the pseudo-measurement
    update (with the omega reset when the fix turned the baseline)."""
    s, st, k = run.s, run.st, ep.k
    groups = first_fix_groups(*_phase_rows_of(ep, j), run.n_sig)
    if not groups or sum(g.size - 1 for g, _ in groups) < s.ambiguity.min_dd:
        return
    outcome = joint_ar.get(j) or resolve_first_fix(st.x, st.P, groups, run.b_idx[j], run.lengths[j], run.s_search)
    run.out_ratio[k, j] = outcome.ratio
    validate_first_fix(run, ep, j, outcome)
    if not outcome.accepted:
        run.events.add(k, "fix_rejected", j, detail=f"ratio {outcome.ratio:.2f}, {outcome.reason}"
                                                    f"{outcome.length_note}")
        return
    run.angle_fail[j] = 0
    b_before = st.x[run.b_idx[j]].copy()
    if not pseudo_update(st, outcome.D, outcome.a_fix):
        # the constraint could not be applied (S not positive definite): no fix, the baseline stays float
        run.events.add(k, "fix_constraint_failed", j, detail=f"{outcome.n_dd} DD ambiguities, ratio "
                                                             f"{outcome.ratio:.2f}: constraint update not applied")
        return
    _log_fix(run, k, outcome.D, outcome.a_fix)
    b_after = st.x[run.b_idx[j]]
    turn_deg = np.degrees(np.arccos(_clip(b_before @ b_after / max(
        np.linalg.norm(b_before) * np.linalg.norm(b_after), 1e-12), -1.0, 1.0)))
    if run.dynamic and turn_deg > OMEGA_RESET_TURN_DEG:
        _reset_omega(run, k, j, turn_deg)
    for g, _ in outcome.groups or groups:
        st.amb_fixed[g - st.n_fixed_part] = True
    ep.ar_changed = True
    run.events.add(k, "fix", j, detail=f"{outcome.n_dd} DD ambiguities, ratio {outcome.ratio:.2f}, "
                                       f"length {outcome.length_m:.4f} m (filter){outcome.length_note}")
    if run.first_fix[j] < 0:
        run.first_fix[j] = k


def _reset_omega(run: FilterRun, k: int, j: int, turn_deg: float) -> None:
    """The angular velocity was learnt with a baseline that the fix has just turned: its estimate and covariance
    (linearised about the wrong baseline) are not to be trusted; back to Table 1's sigma0."""
    st = run.st
    nr = st.n_rate                                   # omega [and alpha]
    st.P[0:nr, :] = 0.0
    st.P[:, 0:nr] = 0.0
    st.P[0:3, 0:3] = np.eye(3) * (run.s.table1.sigma0_omega_deg_s * DEG) ** 2
    if nr == 6:
        st.x[3:6] = 0.0
        st.P[3:6, 3:6] = np.eye(3) * (run.s.sigma0_angular_acceleration_deg_s2 * DEG) ** 2
    run.events.add(k, "omega_reset", j, detail=f"the fix turned the baseline by {turn_deg:.2f} deg")
    run.mark_segment_start(k)
    if run.adapter is not None:
        run.adapter.reset()


def _fix_newcomers(run: FilterRun, ep: EpochData, j: int) -> None:
    """Newcomers on a fixed baseline: DD to the fixed reference of their signal rounded (compiled) and constrained
    in place (DD pseudo-measurements as in pseudo_update, as scalar Joseph updates)."""
    st, k = run.st, ep.k
    fix = FixState.plain(amb_fixed=st.amb_fixed, amb_key=st.amb_key)      # (st.x, st.P may have been replaced)
    nw, rf, vals, applied = fix_newcomers(st.x, st.P, fix, st.n_fixed_part, ep.cols, ep.rows, ep.el_loc, run.n_sig,
                                          j, run.rounding_limits)
    if nw.size and not applied:
        run.events.add(k, "fix_constraint_failed", j, detail=f"{nw.size} newcomers rounded: constraint update "
                                                             "not applied, they stay float")
    elif nw.size:
        ep.ar_changed = True
        run.fix_rows.extend(zip([k] * nw.size, st.amb_arc[nw - st.n_fixed_part].tolist(),
                                st.amb_arc[rf - st.n_fixed_part].tolist(), vals.tolist()))
        run.events.add(k, "fix_added", j, detail=f"{nw.size} newcomers fixed by rounding")


def _log_fix(run: FilterRun, k: int, D: np.ndarray, a_fix: np.ndarray) -> None:
    """The fix log rows (epoch, arc, reference arc, integer) of the two-term DD rows of D."""
    st = run.st
    for row, v in zip(D, a_fix):
        pos, neg = np.flatnonzero(row > 0.5), np.flatnonzero(row < -0.5)
        if pos.size == 1 and neg.size == 1:
            run.fix_rows.append((k, int(st.amb_arc[pos[0] - st.n_fixed_part]),
                                 int(st.amb_arc[neg[0] - st.n_fixed_part]), float(v)))


def pseudo_update(st: FilterState, D: np.ndarray, a_fix: np.ndarray) -> bool:
    """Constrain DD ambiguities D x = a_fix with a (numerically) zero-variance pseudo-measurement (Joseph form):
    seed 000 sec. 2 "the resolved double-difference ambiguities are used as observations with zero variance".
    False (st unchanged) when the update could not be applied (its S not positive definite)."""
    r, c = np.nonzero(D)                         # row-major: each row's columns ascending
    cnt = np.bincount(r, minlength=D.shape[0])
    kmax = int(cnt.max())
    pos = np.arange(r.size) - np.repeat(np.cumsum(cnt) - cnt, cnt)   # position of each non-zero in its row
    cols = np.full((D.shape[0], kmax), -1, dtype=np.int64)
    coef = np.zeros((D.shape[0], kmax))
    cols[r, pos] = c
    coef[r, pos] = D[r, c]
    innov = a_fix - D @ st.x
    # 1e-6 cycles^2 keeps S positive definite in float64 without loosening the constraint noticeably
    x1, P1, _, good = joseph_update_sparse(st.x, st.P, cols, coef, np.full(D.shape[0], PSEUDO_VAR_CYC2), innov)
    if good:
        st.x, st.P = x1, P1
    return bool(good)
