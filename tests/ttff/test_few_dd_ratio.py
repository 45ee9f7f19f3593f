"""The epoch-wise constrained search's stricter ratio for baselines with few DDs (docs/ttff.md "Validation"): the
one wrong L2 fix of the 200-start benchmark (seed 1, start 050, epoch 110: 7 satellites, 6 DDs per baseline,
joint ratio 1.75, both baselines' integers wrong) is refused, and without the rule it is the wrong fix it was."""
from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import pytest

from tests.attitude.conftest import set_files
from gnssatt.sim import simulate_scenario
from gnssatt.ttff.data import load_study_set
from gnssatt.ttff.single_epoch import SingleEpochOptions, epoch_problem, solve_constrained
from worker.jobs.ttff import TtffConfig, payloads

START, EPOCH = 50, 110


@pytest.fixture(scope="module")
def start_050(tmp_path_factory):
    cfg = TtffConfig.model_validate({"simulate": {"count": START + 1, "seed": 1}, "duration_s": 120.0,
                                     "methods": ["epoch-constrained"]})
    pl = payloads(SimpleNamespace(sets=[]), cfg)[START]
    assert pl["label"] == "start 050"
    d = tmp_path_factory.mktemp("start_050")
    simulate_scenario("ttff", d, seed=int(pl["seed"]), overrides=pl["overrides"])
    return load_study_set(set_files(d), pl["label"], truth_dir=d / "truth", max_duration_s=120.0)


def test_few_dd_epoch_refused_and_wrong_without_the_rule(start_050):
    opts = SingleEpochOptions()
    prob = epoch_problem(start_050, EPOCH, ["L2"], opts, "constrained")
    assert prob is not None and prob.usable.all()
    assert max(blk.n_dd for blk in prob.sol.blocks) <= opts.few_dd_max       # the case the rule is for
    out = solve_constrained(prob, start_050.body_baselines_m, opts)
    assert not out.accepted.any(), out.detail
    assert all(c is False for c in out.best_correct)                         # the best candidate is wrong ...
    assert 1.5 <= out.ratio.min() < opts.min_ratio_few_dd                     # ... and passed the old ratio
    old = solve_constrained(prob, start_050.body_baselines_m, replace(opts, min_ratio_few_dd=1.5))
    assert old.accepted.all() and all(c is False for c in old.correct)       # the wrong fix the rule removes


def test_few_dd_rule_changes_only_epochs_with_few_dds(start_050):
    """Every epoch of the same start: where each baseline has more than few_dd_max DDs the outcome is the one of
    the ordinary ratio 1.5; no epoch gives a wrong fix."""
    opts = SingleEpochOptions()
    old_opts = replace(opts, min_ratio_few_dd=1.5)
    n_more = 0
    for k in range(0, 120, 6):
        prob = epoch_problem(start_050, k, ["L2"], opts, "constrained")
        out = solve_constrained(prob, start_050.body_baselines_m, opts)
        assert not any(c is False for c in out.correct), (k, out.detail)
        dd = [sum(b.n_dd for b in prob.sol.blocks if b.baseline == j) for j in range(len(prob.usable))]
        if min(dd) > opts.few_dd_max:
            n_more += 1
            old = solve_constrained(prob, start_050.body_baselines_m, old_opts)
            assert out.accepted.tolist() == old.accepted.tolist(), k
    assert n_more >= 5                       # the comparison was made on enough epochs to mean something
