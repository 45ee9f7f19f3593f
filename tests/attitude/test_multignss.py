"""Multi-GNSS signals of the attitude job (issue 6): signal names, observation extraction per system, the
multi-system orbit source (BeiDou GEO included), the inter-signal code biases of the filter state, the job config.

The extraction tests read a small mixed RINEX 3.04 file written here, whose every value encodes its satellite and
band, so each number can be traced to the array cell it must land in (or must not).
"""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.attitude.observations import build_platform_obs
from gnssatt.attitude.settings import (SIGNALS, SYSTEM_SIGNALS, AttitudeSettings, cn0_mask_of, effective_signals,
                                      signal_system)
from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.io.rinex_obs import read_rinex_obs

# G: L1 + L2 (W); E: E1 + E5b + E5a; C: B1I + B2I; J: L1 only (a system with one frequency); R: must be left out
OBS_TYPES = {
    "G": ["C1C", "L1C", "S1C", "C2W", "L2W", "S2W"],
    "E": ["C1C", "L1C", "S1C", "C7Q", "L7Q", "S7Q", "C5Q", "L5Q", "S5Q"],
    "C": ["C2I", "L2I", "S2I", "C7I", "L7I", "S7I"],
    "J": ["C1C", "L1C", "S1C"],
    "R": ["C1C", "L1C", "S1C"],
}
SATS = ["G05", "G13", "E11", "E33", "C01", "C23", "C59", "J03", "R08"]


def _value(sat: str, code: str, k: int) -> float:
    """A value that names its satellite, band and observable: code ~2.2e7 m, phase ~1.1e8 cycles, C/N0 40-49."""
    prn, band = int(sat[1:]), int(code[1])
    if code[0] == "S":
        return 40.0 + prn % 10
    base = 2.0e7 + prn * 1.0e5 + band * 1.0e3 + k
    return base if code[0] == "C" else base * 5.0 + 0.25


def _mixed_obs_text(marker: str, n_epochs: int = 3, skip=()) -> str:
    head = [
        f"{'3.04':>9}{'':11}{'OBSERVATION DATA':<20}{'M (MIXED)':<20}RINEX VERSION / TYPE",
        f"{'gnssatt-tests':<20}{'gnssatt':<20}{'20260101 000000 UTC':<20}PGM / RUN BY / DATE",
        f"{marker:<60}MARKER NAME",
        f"{-3817681.1213:14.4f}{3562839.4311:14.4f}{3650159.1593:14.4f}{'':18}APPROX POSITION XYZ",
    ]
    for sysl, codes in OBS_TYPES.items():
        head.append((f"{sysl}{len(codes):5d} " + " ".join(codes)).ljust(60) + "SYS / # / OBS TYPES")
    head += [f"{1.0:10.3f}{'':50}INTERVAL",
             f"{2024:6d}{6:6d}{24:6d}{8:6d}{20:6d}{0.0:13.7f}{'':5}{'GPS':<3}{'':9}TIME OF FIRST OBS",
             f"{'':60}END OF HEADER"]
    lines = list(head)
    for k in range(n_epochs):
        sats = [s for s in SATS if (s, k) not in skip]
        lines.append(f"> 2024 06 24 08 20{float(k):11.7f}  0{len(sats):3d}")
        for sat in sats:
            lines.append(sat + "".join(f"{_value(sat, c, k):14.3f}  " for c in OBS_TYPES[sat[0]]).rstrip())
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    d = tmp_path_factory.mktemp("mixed")
    (d / "a.obs").write_text(_mixed_obs_text("A"))
    (d / "b.obs").write_text(_mixed_obs_text("B", skip={("C01", 1)}))
    return {"a": read_rinex_obs(d / "a.obs", name="a.obs"), "b": read_rinex_obs(d / "b.obs", name="b.obs")}


SIGS = ["G:L1", "G:L2", "E:E1", "E:E5b", "C:B1I", "C:B2I", "J:L1", "J:L2"]


