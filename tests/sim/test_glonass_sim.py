"""GLONASS FDMA in the simulator (issue 21): the files it writes read back with the right channels and wavelengths,
its GLONASS orbits as the library evaluates them from the written (or a real) navigation file, the receivers'
inter-channel biases, and GPS-only sets untouched by any of it."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gnssatt.gnss.io.rinex_nav import read_rinex_nav
from gnssatt.gnss.io.rinex_obs import read_rinex_obs
from gnssatt.gnss.orbits.glonass import glonass_state_ecef, select_glonass
from gnssatt.gnss.signals import glonass_wavelength_m
from gnssatt.gnss.time import GpsTime
from gnssatt.sim import simulate_scenario
from gnssatt.sim.glonass_constellation import NOMINAL_CHANNELS, glonass_from_nav
from gnssatt.sim.scenarios import make_params
from gnssatt.sim.simulate import _constellation
from tests.conftest import real_set

#: no noise, multipath, ionosphere, wind-up, PCV/PCO: phase x wavelength - code is then constant along an arc
QUIET = {"duration_s": 120.0, "noise": False, "multipath": False, "ionosphere": False, "windup": False,
         "pcv": False, "pco": False}


@pytest.fixture(scope="module")
def mixed_set(tmp_path_factory):
    d = tmp_path_factory.mktemp("glo_mixed")
    simulate_scenario("ground-static", d, seed=5, overrides={"systems": "G+R", **QUIET})
    return d


def test_mixed_obs_header_carries_the_icd_channels(mixed_set):
    obs = read_rinex_obs(mixed_set / "obs" / "ANT1.rnx")
    text = (mixed_set / "obs" / "ANT1.rnx").read_text()
    assert "M: MIXED" in text.splitlines()[0] and "GLONASS COD/PHS/BIS" in text
    assert obs.header.glonass_slots == {f"R{s:02d}": k for s, k in NOMINAL_CHANNELS.items()}
    model = json.loads((mixed_set / "truth" / "model.json").read_text())
    assert model["glonass"]["channels"] == obs.header.glonass_slots
    assert {s[0] for s in obs.sats} == {"G", "R"}
    assert sum(s[0] == "R" for s in obs.sats) >= 4


def test_phase_scaled_by_each_channel_wavelength(mixed_set):
    """Read back through the attitude job's extraction: per-satellite G1/G2 wavelengths of channel k, and with every
    error source off, phase (m) - code stays within 2 mm along each arc (1 mm file rounding of each); channel 0's
    wavelength for every satellite leaves a drift of decimetres (the range changes by ~km in 2 min), so the check
    separates the right wavelengths from one per signal."""
    from gnssatt.attitude.observations import build_platform_obs, glonass_channels

    obs = {"ANT1": read_rinex_obs(mixed_set / "obs" / "ANT1.rnx")}
    nav = read_rinex_nav(mixed_set / "nav" / "brdc.rnx")
    po = build_platform_obs(obs, ["R:G1", "R:G2"], channels=glonass_channels(obs, nav))
    assert po.sats and all(s[0] == "R" for s in po.sats)
    checked = 0
    for i, sat in enumerate(po.sats):
        k = NOMINAL_CHANNELS[int(sat[1:])]
        for f, band in enumerate((1, 2)):
            assert po.wavelength_sat_m[i, f] == pytest.approx(glonass_wavelength_m(band, k), rel=1e-15)
            code, phase_m = po.code_m[0, :, i, f], po.phase_m[0, :, i, f]
            ok = np.isfinite(code) & np.isfinite(phase_m)
            if ok.sum() < 30:
                continue
            d = phase_m[ok] - code[ok]
            assert np.ptp(d) < 0.002, (sat, band, np.ptp(d))
            checked += 1
            lam0 = glonass_wavelength_m(band, 0)
            if k != 0:
                assert np.ptp(phase_m[ok] / po.wavelength_sat_m[i, f] * lam0 - code[ok]) > 0.05
    assert checked >= 8                     # >= 4 satellites on both bands


def test_georinex_reads_the_same_glonass_values(mixed_set):
    import georinex          # in the venv (requirements): an independent reader of both files
    lib = read_rinex_obs(mixed_set / "obs" / "ANT1.rnx")
    ds = georinex.load(mixed_set / "obs" / "ANT1.rnx", use="R")
    r_sats = [s for s in lib.sats if s[0] == "R"]
    assert sorted(str(s) for s in ds.sv.values) == sorted(r_sats)
    sat = r_sats[0]
    j = list(lib.sats).index(sat)
    for code in ("L1C", "C2P", "L2P"):
        ours = lib.get(code, "R")[:, j]
        theirs = ds[code].sel(sv=sat).values
        ok = np.isfinite(ours)
        np.testing.assert_allclose(theirs[: ours.size][ok], ours[ok], rtol=0, atol=1e-3)
    nav = georinex.load(mixed_set / "nav" / "brdc.rnx", use="R")
    for sat in ("R01", "R10", "R17"):
        k = nav["FreqNum"].sel(sv=sat).values
        assert set(k[np.isfinite(k)].astype(int)) == {NOMINAL_CHANNELS[int(sat[1:])]}


def test_written_glonass_records_give_the_truth_orbit(mixed_set):
    """The library's ICD 5.1 integration of the written records (RK4, 60 s, <= 15 min from t_b) against the
    simulator's truth: measured 0.6 mm worst at 15 min; 2 mm allows for the RINEX text rounding."""
    p = make_params("ground-static", {"systems": "G+R", **QUIET})
    t0 = GpsTime.from_iso(p.start_gps)
    glo = _constellation(p, t0, (-5.0, 125.0), 18).glonass
    nav = read_rinex_nav(mixed_set / "nav" / "brdc.rnx").glonass
    assert sorted(set(nav.sat.tolist())) == glo.sats
    assert {s: int(k) for s, k in zip(nav.sat.tolist(), nav.frequency_number)} == \
        {f"R{s:02d}": k for s, k in NOMINAL_CHANNELS.items()}
    worst = 0.0
    for dt in (0.0, 60.0, 120.0):
        t = t0 + dt
        for j, sat in enumerate(glo.sats):
            i = select_glonass(nav, sat, t, 1800.0)
            r, _, clk, _ = glonass_state_ecef(nav, i, t)
            r_true, clk_true = glo.position_clock(np.array([[float(t - glo.t_ref)]]), np.array([j]))
            worst = max(worst, float(np.linalg.norm(r[0] - r_true[0, 0])))
            assert abs(clk[0] - clk_true[0, 0]) < 1e-15
    assert worst < 0.002


