"""A fix whose integer constraint cannot be applied is an event and leaves the baseline float (issue 21 item 1).

The failure is forced: the first-fix constraint update (boxes.ambiguity_resolution.pseudo_update's Joseph update)
reports S not positive definite, and the compiled newcomers' update gets a covariance whose DD variance is
negative. Nothing may then claim a fix: no "fix" event, no fix_log row, no epoch flagged fixed.
"""
from __future__ import annotations

import numpy as np

import gnssatt.attitude.boxes.ambiguity_resolution as AR
from gnssatt.attitude import update_kernels as UK
from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import AttitudeSettings
from tests.attitude.conftest import set_files


def test_failed_first_fix_constraint_is_an_event_and_the_baseline_stays_float(clean_pass, monkeypatch):
    def failing_update(x, P, cols, coef, R, innovation):
        return x, P, None, False                  # what joseph_update_sparse answers when S is not PD

    monkeypatch.setattr(AR, "joseph_update_sparse", failing_update)
    sol = process(load_inputs(set_files(clean_pass)), AttitudeSettings.preset("seed000", mode="dynamic"))
    kinds = [e["event"] for e in sol.fr.events]
    assert kinds.count("fix_constraint_failed") > 10      # every accepted candidate, epoch after epoch
    assert "fix" not in kinds and "fix_added" not in kinds and "omega_reset" not in kinds
    assert not sol.fr.fixed.any()
    assert sol.fr.fix_log["epoch"].size == 0
    assert (sol.fr.first_fix_epoch < 0).all()


def test_newcomers_constraint_failure_restores_the_float_state():
    """fix_newcomers on a covariance whose DD variance is negative (so no positive innovation variance): applied
    False, x, P and amb_fixed exactly as before; the same call on a proper covariance applies the constraint."""
    from gnssatt.attitude.update_records import FixState, RoundingLimits, UsedRows

    nfp = 2
    x = np.array([0.0, 0.0, 5.02, 2.01, 7.0])             # ambiguity states 2, 3, 4; state 4 fixed (the reference)
    P_bad = np.diag([1.0, 1.0, 1e-4, 1e-4, 1e-4])
    P_bad[2, 4] = P_bad[4, 2] = 1e-3                      # var(x2 - x4) = 2e-4 - 2e-3 < 0
    P_bad[3, 4] = P_bad[4, 3] = 1e-3
    amb_fixed = np.array([False, False, True])
    amb_key = np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0]], np.int64)
    mc_n = 1
    cols = np.full((mc_n + 3, 5), -1, np.int64)
    cols[mc_n:, 4] = [2, 3, 4]
    z1 = np.zeros(mc_n, np.int64)
    rows = UsedRows.plain(jc=z1, sc=z1, fc=z1, jp=np.zeros(3, np.int64), sp=np.arange(3, dtype=np.int64),
                          fp=np.zeros(3, np.int64))
    limits = RoundingLimits.plain(max_sigma_cyc=0.3, max_frac_cyc=0.3, var_cyc2=1e-6)
    el = np.full(3, 0.5)
    x1, P1, fixed1 = x.copy(), P_bad.copy(), amb_fixed.copy()
    nw, rf, vals, applied = UK.fix_newcomers(x1, P1, FixState.plain(amb_fixed=fixed1, amb_key=amb_key), nfp, cols,
                                             rows, el, 1, 0, limits)
    assert nw.size == 2 and not applied
    assert np.array_equal(x1, x) and np.array_equal(P1, P_bad) and np.array_equal(fixed1, amb_fixed)

    P_ok = np.diag([1.0, 1.0, 1e-4, 1e-4, 1e-4])
    x2, fixed2 = x.copy(), amb_fixed.copy()
    nw, rf, vals, applied = UK.fix_newcomers(x2, P_ok, FixState.plain(amb_fixed=fixed2, amb_key=amb_key), nfp, cols,
                                             rows, el, 1, 0, limits)
    assert applied and fixed2.all()
    # the constraint holds to 1e-3 cycle (its variance 1e-6 cycles^2)
    assert np.all(np.abs(x2[nw] - x2[rf] - vals) < 1e-3)