def test_every_value_lands_in_its_system_and_signal(mixed):
    p = build_platform_obs(mixed, SIGS)
    assert p.sats == ["C01", "C23", "C59", "E11", "E33", "G05", "G13", "J03"]       # RINEX names, no GLONASS
    assert p.signals == SIGS
    np.testing.assert_allclose(p.wavelength_m, [C_M_S / SIGNALS[s]["freq_hz"] for s in SIGS])
    assert p.wavelength_m[4] == pytest.approx(0.192039, abs=1e-6)                  # B1I 1561.098 MHz
    band = {"G:L1": 1, "G:L2": 2, "E:E1": 1, "E:E5b": 7, "C:B1I": 2, "C:B2I": 7, "J:L1": 1, "J:L2": 2}
    for i, sat in enumerate(p.sats):
        for f, sig in enumerate(SIGS):
            code, phase = p.code_m[0, :, i, f], p.phase_m[0, :, i, f]
            if signal_system(sig) != sat[0] or (sat[0] == "J" and sig == "J:L2"):
                assert np.isnan(code).all() and np.isnan(phase).all(), (sat, sig)
                assert (p.lli[0, :, i, f] == -1).all()
                continue
            want = np.array([_value(sat, f"C{band[sig]}", k) for k in range(3)])
            np.testing.assert_allclose(code, want, rtol=0, atol=1e-3)
            np.testing.assert_allclose(phase, (want * 5.0 + 0.25) * p.wavelength_m[f], rtol=1e-15)
            assert (p.cn0_dbhz[0, :, i, f] == 40.0 + int(sat[1:]) % 10).all()
    # the codes read per antenna and signal
    assert p.codes_used["a"]["C:B1I"] == ("C2I", "L2I", "S2I")
    assert p.codes_used["a"]["E:E5b"] == ("C7Q", "L7Q", "S7Q")
    # QZSS has one frequency in these files: J:L2 is absent, with a warning, and J:L1 is all there
    assert "J:L2" not in p.codes_used["a"]
    assert any("J:L2" in w and "a.obs" in w for w in p.warnings)
    # the BeiDou GEO C01 missing on antenna b at epoch 1 stays missing there only
    c01 = p.sats.index("C01")
    assert np.isnan(p.code_m[1, 1, c01, 4]) and np.isfinite(p.code_m[1, [0, 2], c01, 4]).all()
    assert np.isfinite(p.code_m[0, :, c01, 4]).all()


def test_gps_names_are_the_historical_ones(mixed):
    old = build_platform_obs(mixed, ["L1", "L2"])
    new = build_platform_obs(mixed, ["G:L1", "G:L2"])
    assert old.sats == new.sats == ["G05", "G13"]
    for a in ("code_m", "phase_m", "cn0_dbhz", "lli"):
        np.testing.assert_array_equal(getattr(old, a), getattr(new, a))
    assert old.signals == ["L1", "L2"]
    with pytest.raises(ValueError):
        build_platform_obs(mixed, ["E:E1"], system="G")


def test_single_system_single_frequency(mixed):
    p = build_platform_obs(mixed, ["E:E5a"])
    assert p.sats == ["E11", "E33"] and p.code_m.shape == (2, 3, 2, 1)
    assert np.isfinite(p.phase_m).all()
    assert p.wavelength_m[0] == pytest.approx(C_M_S / 1176.45e6)


def test_effective_signals_and_masks():
    s = AttitudeSettings()
    assert effective_signals(s) == ["L1", "L2"]
    s = AttitudeSettings.preset("seed000", systems=["G", "E", "C", "J"])
    assert effective_signals(s) == [x for sysl in "GECJ" for x in SYSTEM_SIGNALS[sysl]]
    assert effective_signals(AttitudeSettings.preset("seed000", systems=["C"])) == ["C:B1I", "C:B2I"]
    for bad in (AttitudeSettings.preset("seed000", signals=["L1", "G:L1"]),
                AttitudeSettings.preset("seed000", signals=["E:E6"])):
        with pytest.raises(ValueError):
            effective_signals(bad)
    s = AttitudeSettings.preset("seed000", table2={"cn0_mask_dbhz": {"L1": 38.0, "L2": 31.0, "C:B2I": 20.0}})
    assert cn0_mask_of(s, "L1") == 38.0 and cn0_mask_of(s, "G:L1") == 38.0      # the alias masks GPS L1 too
    assert cn0_mask_of(s, "G:L2") == 31.0 and cn0_mask_of(s, "C:B2I") == 20.0
    assert cn0_mask_of(s, "E:E1") == 35.0 and cn0_mask_of(s, "E:E5b") == 30.0  # default: Table 2 style per system
    t2 = AttitudeSettings.preset("seed000", table2={"cn0_mask_dbhz": {"L1": 38.0}, "cn0_mask_default_dbhz": 0.0})
    assert cn0_mask_of(t2, "E:E1") == 0.0 and cn0_mask_of(t2, "E:E5b") == 0.0    # 0: no mask (noise model)
    assert cn0_mask_of(AttitudeSettings.preset("seed000", table2={"cn0_mask_dbhz": {"G:L1": 40.0}}), "L1") == 40.0