def test_glonass_orbits_from_the_real_nagoya_nav():
    """Truth orbits taken from a real file's GLONASS records (Nagoya base.nav, 8 healthy satellites near t0): the
    simulator's own integration against the library's over +-15 min of each record, measured 0.65 mm worst."""
    nav_path = real_set("static_1m_mosaicx5_nagoya_2024") / "base.nav"
    g = read_rinex_nav(nav_path).glonass
    t0 = GpsTime.from_iso("2024-06-24T08:46:00")
    t_ref = GpsTime(int(t0.s) - int(t0.s) % 7200)
    off = float(t0 - t_ref)
    c = glonass_from_nav(nav_path, t0, t_ref, (off - 10.0, off + 700.0), 18)
    assert len(c.sats) >= 6
    for j, sat in enumerate(c.sats):
        rows = np.flatnonzero(g.sat == sat)
        i = int(rows[np.argmin(np.abs(np.asarray(g.toc[rows].s - int(t0.s), float)))])
        assert c.channels[j] == g.frequency_number[i]
        for dt in np.arange(-900.0, 901.0, 300.0):
            t = g.toc[i] + dt
            r, _, clk, _ = glonass_state_ecef(g, np.array([i]), t)
            r_sim, clk_sim = c.position_clock(np.array([[float(t - t_ref)]]), np.array([j]))
            assert np.linalg.norm(r[0] - r_sim[0, 0]) < 0.002, (sat, dt)
            assert abs(clk[0] - clk_sim[0, 0]) < 1e-15


def test_simulated_set_from_the_nagoya_nav_is_mixed(tmp_path):
    nav_path = real_set("static_1m_mosaicx5_nagoya_2024") / "base.nav"
    simulate_scenario("ground-static", tmp_path, seed=2, overrides={
        "systems": "G+R", "nav_file": str(nav_path), "start_gps": "2024-06-24T08:46:00", "duration_s": 30.0})
    nav = read_rinex_nav(tmp_path / "nav" / "brdc.rnx")
    assert len(nav.kepler["G"]) > 0 and len(nav.glonass) > 0
    obs = read_rinex_obs(tmp_path / "obs" / "ANT1.rnx")
    real_k = dict(zip(read_rinex_nav(nav_path).glonass.sat.tolist(), read_rinex_nav(nav_path).glonass.frequency_number))
    assert obs.header.glonass_slots and all(real_k[s] == k for s, k in obs.header.glonass_slots.items())


