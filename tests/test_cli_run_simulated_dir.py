"""`gnssatt run attitude DIR` on a folder exactly as `gnssatt simulate` wrote it: the answer key (truth/) is left out
with a note, so the job runs on obs/, nav/ and the platform files alone and writes its products."""
from __future__ import annotations

import csv

import pytest

from client.cli import main as cli_main, parse
from gnssatt.sim import simulate_set
from worker.local import ANSWER_KEY_FOLDER, local_set


def test_a_simulated_folder_runs_as_it_is_without_its_answer_key(tmp_path, capsys):
    sim = tmp_path / "sim"
    simulate_set("earth-pointing", sim, seed=3, duration_s=120.0)
    assert (sim / ANSWER_KEY_FOLDER / "attitude.csv").is_file()
    names = [f.name for f in local_set([sim], "set-1").files]
    assert names and not any(n.split("/")[0] == ANSWER_KEY_FOLDER for n in names), names
    cli_main(["run", "attitude", "--quiet", "--out", str(tmp_path / "out"), str(sim)])
    assert f"{sim / ANSWER_KEY_FOLDER}/ left out" in capsys.readouterr().err
    with open(tmp_path / "out" / "attitude.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) > 100 and any(r["fixed"] == "1" for r in rows)


def test_a_file_named_truth_elsewhere_is_kept(tmp_path):
    """Only the top-level folder is the answer key; the rule does not drop other paths containing the word."""
    sim = tmp_path / "sim"
    simulate_set("earth-pointing", sim, seed=3, duration_s=60.0)
    (sim / "obs").rename(sim / "obs_truthful")
    names = [f.name for f in local_set([sim], "set-1").files]
    assert any(n.startswith("obs_truthful/") for n in names)


def test_files_may_follow_the_options():
    a = parse(["run", "attitude", "--quiet", "--out", "p", "a.rnx", "b.rnx"])
    assert a.paths == ["a.rnx", "b.rnx"] and a.out == "p"
    assert parse(["run", "attitude", "a.rnx", "--out", "p", "b.rnx"]).paths == ["a.rnx", "b.rnx"]
    with pytest.raises(SystemExit):
        parse(["run", "attitude", "a.rnx", "--no-such-option"])
