"""bench.rtklib_runner: RTKLIB 2.4.3 b34 postpos through pyrtklib, on the real Nagoya set (issue 6).

Authorities:
- issue 6 quotes RTKLIB 2.4.3 b34 kinematic through pyrtklib on static_1m_mosaicx5_nagoya_2024:
  azimuth 193.047 +- 0.037 deg, elevation 0.554 +- 0.086 deg, 301/301 fixed. Those figures are reproduced by
  GPS + Galileo + QZSS + BeiDou (navsys 57), L1+L2, instantaneous AR, ratio 3, 15 deg mask, broadcast
  ionosphere, Saastamoinen, base at the README position (found by trying the RTKPOST option sets; GLONASS in or
  GLONASS AR off both move the elevation by 0.02-0.05 deg).
- the set's own rover_rtk.pos (the author's RTKPOST 2.4.3 b34 run, LLH, hms time) for the reader.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import real_set, require_module

from bench.rtklib_runner import options_for, options_text, read_pos, run_postpos

NAGOYA = "static_1m_mosaicx5_nagoya_2024"
BASE_LLH = ("35.134707705", "136.977577939", "104.853")      # base_position.txt


def _base_opts(**extra) -> dict:
    return options_for("kinematic", **{"ant2-postype": "llh", "ant2-pos1": BASE_LLH[0], "ant2-pos2": BASE_LLH[1],
                                       "ant2-pos3": BASE_LLH[2], **extra})


def _needs_rtklib() -> None:
    """Only the tests that run postpos need the bindings (the .pos reader and the option helpers do not)."""
    require_module("pyrtklib", "RTKLIB 2.4.3 b34 bindings")


def _run(tmp_path, **extra):
    _needs_rtklib()
    d = real_set(NAGOYA)
    return run_postpos(d / "rover.obs", d / "base.obs", d / "base.nav", _base_opts(**extra), tmp_path / "r.pos")


def test_reproduces_issue_6_rtklib_figures(tmp_path):
    sol = _run(tmp_path, **{"pos1-navsys": "57", "pos2-armode": "instantaneous"})
    assert sol.frame == "enu" and sol.q.size == 301
    assert sol.fixed.all(), "301/301 fixed"
    az, el = sol.azimuth_deg(), sol.elevation_deg()
    # issue 6: 193.047 +- 0.037 deg and 0.554 +- 0.086 deg ("within a few hundredths of a degree")
    assert abs(az.mean() - 193.047) < 0.01 and abs(az.std() - 0.037) < 0.01
    assert abs(el.mean() - 0.554) < 0.02 and abs(el.std() - 0.086) < 0.01
    # and the README's geometry (0.9902 m)
    assert abs(np.median(sol.length_m()) - 0.9902) < 0.002
    # solution times: the 301 whole GPS seconds of 2024-06-24 08:20:00-08:25:00 (week 2320, sow 116400-116700)
    assert (sol.gps_week == 2320).all()
    np.testing.assert_allclose(sol.gps_sow, 116400.0 + np.arange(301), atol=1e-3)
    assert sol.elapsed_s > 0 and "pos1-navsys        =57" in sol.effective_options
    assert sol.header["pos mode"] == ["Kinematic"]


def test_gps_only_rtklib_agrees_with_gnssatt_not_with_the_multi_gnss_readme(tmp_path):
    """On GPS L1 C/A + L2 alone, RTKLIB's baseline is 3 mm shorter and 0.4 deg flatter than the README's (multi-GNSS)
    one, and gnssatt, GPS-only too, agrees with RTKLIB on the same signals: that is why
    test_real_nagoya.py::test_nagoya_matches_rtklib_level runs gnssatt with Galileo, BeiDou and QZSS."""
    import json

    from bench.real_sets import NAGOYA_PLATFORM as PLATFORM
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import AttitudeSettings

    sol = _run(tmp_path, **{"pos1-navsys": "1", "pos1-elmask": "10"})
    assert sol.fixed.all()
    r_az, r_el, r_len = (float(np.median(x)) for x in (sol.azimuth_deg(), sol.elevation_deg(), sol.length_m()))
    assert abs(r_len - 0.9902) > 0.002, "GPS-only RTKLIB is not at the README's length (measured 0.9870 m)"
    d = real_set(NAGOYA)
    plat = tmp_path / "platform.json"
    plat.write_text(json.dumps(PLATFORM))
    files = [("base.obs", "rinex_obs", d / "base.obs"), ("rover.obs", "rinex_obs", d / "rover.obs"),
             ("base.nav", "rinex_nav", d / "base.nav"), ("platform.json", "platform", plat)]
    # GPS L1/L2 without weights as given: the terrestrial platform defaults (G/E/C/J, elevation weights) are off
    g = process(load_inputs(files), AttitudeSettings.preset("seed000", mode="kinematic", platform_defaults=False,
                                                            table2={"elevation_mask_local_deg": 10.0}))
    b = g.summary["baselines"][0]
    # measured: azimuth 193.118 vs 193.100 deg, length 0.9868 vs 0.9870 m, elevation 0.30 vs 0.18 deg
    assert abs(b["median_azimuth_deg"] - r_az) < 0.05
    assert abs(b["median_length_m"] - r_len) < 0.002
    assert abs(b["median_elevation_deg"] - r_el) < 0.2


def test_multi_gnss_gnssatt_agrees_with_rtklib_epoch_by_epoch(tmp_path):
    """G+E+C+J L1+L2 on both sides (RTKLIB navsys 57, instantaneous AR, 15 deg mask; gnssatt `systems` G/E/C/J,
    kinematic, elevation weights): the same baseline epoch by epoch. Measured: median differences 0.002 deg azimuth,
    -0.016 deg elevation, -0.1 mm length; epoch-wise correlation 0.7-0.8 (both see the same multipath); gnssatt's
    scatter 0.031 / 0.065 deg against RTKLIB's 0.037 / 0.086 deg."""
    import json

    from bench.real_sets import NAGOYA_PLATFORM as PLATFORM
    from gnssatt.attitude.process import load_inputs, process
    from gnssatt.attitude.settings import TABLE2_MASKS, AttitudeSettings

    r = _run(tmp_path, **{"pos1-navsys": "57", "pos2-armode": "instantaneous"})
    assert r.fixed.all()
    d = real_set(NAGOYA)
    plat = tmp_path / "platform.json"
    plat.write_text(json.dumps(PLATFORM))
    files = [("base.obs", "rinex_obs", d / "base.obs"), ("rover.obs", "rinex_obs", d / "rover.obs"),
             ("base.nav", "rinex_nav", d / "base.nav"), ("platform.json", "platform", plat)]
    # seed 000 Table 2's C/N0 masks: close to the data RTKLIB's 15 deg mask leaves (with gnssatt's default of no
    # masks the elevation differs by -0.056 deg: 0.508 instead of 0.537 deg, the README says 0.56)
    g = process(load_inputs(files), AttitudeSettings.preset("seed000", mode="kinematic", systems=["G", "E", "C", "J"], **TABLE2_MASKS, noise={"weighting": "elevation"}))
    bt = g.baseline_table
    assert bt["fixed"].all()
    _, sow = g.pobs.time.week_sow()
    common, ig, ir = np.intersect1d(np.round(sow[bt["epoch"]]), np.round(r.gps_sow), return_indices=True)
    assert common.size == 301
    for a, b, med, corr in ((bt["azimuth_deg"][ig], r.azimuth_deg()[ir], 0.01, 0.5),
                            (bt["elevation_deg"][ig], r.elevation_deg()[ir], 0.05, 0.4),
                            (bt["length_m"][ig], r.length_m()[ir], 0.0005, 0.4)):
        assert abs(np.median(a - b)) < med
        assert np.corrcoef(a, b)[0, 1] > corr
        assert a.std() <= 1.1 * b.std()


