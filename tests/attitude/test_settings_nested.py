"""Nested attitude settings (seed 000 Tables 1-2 and our groups): defaults unchanged from the flat settings they
replace, metadata on every field, legacy flat job configs equal to their nested form, presets valid."""
from __future__ import annotations

import dataclasses

import pytest
from pydantic import ValidationError

from gnssatt.attitude.settings import FLAT_TO_NESTED, GROUPS, PRESETS, AttitudeSettings
from worker.jobs.attitude import AttitudeConfig

#: the flat AttitudeSettings defaults before the nesting (frozen copy; seed 000 Tables 1-2 and our choices)
OLD_FLAT_DEFAULTS = {
    "sigma_code_m": 0.30, "sigma_phase_m": 0.003, "weighting": "none", "separate_phase_clock": True,
    "noise_estimation": True, "noise_cn0_growth": True, "sigma_multipath_phase_m": (0.0015, 0.006),
    "sigma_multipath_code_m": (0.15, 0.9), "multipath_correlation_factor": 3.0, "multipath_adaptive": True,
    "sigma0_baseline_m": 2.0, "sigma_clock_s": 1.0e-6, "sigma0_omega_deg_s": 1.0, "sigma_omega_deg_s": 0.03,
    "adaptive_omega_noise": False, "adaptive_omega_threshold": 5.0, "adaptive_omega_mix_at": 0.0,
    "adaptive_omega_sigma_acc_deg_s2": 0.05, "adaptive_omega_sigma_deg_s": 0.3, "adaptive_omega_hold_epochs": 30,
    "tau_omega_s": 1.0, "smoother": False, "smoother_adaptive_noise": False, "smoother_noise_floor": 0.03,
    "smoother_noise_gain": 0.5, "smoother_noise_window_s": 20.0, "smoother_accel_window_s": 5.0,
    "smoother_accel_noise_k": 3.0, "sigma0_ambiguity_cyc": 500.0, "sigma_baseline_kinematic_m": 1.0,
    "tau_baseline_s": 1.0, "sigma0_code_bias_m": 10.0, "elevation_mask_local_deg": -90.0,
    "elevation_mask_antenna_deg": 0.0, "cn0_mask_dbhz": {}, "cn0_mask_default_dbhz": None, "td_code_m": 0.50,
    "td_phase_cyc": 0.25, "max_length_error_m": 0.03, "min_ratio": 0.0, "ambiguity_search": "lambda",
    "min_ratio_constrained": 3.0, "min_ratio_constrained_joint": 1.5, "ar_min_ratio_first_fix": 0.0,
    "max_angle_error_m": 0.03, "ar_min_dd": 6, "ar_min_sats": 4, "fixed_min_sats": 4,
    "new_amb_round_sigma_cyc": 0.08, "new_amb_round_frac_cyc": 0.2, "max_gap_s": 10.0,
    "innovation_gate_sigma": 8.0, "pcv_maps": {}, "pcv_empty_bins": "exclude", "calibrated_baselines": {},
}
#: group fields added after the restructuring (issue 21), with their defaults (length_validation: "both" since
#: bench/bench_fix_validation.py showed "filter" alone letting wrong integers through)
NEW_GROUP_DEFAULTS = {"length_validation": "both", "smoother_quiet_jerk_share": 1.0,
                      "smoother_noise_em_iterations": 0, "smoother_noise_em_bound": 10.0,
                      "multipath_adaptive_method": "leverage"}
OLD_TOP_DEFAULTS = {"mode": "dynamic", "signals": ["L1", "L2"], "systems": None, "rk4_step_s": 1.0,
                    "initial_attitude": "earth-pointing", "initial_q_body_from_ecef": None, "attitude_method": "quest"}


def _get(s, path):
    g, f = path.split(".")
    return getattr(getattr(s, g), f)


def test_defaults_equal_the_old_flat_defaults_field_by_field():
    s = AttitudeSettings()
    # every moved field is mapped, none invented beside the new ones
    assert set(FLAT_TO_NESTED) == set(OLD_FLAT_DEFAULTS) | set(NEW_GROUP_DEFAULTS)
    for old, value in {**OLD_FLAT_DEFAULTS, **NEW_GROUP_DEFAULTS}.items():
        got = _get(s, FLAT_TO_NESTED[old])
        assert got == value and type(got) is type(value), old    # exact: defaults are copied, not recomputed
    for name, value in OLD_TOP_DEFAULTS.items():
        assert getattr(s, name) == value, name
    assert AttitudeSettings.preset("seed000") == s


