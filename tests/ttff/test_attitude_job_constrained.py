"""The attitude job's `ambiguity_search: "constrained"` (issue 7 item 3) on short simulated single-frequency
passes: the filter with the MC-LAMBDA first fix (gnssatt.attitude.ambiguity.resolve_joint_constrained) fixes every
baseline no later than the paper's MLAMBDA + length search, sooner on at least one, and never wrongly (truth)."""
from __future__ import annotations

from pathlib import Path

import pytest

from bench.bench_ttff import set_files, study_payloads
from worker.jobs.attitude import AttitudeConfig
from gnssatt.sim import simulate_scenario
from gnssatt.ttff.data import load_study_set
from gnssatt.ttff.study import StudyOptions, _filter_runs

DURATION_S = 20.0
#: starts 3, 4 and 13 of `bench_ttff study --seed 1` (20 s, the `ttff` preset of commit e0e0b58): on starts 4 and
#: 13 the L1 filter with MLAMBDA + length fixes one baseline late (6 s, 2 s). Over 40 starts of 120 s the
#: constrained L1 first fix is later on 2 of 80 baselines (by 1 and 4 s) and sooner on 15 (docs/ttff.md); a
#: change of the preset changes these starts.
STARTS = (3, 4, 13)


@pytest.fixture(scope="module")
def study_sets(tmp_path_factory):
    pl = study_payloads(max(STARTS) + 1, 1, DURATION_S)
    out = []
    for i in STARTS:
        d: Path = tmp_path_factory.mktemp(f"start{i}")
        simulate_scenario("ttff", d, seed=int(pl[i]["seed"]), overrides=pl[i]["overrides"])
        out.append(load_study_set(set_files(d), pl[i]["label"], truth_dir=d / "truth"))
    return out


def test_job_config_passes_the_search_to_the_filter():
    s = AttitudeConfig.model_validate({"ambiguity_search": "constrained", "min_ratio_constrained": 2.5}).to_settings()
    assert s.ambiguity.ambiguity_search == "constrained" and s.ambiguity.min_ratio_constrained == 2.5
    assert AttitudeConfig.model_validate({}).to_settings().ambiguity.ambiguity_search == "lambda"
    with pytest.raises(ValueError):
        AttitudeConfig.model_validate({"ambiguity_search": "rounding"})


def test_constrained_fixes_sooner_or_equal_and_never_wrong(study_sets):
    opts = StudyOptions()
    sooner = 0
    for ss in study_sets:
        lam = _filter_runs(ss, "L1", "filter", opts)
        con = _filter_runs(ss, "L1", "filter-constrained", opts)
        for rl, rc in zip(lam, con):
            assert rc["ttff_s"] is not None, (ss.label, rc)
            assert rc["fix_right"] is True and rc["wrong_fixed_epochs"] == 0, (ss.label, rc)
            t_lam = rl["ttff_s"] if rl["ttff_s"] is not None else float("inf")
            assert rc["ttff_s"] <= t_lam, (ss.label, rl, rc)
            sooner += rc["ttff_s"] < t_lam
    assert sooner >= 2