def test_read_pos_of_the_authors_rtkpost_file():
    d = real_set(NAGOYA)
    sol = read_pos(d / "rover_rtk.pos")
    assert sol.frame == "llh" and sol.q.size == 301 and sol.fixed.all()
    assert sol.header["program"] == ["RTKPOST ver.2.4.3 b34"]
    # first row: 2024/06/24 08:20:00.000 35.134699011 136.977575483 104.8619 1 42 ... ratio 12.0
    assert sol.gps_week[0] == 2320 and sol.gps_sow[0] == pytest.approx(116400.0)
    np.testing.assert_allclose(sol.vector_m[0], [35.134699011, 136.977575483, 104.8619])
    assert sol.ns[0] == 42 and sol.ratio[0] == pytest.approx(12.0)
    assert sol.gps_sow[-1] == pytest.approx(116700.0)
    with pytest.raises(ValueError, match="ENU"):
        sol.azimuth_deg()


@pytest.mark.parametrize("bad, exc", [({"pos1-bogus": "1"}, KeyError), ({"pos1-posmode": "flying"}, ValueError),
                                      ({"pos1-elmask": "abc"}, ValueError)], ids=["unknown", "enum", "number"])
def test_bad_options_raise_instead_of_silent_defaults(tmp_path, bad, exc):
    _needs_rtklib()
    d = real_set(NAGOYA)
    with pytest.raises(exc):
        run_postpos(d / "rover.obs", d / "base.obs", d / "base.nav", {**_base_opts(), **bad}, tmp_path / "r.pos")


def test_options_for_modes():
    mb = options_for("movingbase", pos2_baselen="1.05")
    assert mb["pos1-posmode"] == "movingbase" and mb["pos2-baselen"] == "1.05"
    assert "pos1-posmode       =movingbase\n" in options_text(mb)
    with pytest.raises(ValueError):
        options_for("ppp-kine")