def test_filter_state_has_one_code_bias_per_extra_signal():
    from gnssatt.attitude.filter import _State

    two = _State(2, 10, 2, True, True)
    # GPS L1 + L2 (the default): the layout of before multi-GNSS, one bias at b + 4, phase clocks after it
    np.testing.assert_array_equal(two.bias[:, 0], [-1, -1])
    np.testing.assert_array_equal(two.bias[:, 1], two.b_off + 4)
    np.testing.assert_array_equal(two.pclk[:, 0], two.b_off + 5)
    eight = _State(2, 60, 8, False, True)
    idx = np.concatenate([eight.b_off[:, None] + np.arange(4), eight.bias[:, 1:], eight.pclk], axis=1)
    assert (eight.bias[:, 0] == -1).all()
    # every state index of the fixed part used exactly once
    np.testing.assert_array_equal(np.sort(idx.ravel()), np.arange(eight.n_fixed_part))
    one = _State(1, 10, 1, False, True)
    assert one.bias.shape == (1, 1) and one.bias[0, 0] == -1 and one.n_fixed_part == 5


def test_job_config_systems_and_signals():
    from pydantic import ValidationError

    from worker.jobs.attitude import AttitudeConfig

    s = AttitudeConfig(systems=["G", "E", "C", "J"], cn0_mask_dbhz={"C:B1I": 33.0}).to_settings()
    assert effective_signals(s) == ["G:L1", "G:L2", "E:E1", "E:E5b", "C:B1I", "C:B2I", "J:L1", "J:L2"]
    assert cn0_mask_of(s, "C:B1I") == 33.0 and cn0_mask_of(s, "G:L1") == 35.0 and cn0_mask_of(s, "E:E1") == 35.0 \
        and cn0_mask_of(s, "E:E5b") == 30.0                                       # defaults: Table 2 style
    assert AttitudeConfig(signals=["L1", "E:E1"]).to_settings().signals == ["L1", "E:E1"]
    assert AttitudeConfig().to_settings().signals == ["L1", "L2"] and AttitudeConfig().systems is None
    for bad in ({"signals": ["L1", "G:L1"]}, {"signals": ["E6"]}, {"systems": ["X"]}, {"systems": ["G", "G"]},
                {"cn0_mask_dbhz": {"X": 30.0}}):
        with pytest.raises(ValidationError):
            AttitudeConfig(**bad)


def test_multi_system_orbits_explain_the_real_pseudoranges_beidou_geo_included():
    """Orbit source of the attitude job for G/E/C/J on the real Nagoya set: at the known base position, every
    satellite's pseudorange minus its modelled range (broadcast orbit and clock, light time, Sagnac) is the same
    receiver clock within each system to a few metres (ionosphere and troposphere left in). A GEO computed like a
    MEO (no -5 deg / Omega_e t_k rotation) or BeiDou time taken as GPS time would be kilometres off."""
    from tests.conftest import real_set
    from gnssatt.attitude.process import AttitudeInputs, _sat_state
    from gnssatt.gnss.geometry import elevation_azimuth_local, emission_time_and_position
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.orbits.broadcast import BEIDOU_GEO_PRNS

    d = real_set("static_1m_mosaicx5_nagoya_2024")
    obs = read_rinex_obs(d / "base.obs", name="base.obs")
    inputs = AttitudeInputs(platform=None, obs={"base": obs}, obs_names={"base": "base.obs"},
                            nav=read_rinex_nav(d / "base.nav", name="base.nav"))
    state, src = _sat_state(inputs, ["G", "E", "C", "J"])
    assert src == "broadcast" and not inputs.warnings
    p = build_platform_obs({"base": obs}, ["G:L1", "E:E1", "C:B1I", "J:L1"])
    r_rx = np.array([-3817681.1213, 3562839.4311, 3650159.1593])              # README base position
    k = 0
    seen = {}
    for f, sysl in enumerate("GECJ"):
        cols = [i for i, s in enumerate(p.sats) if s[0] == sysl and np.isfinite(p.code_m[0, k, i, f])]
        sats = np.array(p.sats)[cols]
        res = emission_time_and_position(state, sats, r_rx, p.time[k])
        el, _ = elevation_azimuth_local(np.broadcast_to(r_rx, (len(cols), 3)), res.r_sat_ecef_m)
        high = np.degrees(el) > 15.0
        clk = res.clock_s if res.clock_s is not None else np.zeros(len(cols))
        dtr = p.code_m[0, k, cols, f] - res.range_m + C_M_S * clk                 # c dt_rx + iono + tropo
        dtr = dtr[high] - np.median(dtr[high])
        assert high.sum() >= 2 and np.all(np.isfinite(dtr)), sysl
        assert np.all(np.abs(dtr) < 15.0), (sysl, dict(zip(sats[high], np.round(dtr, 1))))
        seen[sysl] = list(sats[high])
    geo = [s for s in seen["C"] if int(s[1:]) in BEIDOU_GEO_PRNS]
    assert len(geo) >= 3, seen["C"]                        # C01-C05, C59, C60 are up over Nagoya
    assert len(seen["J"]) >= 2                            # QZSS health word 1 (L6 only) does not exclude them
    # GEO: ~42164 km from the geocentre, nearly fixed in ECEF (inclination <= ~2 deg: |v| ~ 3.07 km/s sin i, so
    # ~100 m/s at most; an IGSO or MEO moves at 1.5-3 km/s there)
    res = emission_time_and_position(state, np.array(geo), r_rx, p.time[k])
    assert np.all(np.abs(np.linalg.norm(res.r_sat_ecef_m, axis=1) - 42164e3) < 100e3)
    assert np.all(np.linalg.norm(res.v_sat_ecef_m_s, axis=1) < 200.0)


