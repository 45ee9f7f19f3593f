"""Single-epoch single-frequency solutions on a short CubeSat-like set (preset `cubesat`: 10 cm baselines, L1,
switch-on acquisition delays as the preset has them): the per-method usability rule (the constrained search
attempts baselines with 3-5 DDs that the paper's MLAMBDA + length rule leaves out) and zero wrong fixes against
the simulator's truth integers, with every epoch that has 4 or more satellites on both baselines fixed right."""
from __future__ import annotations


import numpy as np
import pytest

from tests.attitude.conftest import set_files
from gnssatt.sim import simulate_scenario
from gnssatt.ttff.data import load_study_set
from gnssatt.ttff.single_epoch import SingleEpochOptions, epoch_problem, solve_constrained, solve_lambda

DURATION_S = 120.0
STEP_S = 5.0


@pytest.fixture(scope="module")
def cubesat_set(tmp_path_factory):
    d = tmp_path_factory.mktemp("cubesat_set")
    simulate_scenario("cubesat", d, seed=1000, overrides={"count": 1, "duration_s": DURATION_S,
                                                          "truth_components": False,
                                                          "start_gps": "2019-01-10T00:00:00"})
    return load_study_set(set_files(d), "cubesat 0", truth_dir=d / "truth")


def _sampled(ss):
    t = ss.t_s
    return np.flatnonzero(np.diff(np.floor((t - t[0]) / STEP_S), prepend=-1) > 0)


def test_usability_is_per_method():
    opts = SingleEpochOptions()
    assert opts.usability("lambda") == (4, 6)
    assert opts.usability("constrained") == (4, 3)
    with pytest.raises(ValueError):
        opts.usability("rounding")


def test_constrained_attempts_what_the_lambda_rule_leaves_out_and_fixes_right(cubesat_set):
    ss = cubesat_set
    opts = SingleEpochOptions()
    body = ss.body_baselines_m
    n = right = wrong = only_constrained = 0
    for k in _sampled(ss):
        pl = epoch_problem(ss, int(k), ["L1"], opts, "lambda")
        pc = epoch_problem(ss, int(k), ["L1"], opts, "constrained")
        if pc is None:
            continue
        assert pc.method == "constrained"
        n_dd = np.zeros(len(ss.bl_idx), int)
        for blk in pc.sol.blocks:
            n_dd[blk.baseline] += blk.n_dd
        assert np.array_equal(pc.usable, n_dd >= 3)
        lam_usable = pl.usable if pl is not None else np.zeros(len(ss.bl_idx), bool)
        assert np.all(lam_usable <= pc.usable)          # whatever MLAMBDA may attempt, the constrained may too
        # the paper's method on the constrained problem still attempts only baselines with >= 6 DDs
        rl = solve_lambda(pc, body, opts)
        assert not np.any(np.isfinite(rl.ratio) & (n_dd < 6))
        res = solve_constrained(pc, body, opts)
        for j in range(len(ss.bl_idx)):
            wrong += res.correct[j] is False
            if pc.usable.all():
                n += 1
                right += res.correct[j] is True
                only_constrained += bool(res.correct[j] is True and not lam_usable[j])
    assert wrong == 0
    assert n >= 40 and right == n            # every epoch with >= 4 satellites on both baselines fixed right
    assert only_constrained >= 1             # at least one fix the >= 6 DD rule could not have attempted
