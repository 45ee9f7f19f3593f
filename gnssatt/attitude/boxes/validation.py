"""Fig. 2 box "validation": the tests a first-fix candidate must pass before its integers constrain the filter.

Implements: seed 000 sec. 2 (the fixed baseline's length against the known length within Table 2's 3 cm, done
inside gnssatt.attitude.ambiguity.resolve_first_fix), plus the ratio test of the first fix (Teunissen/Verhagen
ratio, settings.ar_min_ratio_first_fix) and, with fixed partner baselines, the angle test against their directions
(gnssatt.attitude.validation.angle_test_against_fixed, max_angle_error_m).
"""
from __future__ import annotations

import numpy as np

from gnssatt.attitude.filter_state import ANGLE_FAIL_RESET, EpochData, FilterRun
from gnssatt.attitude.single_epoch_length import single_epoch_baseline
from gnssatt.attitude.validation import angle_test_against_fixed, fixed_baseline_vector


def validate_first_fix(run: FilterRun, ep: EpochData, j: int, outcome) -> None:
    """outcome.accepted cleared (with outcome.reason) when the first fix of baseline j fails the ratio test or
    the angle test; after ANGLE_FAIL_RESET angle failures in a row the partners' fix is queued for withdrawal
    (run.pending_reset, carried out by the fix monitor)."""
    s, st = run.s, run.st
    if outcome.accepted and not (outcome.ratio >= s.ambiguity.min_ratio_first_fix):
        outcome.accepted = False
        outcome.reason = f"ratio {outcome.ratio:.2f} < {s.ambiguity.min_ratio_first_fix:.2f} (first fix)"
    _length_tests(run, ep, j, outcome)
    if not (outcome.accepted and run.n_bl > 1 and s.ambiguity.max_angle_error_m > 0):
        return
    partners = [j2 for j2 in range(run.n_bl) if j2 != j and st.baseline_has_fix(j2)]
    if not partners:
        return
    b_cand = fixed_baseline_vector(st.x, st.P, outcome.D, outcome.a_fix, run.b_idx[j])
    body = run.body_baselines_m
    ok_ang, worst = angle_test_against_fixed(b_cand, body[j], st.x[run.b_idx[partners]], body[partners],
                                             s.ambiguity.max_angle_error_m)
    if ok_ang:
        run.angle_fail[j] = 0
        return
    outcome.accepted = False
    outcome.reason = f"angle to fixed baseline(s) {partners} off by {worst:.2f} deg (length {outcome.length_m:.4f} m)"
    run.angle_fail[j] += 1
    if run.angle_fail[j] >= ANGLE_FAIL_RESET:
        # a candidate that passes length and ratio but never fits the partners' directions: the partners' fix is
        # the suspect one; back to float on all of them
        for j2 in partners:
            run.pending_reset[j2] = f"{ANGLE_FAIL_RESET} candidates of baseline {j} in a row failed the angle test " \
                                    f"against it"
        run.angle_fail[j] = 0


def _length_tests(run: FilterRun, ep: EpochData, j: int, outcome) -> None:
    """The length test of settings.ambiguity.length_validation on a candidate: the filter's conditional baseline
    (already tested by the search unless "single-epoch"), the epoch's own single-epoch baseline
    (gnssatt.attitude.single_epoch_length) for "single-epoch" / "both"; the single-epoch length goes into the
    fix event (outcome.length_note) and the rejection reason in every mode where it is computed."""
    s, st = run.s, run.st
    mode = s.ambiguity.length_validation
    if outcome.D is None or outcome.a_fix is None:
        return
    tol, L = s.ambiguity.max_length_error_m, run.lengths[j]
    b1 = single_epoch_baseline(outcome.D, outcome.a_fix, st.x, st.n_fixed_part, st.amb_key, ep.sdp_c, ep.pcv_m,
                               ep.u, ep.cfac, run.lam)
    l1 = float(np.linalg.norm(b1)) if b1 is not None else float("nan")
    outcome.length_note = (f"; single-epoch length {l1:.4f} m" if b1 is not None
                           else "; single-epoch length: too few DDs with data")
    if not outcome.accepted or mode == "filter":
        return
    if mode == "single-epoch" and abs(outcome.length_m - L) > tol:
        outcome.length_note += " (the filter length is not tested in this mode)"
    if not abs(l1 - L) <= tol:
        outcome.accepted = False
        outcome.reason = f"single-epoch length test failed vs known {L:.4f} m"