def test_every_field_has_metadata_and_names_are_unique():
    records = [AttitudeSettings, *GROUPS.values()]
    for rec in records:
        for f in dataclasses.fields(rec):
            assert f.metadata.get("description"), f"{rec.__name__}.{f.name}"
            for k in ("gt", "ge", "le", "lt"):
                if k in f.metadata and isinstance(f.default, (int, float)) and not isinstance(f.default, bool):
                    b = f.metadata[k]
                    ok = {"gt": f.default > b, "ge": f.default >= b, "le": f.default <= b, "lt": f.default < b}[k]
                    assert ok, f"{rec.__name__}.{f.name} default outside its bound {k} {b}"
    assert len(set(FLAT_TO_NESTED.values())) == len(FLAT_TO_NESTED)


def test_flat_legacy_config_equals_its_nested_form():
    flat = {"mode": "kinematic", "sigma_code_m": 0.5, "weighting": "cn0", "smoother": True,
            "adaptive_omega_threshold": 6.0, "ambiguity_search": "constrained", "cn0_mask_l1_dbhz": 0.0,
            "cn0_mask_default_dbhz": 0.0, "elevation_mask_antenna_deg": -90.0}
    nested = {"mode": "kinematic", "table1": {"sigma_code_m": 0.5}, "noise": {"weighting": "cn0"},
              "smoothing": {"enabled": True}, "adaptive": {"threshold": 6.0},
              "ambiguity": {"ambiguity_search": "constrained"},
              "table2": {"cn0_mask_l1_dbhz": 0.0, "cn0_mask_default_dbhz": 0.0, "elevation_mask_antenna_deg": -90.0}}
    a = AttitudeConfig.model_validate(flat).to_settings()
    assert a == AttitudeConfig.model_validate(nested).to_settings()
    assert a.table1.sigma_code_m == 0.5 and a.smoothing.enabled and a.table2.cn0_mask_dbhz == {"L1": 0.0, "L2": 30.0}
    # the old job's behaviour: the L1/L2 masks stay pinned at Table 2's when only the default mask is lowered
    assert AttitudeConfig(cn0_mask_default_dbhz=0.0).to_settings().table2.cn0_mask_dbhz == {"L1": 35.0, "L2": 30.0}


@pytest.mark.parametrize("cfg, name", [({"sigma_code_mm": 1}, "sigma_code_mm"),
                                       ({"table1": {"sigma_code_mm": 1}}, "sigma_code_mm"),
                                       ({"table1": {"sigma_code_m": -1}}, "sigma_code_m"),
                                       ({"sigma_code_m": 1, "table1": {"sigma_code_m": 2}}, "sigma_code_m")])
def test_unknown_or_bad_key_is_refused_naming_it(cfg, name):
    with pytest.raises(ValidationError) as exc:
        AttitudeConfig.model_validate(cfg)
    assert name in str(exc.value)
    with pytest.raises(ValueError, match="sigma_code_mm"):
        AttitudeSettings.preset("seed000", sigma_code_mm=1)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_each_preset_validates(name):
    s = AttitudeConfig.model_validate({"preset": name}).to_settings()
    assert s == AttitudeSettings.preset(name).override(cn0_mask_dbhz=s.table2.cn0_mask_dbhz)
    if name.startswith("all-phases"):
        assert s.table2.elevation_mask_antenna_deg == -90.0 and s.table2.cn0_mask_dbhz == {"L1": 0.0, "L2": 0.0}
    with pytest.raises(ValueError, match="nope"):
        AttitudeSettings.preset("nope")


def test_held_out_default_preset_equals_the_former_flat_default():
    from worker.jobs.calibration import HELD_OUT_ATTITUDE_DEFAULT

    former = {"smoother": True, "elevation_mask_antenna_deg": -90.0, "cn0_mask_l1_dbhz": 0.0,
              "cn0_mask_l2_dbhz": 0.0, "cn0_mask_default_dbhz": 0.0}
    assert (AttitudeConfig.model_validate(HELD_OUT_ATTITUDE_DEFAULT).to_settings()
            == AttitudeConfig.model_validate(former).to_settings())


def test_flat_names_are_not_attributes():
    """Code reads the nested path only: an old flat name is no attribute (it is accepted on input, where
    `override` and the job config route it through FLAT_TO_NESTED)."""
    s = AttitudeSettings.preset("seed000", table1={"sigma_code_m": 0.4})
    assert s.table1.sigma_code_m == 0.4
    with pytest.raises(AttributeError):
        s.sigma_code_m
    assert s.override(sigma_code_m=0.5).table1.sigma_code_m == 0.5
