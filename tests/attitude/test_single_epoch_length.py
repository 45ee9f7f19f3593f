"""Seed 000's single-epoch length validation (gnssatt.attitude.single_epoch_length, option
ambiguity.length_validation; issue 21 item 6): the epoch's own baseline with the candidate integers, and the
option on a short realistic pass."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.attitude.single_epoch_length import single_epoch_baseline


def _epoch(rng, n_sat=8, noise_m=0.0):
    """A synthetic epoch of one baseline, one signal: SD phase = -u.b + cf c + lambda A (+ noise)."""
    lam = np.array([0.1903])
    b = np.array([0.6, -0.8, 0.3])
    u = rng.normal(size=(n_sat, 3))
    u[:, 2] = np.abs(u[:, 2]) + 0.3
    u /= np.linalg.norm(u, axis=1)[:, None]
    cf = 1.0 - rng.normal(size=n_sat) * 1e-6
    clock = 1234.5
    A = np.round(rng.normal(size=n_sat) * 1e4)                     # integer SD ambiguities (cycles)
    sdp = (-u @ b + cf * clock + lam[0] * A + rng.normal(size=n_sat) * noise_m)[None, :, None]
    nfp = 4
    amb_key = np.stack([np.zeros(n_sat, np.int64), np.arange(n_sat), np.zeros(n_sat, np.int64)], 1)
    x = np.zeros(nfp + n_sat)
    x[nfp:] = A + rng.normal(size=n_sat) * 0.3                    # the filter's floats: off by a fraction of a cycle
    D = np.zeros((n_sat - 1, x.size))
    D[np.arange(n_sat - 1), nfp + 1 + np.arange(n_sat - 1)] = 1.0
    D[:, nfp] = -1.0                                             # reference: satellite 0
    a_true = A[1:] - A[0]
    return dict(D=D, x=x, nfp=nfp, amb_key=amb_key, sdp=sdp, pcv=np.zeros_like(sdp), u=u, cf=cf, lam=lam, b=b,
                a_true=a_true)


def _solve(e, a_fix):
    return single_epoch_baseline(e["D"], a_fix, e["x"], e["nfp"], e["amb_key"], e["sdp"], e["pcv"], e["u"], e["cf"],
                                 np.broadcast_to(np.atleast_2d(e["lam"]), e["u"].shape[:1] + np.shape(e["lam"])[-1:]))


def test_right_integers_give_the_baseline_whatever_the_filter_floats():
    """Noise-free data, right integers: the baseline to 1 um (float64 of 1e4-cycle ambiguities x 19 cm), although
    the filter's float of the reference is 0.3 cycles off (it only shifts the group's clock)."""
    e = _epoch(np.random.default_rng(1))
    b = _solve(e, e["a_true"])
    assert np.max(np.abs(b - e["b"])) < 1e-6


def test_a_wrong_integer_moves_the_length_by_centimetres():
    """One DD off by a cycle moves the epoch's baseline by ~lambda times the geometry: its length by > 1 cm here
    (the Table 2 tolerance is 3 cm; a wrong vector usually moves it by more), and a fix of the wrong integers
    on noisy data (3 mm) stays distinguishable from the right ones."""
    rng = np.random.default_rng(2)
    e = _epoch(rng, noise_m=0.003)
    L = np.linalg.norm(e["b"])
    right = abs(np.linalg.norm(_solve(e, e["a_true"])) - L)
    wrong_a = e["a_true"].copy()
    wrong_a[[0, 2]] += [1.0, -1.0]
    wrong = abs(np.linalg.norm(_solve(e, wrong_a)) - L)
    assert right < 0.005 and wrong > 0.01, (right, wrong)


def test_too_few_dds_give_none():
    e = _epoch(np.random.default_rng(3), n_sat=3)                 # 2 DDs: fewer than the 3 unknowns of b
    assert _solve(e, e["a_true"]) is None


@pytest.mark.parametrize("mode", ["single-epoch", "both"])
def test_option_on_the_realistic_pass_fixes_right_and_reports_both_lengths(realistic_pass, mode):
    """The option on the 10-min realistic pass (multipath, PCV, PCO): every fix event names both lengths, no
    wrong integer (truth arcs), the fix rate within 1 % of today's filter-baseline test."""
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import score_fixes
    from tests.attitude.conftest import set_files

    inputs = load_inputs(set_files(realistic_pass))
    sols = {m: process(inputs, AttitudeSettings.preset("seed000", ambiguity={"length_validation": m}))
            for m in ("filter", mode)}
    fixes = [e for e in sols[mode].fr.events if e["event"] == "fix"]
    assert fixes and all("(filter); single-epoch length" in e["detail"] for e in fixes)
    assert score_fixes(sols[mode], realistic_pass / "truth")["wrong_constraints"] == 0
    assert sols[mode].att_fixed.mean() > sols["filter"].att_fixed.mean() - 0.01