def test_inter_channel_biases_follow_the_receiver_model(tmp_path):
    """Code ICB linear in k plus a per-channel table on one receiver model: the code difference against the same
    set without biases is exactly the model on GLONASS (1 mm file rounding), zero on GPS and on the other model."""
    icb = {"RX-B": {"code_m_per_k": 0.25, "phase_m_per_k": 0.003, "code_m_by_k": {"1": 0.5, "-4": -0.7}}}
    types = {"ANT1": "RX-A", "ANT2": "RX-B"}
    for name, extra in (("plain", {}), ("icb", {"glonass_icb_by_model": icb})):
        simulate_scenario("ground-static", tmp_path / name, seed=5,
                          overrides={"systems": "G+R", **QUIET, "receiver_types": types, **extra})
    model = json.loads((tmp_path / "icb" / "truth" / "model.json").read_text())
    assert model["glonass"]["receivers"]["ANT2"]["receiver"] == "RX-B"
    for ant, slope in (("ANT1", 0.0), ("ANT2", 0.25)):
        a = read_rinex_obs(tmp_path / "plain" / "obs" / f"{ant}.rnx")
        b = read_rinex_obs(tmp_path / "icb" / "obs" / f"{ant}.rnx")
        assert a.header.receiver_type == types[ant]
        for j, sat in enumerate(a.sats):
            d = b.get("C1C", sat[0])[:, j] - a.get("C1C", sat[0])[:, j]
            d = d[np.isfinite(d)]
            if sat[0] == "G":
                assert np.all(d == 0.0)
                continue
            k = NOMINAL_CHANNELS[int(sat[1:])]
            want = slope * k + (({"1": 0.5, "-4": -0.7}.get(str(k), 0.0)) if slope else 0.0)
            assert want == pytest.approx(model["glonass"]["receivers"][ant]["icb"]["L1"]["code_m"][sat], abs=1e-12)
            np.testing.assert_allclose(d, want, atol=1.5e-3)


def test_glonass_only_set(tmp_path):
    simulate_scenario("ground-static", tmp_path, seed=1, overrides={"systems": "R", "duration_s": 20.0})
    assert "R: GLONASS" in (tmp_path / "nav" / "brdc.rnx").read_text().splitlines()[0]
    assert "R: GLONASS" in (tmp_path / "obs" / "ANT1.rnx").read_text().splitlines()[0]
    obs = read_rinex_obs(tmp_path / "obs" / "ANT1.rnx")
    assert obs.sats and all(s[0] == "R" for s in obs.sats)
    arcs = (tmp_path / "truth" / "arcs.csv").read_text()
    assert ",R:G1," in arcs and ",R:G2," in arcs and ",L1," not in arcs


def test_gps_only_sets_have_no_glonass_trace(tmp_path):
    """Default systems "G": the files are those of the simulator before GLONASS (header, parameters in
    model.json; byte-identity was checked by hashing every file of four GPS-only scenarios before and after)."""
    simulate_scenario("ground-static", tmp_path, seed=1, overrides={"duration_s": 10.0})
    obs_text = (tmp_path / "obs" / "ANT1.rnx").read_text()
    assert "G: GPS" in obs_text.splitlines()[0] and "GLONASS" not in obs_text
    assert "GLONASS" not in (tmp_path / "nav" / "brdc.rnx").read_text()
    model = json.loads((tmp_path / "truth" / "model.json").read_text())
    assert "glonass" not in model
    assert not {"systems", "receiver_types", "glonass_icb_by_model"} & set(model["parameters"])


def test_unknown_system_is_refused(tmp_path):
    with pytest.raises(ValueError, match="systems"):
        simulate_scenario("ground-static", tmp_path, overrides={"systems": "G+E", "duration_s": 5.0})
    with pytest.raises(ValueError, match="receiver_types"):
        simulate_scenario("ground-static", tmp_path, overrides={"receiver_types": {"X": "RX"}, "duration_s": 5.0})


def _rows(path, key) -> dict:
    import csv

    return {key(r): r for r in csv.DictReader(open(path))}