def test_job_with_systems_preset_runs_end_to_end(tmp_path):
    """The attitude job through its plug-in with `systems: [G, E, C, J]` on the real Nagoya set: the products name
    the signals and satellites of every system, and the summary lists the signals used."""
    import hashlib
    import json

    from bench.real_sets import NAGOYA_PLATFORM as PLATFORM
    from tests.conftest import real_set
    from worker.context import InputFile, InputSet, JobContext
    from worker.jobs.attitude import AttitudeConfig
    from worker.jobs.attitude import run

    d = real_set("static_1m_mosaicx5_nagoya_2024")
    plat = tmp_path / "platform.json"
    plat.write_text(json.dumps(PLATFORM))
    files = [("base.obs", "rinex_obs", d / "base.obs"), ("rover.obs", "rinex_obs", d / "rover.obs"),
             ("base.nav", "rinex_nav", d / "base.nav"), ("platform.json", "platform", plat)]

    def store(path):
        data = path.read_bytes()
        return hashlib.sha256(data).hexdigest(), len(data)

    s = InputSet(id="set-1", name="nagoya", files=[InputFile(n, k, p, {}) for n, k, p in files], summary={})
    ctx = JobContext(job_id="job-1", attempt=1, sets=[s], workdir=tmp_path / "w", _store_blob=store)
    ctx._flush_progress = lambda f, stage: None
    run(ctx, AttitudeConfig(mode="kinematic", weighting="elevation", systems=["G", "E", "C", "J"]))
    out = tmp_path / "w" / "products"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["signals"] == ["G:L1", "G:L2", "E:E1", "E:E5b", "C:B1I", "C:B2I", "J:L1", "J:L2"]
    rows = (out / "residuals.csv").read_text().splitlines()[1:]
    pairs = {(r.split(",")[3][0], r.split(",")[4]) for r in rows}
    assert {("G", "G:L2"), ("E", "E:E5b"), ("C", "C:B1I"), ("J", "J:L1")} <= pairs
    assert all(sig.startswith(sysl + ":") for sysl, sig in pairs)
    assert len((out / "heading.nmea").read_text().splitlines()) == 301


def test_a_system_without_ephemerides_is_left_out_with_a_warning():
    import dataclasses

    from tests.conftest import real_set
    from gnssatt.attitude.process import AttitudeInputs, InputProblem, _sat_state
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.time import GpsTime

    d = real_set("static_1m_mosaicx5_nagoya_2024")
    nav = read_rinex_nav(d / "base.nav", name="base.nav")
    no_j = dataclasses.replace(nav, kepler={k: v for k, v in nav.kepler.items() if k != "J"})
    inputs = AttitudeInputs(platform=None, obs={}, obs_names={}, nav=no_j)
    state, _ = _sat_state(inputs, ["G", "J"])
    assert len(inputs.warnings) == 1 and "J" in inputs.warnings[0]
    t = GpsTime(np.array([nav.kepler["G"].toe_gpst().s[0]] * 2), np.zeros(2))
    r, _, _, _ = state(np.array(["G" + nav.kepler["G"].sat[0][1:], "J03"]), t)
    assert np.isfinite(r[0]).all() and np.isnan(r[1]).all()
    with pytest.raises(InputProblem):
        _sat_state(AttitudeInputs(platform=None, obs={}, obs_names={}, nav=no_j), ["J"])
