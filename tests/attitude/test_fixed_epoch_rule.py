"""The attitude product's fixed-epoch rule (CONVENTIONS.md attitude.csv `fixed`: 1 where every baseline's ambiguities
are fixed; docs/attitude.md: a baseline counts as fixed at an epoch when at least `fixed_min_sats` satellites with
fixed ambiguities were used) on a simulated start where one baseline fixes before the other (issue 21 item 3: the
first fixed epoch of the slews must be one where the attitude is determined by fixed baselines on both axes)."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.attitude.process import load_inputs, process
from gnssatt.attitude.settings import AttitudeSettings
from tests.attitude.conftest import CLEAN, set_files

#: the first 60 s of seed 000 Fig. 6's pitch manoeuvre, simulator seed 4: the first phases are at t = 6 s and
#: the second baseline fixes two epochs before the first (measured: epochs 12 and 14)
START = {"start_gps": "2018-06-06T16:31:00", "duration_s": 60.0,
         "waypoints": [[0.0, 0.0, 0.0, 0.0], [60.0, 0.0, 0.0, 0.0]]}


@pytest.fixture(scope="module")
def staggered_fix(tmp_path_factory):
    from gnssatt.sim import simulate_scenario

    d = tmp_path_factory.mktemp("staggered_fix")
    simulate_scenario("slew", d, seed=4, overrides={**START, **CLEAN})
    sol = process(load_inputs(set_files(d)), AttitudeSettings.preset("all-phases", mode="dynamic"))
    return d, sol


def test_an_attitude_epoch_is_fixed_only_when_every_baseline_is(staggered_fix):
    """attitude.csv `fixed` equals "every baseline fixed" row by row, and the set exercises it: the baselines' first
    fixes differ, and the attitude rows between them (one baseline fixed, the other float) are not fixed."""
    _, sol = staggered_fix
    fr = sol.fr
    ff = fr.first_fix_epoch
    assert (ff >= 0).all() and ff.min() < ff.max(), ff
    per_baseline = fr.fixed[sol.att_epochs]
    assert np.array_equal(sol.att_fixed, per_baseline.all(axis=1))
    between = (sol.att_epochs >= ff.min()) & (sol.att_epochs < ff.max())
    assert between.any() and not sol.att_fixed[between].any()
    assert per_baseline[between].any(axis=1).all()          # one baseline fixed there, yet the attitude is float
    assert sol.att_epochs[np.argmax(sol.att_fixed)] == ff.max()


def test_the_first_fixed_epoch_has_every_baseline_on_fixed_satellites(staggered_fix):
    """At the first fixed attitude epoch every baseline holds integer constraints (fix_log, alive at that epoch) on at
    least fixed_min_sats satellites of one signal, and those integers are the truth's (truth/arcs.csv)."""
    from gnssatt.attitude.truth import score_fixes

    d, sol = staggered_fix
    fr, log = sol.fr, sol.fr.fix_log
    k0 = int(sol.att_epochs[np.argmax(sol.att_fixed)])
    need = sol.settings.ambiguity.fixed_min_sats
    for j in range(fr.fixed.shape[1]):
        alive = (log["bl"] == j) & (log["epoch"] <= k0) & (log["last_epoch"] >= k0)
        n_sats = max(len(set(log["sat"][alive & (log["sig"] == f)]) | set(log["ref_sat"][alive & (log["sig"] == f)]))
                     for f in range(len(sol.pobs.signals)))
        assert n_sats >= need, (j, n_sats)
    assert score_fixes(sol, d / "truth")["wrong_constraints"] == 0
