"""Defaults by platform kind (gnssatt.attitude.platform_defaults, issue 21 item 4): applied to what the user left
as it is, listed with their reasons in the job type's schema, and on the real Nagoya baseline the defaults alone
meet the known geometry."""
from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from gnssatt.attitude.platform_defaults import PLATFORM_DEFAULTS, apply_platform_defaults
from gnssatt.attitude.settings import AttitudeSettings


def _obs(*systems_per_antenna):
    return {f"A{i}": SimpleNamespace(sats=[f"{x}{n:02d}" for x in sy for n in (1, 2)])
            for i, sy in enumerate(systems_per_antenna)}


def test_terrestrial_gets_the_systems_in_every_file_and_elevation_weights():
    s, applied = apply_platform_defaults(AttitudeSettings.preset("seed000"), "terrestrial",
                                         _obs("GECJR", "GEC"))          # J and R on one antenna only
    assert s.systems == ["G", "E", "C"] and s.noise.weighting == "elevation"
    assert [a["setting"] for a in applied] == ["systems", "noise.weighting"]
    assert all(a["reason"] for a in applied)


def test_what_the_user_set_is_kept():
    s, applied = apply_platform_defaults(AttitudeSettings.preset("seed000", noise={"weighting": "cn0"},
                                                                 signals=["L1"]), "terrestrial", _obs("GE", "GE"))
    assert s.signals == ["L1"] and s.systems is None and s.noise.weighting == "cn0" and applied == []
    s, _ = apply_platform_defaults(AttitudeSettings.preset("seed000", systems=["G"]), "terrestrial", _obs("GE", "GE"))
    assert s.systems == ["G"] and s.noise.weighting == "elevation"
    s, applied = apply_platform_defaults(AttitudeSettings.preset("seed000", platform_defaults=False), "terrestrial",
                                         _obs("GE", "GE"))
    assert s.systems is None and s.noise.weighting == "none" and applied == []


def test_spacecraft_keep_seed000_tables_1_2():
    base = AttitudeSettings.preset("seed000")
    s, applied = apply_platform_defaults(base, "spacecraft", _obs("GE", "GE"))
    assert s is base and applied == []
    s, applied = apply_platform_defaults(base, "terrestrial", _obs("G", "G"))      # GPS-only files: only weights
    assert s.systems is None and s.signals == ["L1", "L2"] and [a["setting"] for a in applied] == ["noise.weighting"]


def test_the_job_schema_lists_each_default_with_its_reason():
    from worker.jobs.attitude import AttitudeConfig

    schema = AttitudeConfig.model_json_schema()
    got = schema["x-platform-defaults"]
    assert got == json.loads(json.dumps(PLATFORM_DEFAULTS))
    for kind in ("spacecraft", "terrestrial"):
        assert got[kind] and all(v["value"] and v["reason"] for v in got[kind].values())
    assert "platform_defaults" in schema["properties"]
    assert AttitudeConfig.model_validate({}).to_settings().platform_defaults is True


def test_nagoya_with_the_defaults_and_no_options(tmp_path):
    """Real data (the set's README: 0.9902 m, azimuth 193.03 deg, elevation 0.56 deg), the job's defaults (dynamic
    mode, seed000 preset) and nothing else: within 3 mm, 0.05 deg azimuth, 0.1 deg elevation (issue 21); the
    summary names the defaults the platform kind set."""
    from bench.real_sets import NAGOYA, NAGOYA_PLATFORM, nagoya_files
    from gnssatt.attitude.process import load_inputs, process
    from tests.conftest import real_set

    d = real_set(NAGOYA)
    plat = tmp_path / "platform.json"
    plat.write_text(json.dumps(NAGOYA_PLATFORM))
    from worker.jobs.attitude import AttitudeConfig

    sol = process(load_inputs(nagoya_files(d, plat)), AttitudeConfig.model_validate({}).to_settings())
    b = sol.summary["baselines"][0]
    assert sol.pobs.signals == ["G:L1", "G:L2", "E:E1", "E:E5b", "C:B1I", "C:B2I", "J:L1", "J:L2", "R:G1", "R:G2"]
    assert [a["setting"] for a in sol.summary["platform_defaults"]] == ["systems", "noise.weighting"]
    assert abs(b["median_length_m"] - 0.9902) < 0.003
    assert abs(b["median_azimuth_deg"] - 193.03) < 0.05
    assert abs(b["median_elevation_deg"] - 0.56) < 0.1
    assert sol.baseline_table["fixed"].all()


@pytest.mark.parametrize("kind", ["spacecraft", "terrestrial"])
def test_table_kinds_are_platform_kinds(kind):
    from gnssatt.gnss.io.platform import KINDS

    assert kind in KINDS


def test_mixed_receivers_leave_glonass_out_with_a_reason():
    """Receivers of different models: GLONASS inter-channel biases do not cancel, so the default leaves R out and
    says so; same-model receivers keep it (their inter-channel biases cancel)."""
    def obs(model):
        return SimpleNamespace(sats=["G01", "G02", "R01", "R02", "E01"], header=SimpleNamespace(receiver_type=model))

    s, applied = apply_platform_defaults(AttitudeSettings.preset("seed000"), "terrestrial",
                                         {"A": obs("SEPT POLARX5"), "B": obs("TRIMBLE NETR9")})
    assert s.systems == ["G", "E"]
    assert applied[0]["value"] == "without R" and "TRIMBLE NETR9" in applied[0]["reason"]
    s, _ = apply_platform_defaults(AttitudeSettings.preset("seed000"), "terrestrial",
                                   {"A": obs("SEPT POLARX5"), "B": obs("SEPT POLARX5")})
    assert s.systems == ["G", "E", "R"]
