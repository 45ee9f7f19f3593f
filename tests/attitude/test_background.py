"""The attitude job's serial start on two cores (issue 24): load_inputs and process with a `background` runner (the
worker passes worker.forked.Forked) give the same inputs and the same solution as without one; the geometry's
background part is collected when the filter reaches it, and a failing background falls back to the job."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

import gnssatt.attitude.geometry as G
from gnssatt.attitude.process import load_inputs, process
from gnssatt.gnss.io.errors import ParseError
from tests.attitude.conftest import set_files
from worker.forked import Forked
from worker.jobs.attitude import AttitudeConfig


class Recorder:
    """A Forked that records when its result is asked for (the filter's epoch at that moment)."""

    made: list["Recorder"] = []

    def __init__(self, fn):
        self.forked, self.asked = Forked(fn), 0
        Recorder.made.append(self)

    def result(self):
        self.asked += 1
        return self.forked.result()

    def cancel(self):
        self.forked.cancel()


class Broken:
    """A background runner whose child never delivers."""

    def __init__(self, fn):
        pass

    def result(self):
        raise RuntimeError("child died")

    def cancel(self):
        pass


def _same_obs(a, b):
    assert list(a.obs) == list(b.obs) and a.obs_names == b.obs_names
    for ant in a.obs:
        x, y = a.obs[ant], b.obs[ant]
        assert x.sats == y.sats and x.codes == y.codes and np.array_equal(x.time.s, y.time.s)
        assert np.array_equal(x.values, y.values, equal_nan=True) and np.array_equal(x.lli, y.lli)


def test_inputs_parsed_in_the_background_are_the_same(realistic_pass):
    files = set_files(realistic_pass)
    here = load_inputs(files)
    _same_obs(load_inputs(files, background=Forked), here)
    _same_obs(load_inputs(files, background=Broken), here)          # parsed in the job instead


def test_a_bad_observation_file_parsed_in_the_background_is_the_same_error(realistic_pass, tmp_path):
    files = set_files(realistic_pass)
    name, kind, path = files[2]                       # one the background parses (all but the first)
    bad = tmp_path / "bad.rnx"
    shutil.copy(path, bad)
    lines = bad.read_bytes().split(b"\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith(b">")) + 1      # the first epoch's first record
    lines[k] = b"X" + lines[k][1:]                                            # no such system
    bad.write_bytes(b"\n".join(lines))
    files[2] = (name, kind, bad)
    with pytest.raises(ParseError) as here:
        load_inputs(files)
    with pytest.raises(ParseError) as there:
        load_inputs(files, background=Forked)
    assert str(there.value) == str(here.value)


def test_geometry_in_the_background_gives_the_same_solution(realistic_pass, monkeypatch):
    inputs = load_inputs(set_files(realistic_pass))
    settings = AttitudeConfig(mode="kinematic").to_settings()
    ref = process(inputs, settings)
    monkeypatch.setattr(G, "BACKGROUND_MIN_EPOCHS", 0)      # a 600-epoch pass: epochs 256- in the background
    Recorder.made.clear()
    sol = process(inputs, settings, background=Recorder)
    assert len(Recorder.made) == 1 and Recorder.made[0].asked == 1 and sol.geom.pending is None
    for f in ("los_ecef", "range_rate_m_s", "elevation_local_rad", "valid"):
        assert np.array_equal(getattr(sol.geom, f), getattr(ref.geom, f), equal_nan=True), f
    assert np.array_equal(sol.fr.b_ecef_m, ref.fr.b_ecef_m, equal_nan=True)
    assert np.array_equal(sol.q_body_from_ecef, ref.q_body_from_ecef)


def test_geometry_waits_only_when_the_filter_reaches_the_background_part(realistic_pass, monkeypatch):
    inputs = load_inputs(set_files(realistic_pass))
    monkeypatch.setattr(G, "BACKGROUND_MIN_EPOCHS", 0)
    pobs_time = inputs.obs[next(iter(inputs.obs))].time
    n = len(pobs_time)
    geom = G.compute_geometry(pobs_time, ["G01"], np.zeros((n, 1), bool), None, np.full((n, 3), np.nan),
                              np.zeros((n, 3)), "test", background=Recorder)
    k1, handle = geom.pending
    assert k1 == 256 and handle.asked == 0
    geom.ready(k1)                     # epochs < 256: here already
    assert handle.asked == 0 and geom.pending is not None
    geom.ready(k1 + 1)
    assert handle.asked == 1 and geom.pending is None and not geom.valid.any()


def test_the_plot_children_draw_every_plot_once_and_the_same_pngs_as_one_process(realistic_pass, tmp_path):
    """The job's two plot children (worker.jobs.attitude.PLOT_GROUPS) give every PNG of PLOT_NAMES once, the bytes
    that attitude_plots draws in one process from the same tables, events.csv text and reference."""
    from gnssatt.attitude.products import events_csv, product_tables
    from gnssatt.plots.attitude import PLOT_NAMES, attitude_plots
    from gnssatt.plots import PlotContext
    from bench.local_jobs import files_set, job_context
    from worker.jobs.attitude import PLOT_GROUPS, _PlotJob

    groups = [n for g in PLOT_GROUPS for n in g]
    assert sorted(groups) == sorted(PLOT_NAMES)
    config = AttitudeConfig(mode="kinematic")
    sol = process(load_inputs(set_files(realistic_pass)), config.to_settings())
    tables = product_tables(sol)
    obs_set = files_set(set_files(realistic_pass), name="pass")
    ctx = job_context(tmp_path, [obs_set], job_id="plots")
    job = _PlotJob(ctx, config, obs_set, sol, tables)
    pngs = job.draw()
    job.cancel()
    assert list(pngs) == list(PLOT_NAMES)
    here = attitude_plots({**tables, "events.csv": events_csv(sol)}, (realistic_pass / "reference_attitude.csv")
                          .read_text(), PlotContext(set_name="pass", job_id="plots",
                                                    config={"preset": config.preset, "mode": config.mode}))
    assert pngs == here