def test_glonass_observations_rebuilt_from_the_truth_files(tmp_path):
    """Undifferenced G1/G2 phase and code of one antenna rebuilt apart from the simulator: the library's orbit and
    clock of the written nav records (light time, Sagnac), the receiver clock and position of truth/receivers.csv,
    ionosphere (iono_l1_m: the delay on the satellite's own G1) and wind-up of truth/observations_*.csv, arcs.csv
    integers, model.json biases,
    wavelength c / f_k of the file's GLONASS SLOT / FRQ #. Residuals: orbit (0.6 mm) + RINEX rounding (1 mm
    code, 0.001 cycle phase) -> 2 mm."""
    from gnssatt.gnss.constants import C_M_S, OMEGA_EARTH_RAD_S
    from gnssatt.gnss.signals import glonass_frequency_hz

    simulate_scenario("ground-static", tmp_path, seed=7, overrides={
        "systems": "R", "duration_s": 60.0, "noise": False, "multipath": False, "troposphere": False, "pcv": False,
        "pco": False})
    aid = "ANT2"
    obs = read_rinex_obs(tmp_path / "obs" / f"{aid}.rnx")
    nav = read_rinex_nav(tmp_path / "nav" / "brdc.rnx").glonass
    model = json.loads((tmp_path / "truth" / "model.json").read_text())
    A = model["antennas"][aid]
    rec = _rows(tmp_path / "truth" / "receivers.csv", lambda r: (r["antenna"], r["time_gps"]))
    comp = _rows(tmp_path / "truth" / f"observations_{aid}.csv", lambda r: (r["time_gps"], r["sat"]))
    arcs = [r for r in _rows(tmp_path / "truth" / "arcs.csv", lambda r: tuple(r.values())).values()
            if r["antenna"] == aid]
    iso = np.asarray(obs.time.iso(3))
    clock = np.array([float(rec[(aid, t)]["clock_s"]) for t in iso])
    r_rx = np.array([[float(rec[(aid, t)][c]) for c in ("x_ecef_m", "y_ecef_m", "z_ecef_m")] for t in iso])
    t_rx = obs.time + (-clock)
    n_checked = 0
    for j, sat in enumerate(obs.sats):
        k = obs.header.glonass_slots[sat]
        tau = np.full(iso.size, 0.07)
        for _ in range(4):
            t_tx = t_rx + (-tau)
            r_tx, _, dt_sv, _ = glonass_state_ecef(nav, select_glonass(nav, sat, t_tx, 1800.0), t_tx)
            c, s = np.cos(OMEGA_EARTH_RAD_S * tau), np.sin(OMEGA_EARTH_RAD_S * tau)
            r_s = np.stack([c * r_tx[:, 0] + s * r_tx[:, 1], -s * r_tx[:, 0] + c * r_tx[:, 1], r_tx[:, 2]], 1)
            rho = np.linalg.norm(r_s - r_rx, axis=1)
            tau = rho / C_M_S
        for band, sig, lcode, ccode in ((1, "L1", "L1C", "C1C"), (2, "L2", "L2P", "C2P")):
            f_k = glonass_frequency_hz(band, k)
            lam = C_M_S / f_k
            L, P = obs.get(lcode, "R")[:, j], obs.get(ccode, "R")[:, j]
            ok = np.isfinite(L)
            if ok.sum() < 20:
                continue
            iono = np.array([float(comp[(t, sat)]["iono_l1_m"]) if (t, sat) in comp else np.nan for t in iso]) \
                * (glonass_frequency_hz(1, k) / f_k) ** 2          # the column is the delay on the satellite's L1
            wind = np.array([float(comp[(t, sat)]["windup_cyc"]) if (t, sat) in comp else np.nan for t in iso])
            amb = np.full(iso.size, np.nan)
            for a in arcs:
                if a["sat"] == sat and a["signal"] == f"R:G{band}":
                    amb[(iso >= a["start_time_gps"]) & (iso <= a["end_time_gps"])] = float(a["ambiguity_cyc"])
            bias = A["receiver_phase_bias_cyc"][sig] + model["satellite_phase_bias_cyc"][sig][sat]
            geo = rho + C_M_S * (clock - dt_sv)
            phase = geo - iono + lam * (wind + amb + bias)
            code = geo + iono + A["receiver_code_bias_m"][sig]
            assert np.max(np.abs(L[ok] * lam - phase[ok])) < 0.002, (sat, sig)
            assert np.max(np.abs(P[ok] - code[ok])) < 0.002, (sat, sig)
            n_checked += 1
    assert n_checked >= 8
