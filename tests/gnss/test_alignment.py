"""gnssatt.gnss.alignment: receivers with free-running clocks, aligned, against perfectly synchronised twins.

The simulator (gnssatt.sim, preset "hard") is run twice with the same seed and noise, multipath, slips, gaps and
outages off: once with free-running clocks (+-0.5 ms, 1 ms jumps; drift raised to 5 ppm so 300 s hold one or two
jumps per receiver) and once with clocks exactly on GPS time (steered, amplitude 0). Everything else (geometry,
biases, ionosphere, PCV, wind-up) is identical, so the single differences between antennas of the aligned free
set must equal those of the synchronised set up to (a) a per-epoch common term (the receivers' differential clock,
which alignment keeps on purpose), (b) whole cycles per arc in phase (different ambiguities), and (c) the RINEX
quantisation: F14.3 writes code to 1 mm and phase to 0.001 cycle (0.19/0.24 mm), and a difference of single
differences adds four roundings (code up to 2 mm, RMS 0.58 mm; L2 phase up to 0.49 mm, RMS 0.14 mm).
Measured (seed 3): phase RMS 0.12-0.15 mm, max 0.52 mm; code RMS 0.56-0.58 mm, max 2.1 mm, i.e. the
quantisation floor; unaligned, the same comparison is off by metres.
"""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.gnss.alignment import align_to_gps_epochs, detect_clock_jumps
from gnssatt.gnss.constants import C_M_S
from gnssatt.gnss.ephemeris import BroadcastEphemeris
from gnssatt.gnss.positioning import spp
from gnssatt.gnss.signals import FREQ_GPS_L1_HZ, FREQ_GPS_L2_HZ

ANTS = ["GPS-2", "GPS-0", "GPS-1"]
BASE = dict(duration_s=300.0, noise=False, multipath=False, slip_rate_per_hour=0.0, gap_rate_per_hour=0.0,
            outage_rate_per_hour=0.0, outage_windows=[], clock_free_drift_ppm=5.0, truth_components=False,
            sp3_interval_s=0.0)
LAM = {"C1C": 1.0, "C2W": 1.0, "L1C": C_M_S / FREQ_GPS_L1_HZ, "L2W": C_M_S / FREQ_GPS_L2_HZ}
# Tolerances: the 0.5 mm, plus the quantisation of what the files can hold (module docstring).
PHASE_RMS_MM = 0.25
PHASE_MAX_MM = 0.5 + 0.1     # 0.5 mm requirement; four 0.001-cycle roundings alone reach 0.49 mm on L2
CODE_RMS_MM = 1.0            # 1 mm LSB: RMS of four roundings 0.58 mm
MIN_SATS = 5                 # epochs where both receivers have a tested fix (the first seconds have 2-4 sats)


def _simulate(tmp_path, jump_in_phase: bool):
    from gnssatt.sim import simulate_scenario

    ov = dict(BASE, clock_jump_in_phase=jump_in_phase)
    free = simulate_scenario("hard", tmp_path / "free", seed=3, overrides=ov)
    sync = simulate_scenario("hard", tmp_path / "sync", seed=3,
                             overrides=dict(ov, clock_mode="steered", clock_steer_amp_s=0.0))
    return free.sets[0], sync.sets[0]


def _read(set_):
    from gnssatt.gnss.io.rinex_nav import read_rinex_nav
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    eph = BroadcastEphemeris(read_rinex_nav(set_["files"]["nav"]))
    return eph, [read_rinex_obs(set_["files"]["obs"][a]) for a in ANTS]


def _ms(t):
    return t.s * 1000 + np.round(t.frac * 1000).astype(np.int64)


def _sync_on_grid(obs, code, grid_ms, sats):
    v = obs.get(code, "G")
    out = np.full((len(grid_ms), len(obs.sats)), np.nan)
    _, ig, io = np.intersect1d(grid_ms, _ms(obs.time), return_indices=True)
    out[ig] = v[io]
    cols = [obs.sats.index(s) if s in obs.sats else None for s in sats]
    return np.stack([out[:, c] if c is not None else np.full(len(grid_ms), np.nan) for c in cols], axis=1)


def _sd_difference_mm(al, sync_obs, code, b_idx):
    """(n, m) aligned-free SD minus synchronised SD, common per-epoch term and per-arc whole cycles removed, mm."""
    lam = LAM[code]
    grid_ms = _ms(al.time)
    A = al.receiver(ANTS[0]).get(code, "G", al.sats)
    B = al.receiver(ANTS[b_idx]).get(code, "G", al.sats)
    sync_sd = _sync_on_grid(sync_obs[b_idx], code, grid_ms, al.sats) - _sync_on_grid(sync_obs[0], code, grid_ms,
                                                                                      al.sats)
    d = (B - A - sync_sd) * lam
    enough = np.sum(np.isfinite(d), axis=1) >= MIN_SATS
    d[~enough] = np.nan
    with np.errstate(invalid="ignore"), _nowarn():
        d = d - np.nanmedian(d, axis=1, keepdims=True)
        if code[0] == "L":  # different ambiguities: whole cycles per satellite (arcs are unbroken here)
            d = d - np.round(np.nanmedian(d, axis=0, keepdims=True) / lam) * lam
            d = d - np.nanmedian(d, axis=1, keepdims=True)
    return d * 1e3


class _nowarn:
    def __enter__(self):
        import warnings

        self._c = warnings.catch_warnings()
        self._c.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows/columns in nanmedian

    def __exit__(self, *exc):
        return self._c.__exit__(*exc)


@pytest.fixture(scope="module")
def free_and_sync(tmp_path_factory):
    free, sync = _simulate(tmp_path_factory.mktemp("align_jip"), jump_in_phase=True)
    eph, obs = _read(free)
    _, sync_obs = _read(sync)
    sols = [spp(o, eph) for o in obs]
    al = align_to_gps_epochs(obs, sols, eph, names=ANTS)
    return dict(free=free, eph=eph, obs=obs, sync_obs=sync_obs, sols=sols, al=al)


def test_receivers_really_are_free_running(free_and_sync):
    clocks = [np.nanmax(np.abs(s.clock_s)) for s in free_and_sync["sols"]]
    assert all(2e-4 < c <= 5.1e-4 for c in clocks), clocks  # up to 0.5 ms off GPS time


@pytest.mark.parametrize("code", ["L1C", "L2W"])
@pytest.mark.parametrize("b_idx", [1, 2])
def test_aligned_phase_single_differences_match_synchronised(free_and_sync, code, b_idx):
    d = _sd_difference_mm(free_and_sync["al"], free_and_sync["sync_obs"], code, b_idx)
    assert np.isfinite(d).sum() > 2000
    rms, worst = float(np.sqrt(np.nanmean(d ** 2))), float(np.nanmax(np.abs(d)))
    assert rms < PHASE_RMS_MM and worst < PHASE_MAX_MM, (rms, worst)


@pytest.mark.parametrize("code", ["C1C", "C2W"])
def test_aligned_code_single_differences_match_synchronised(free_and_sync, code):
    d = _sd_difference_mm(free_and_sync["al"], free_and_sync["sync_obs"], code, 1)
    assert float(np.sqrt(np.nanmean(d ** 2))) < CODE_RMS_MM


def test_without_alignment_the_difference_is_metres(free_and_sync):
    """The same comparison on the raw time tags: this is what alignment removes (range rate x clock offset)."""
    al = free_and_sync["al"]
    obs = free_and_sync["obs"]
    grid_ms = _ms(al.time)
    raw = [_sync_on_grid(o, "L1C", grid_ms, al.sats) for o in obs]  # tags are whole seconds: same grid
    sync = [_sync_on_grid(o, "L1C", grid_ms, al.sats) for o in free_and_sync["sync_obs"]]
    d = ((raw[1] - raw[0]) - (sync[1] - sync[0])) * LAM["L1C"]
    with _nowarn():
        d = d - np.nanmedian(d, axis=1, keepdims=True)
        d = d - np.round(np.nanmedian(d, axis=0, keepdims=True) / LAM["L1C"]) * LAM["L1C"]
    assert np.nanmax(np.abs(d)) > 0.5


def test_clock_jumps_found_with_phase(free_and_sync):
    al, free = free_and_sync["al"], free_and_sync["free"]
    for a in ANTS:
        ev = [e for e in al.events if e.receiver == a]
        assert len(ev) == free["summary"]["antennas"][a]["clock_jumps"], (a, ev)
        assert all(e.in_phase is True and abs(abs(e.jump_s) - 1e-3) < 1e-12 for e in ev)
    assert len(al.events) >= 3


def test_grid_and_bookkeeping(free_and_sync):
    al = free_and_sync["al"]
    assert al.interval_s == 1.0 and np.all(al.time.frac == 0.0)
    for rx in al.receivers:
        ok = rx.present
        assert np.all(np.abs(rx.shift_s[ok]) <= 5.1e-4)  # t0 - t: the clock offset (within 0.5 ms)
        assert rx.shifted[ok].sum() > 0.9 * np.isfinite(rx.values[ok][:, :, 0]).sum()


def test_code_only_jumps_detected_and_repaired(tmp_path):
    free, _ = _simulate(tmp_path, jump_in_phase=False)
    eph, obs = _read(free)
    sols = [spp(o, eph) for o in obs]
    al = align_to_gps_epochs(obs, sols, eph, names=ANTS, repair_clock_jumps=True)
    assert al.events and all(e.in_phase is False and e.repaired for e in al.events)
    # after the repair the kept clock and the code are continuous across every jump
    for e in al.events:
        rx = al.receiver(e.receiver)
        clk = rx.clock_s[np.isfinite(rx.clock_s)]
        assert np.max(np.abs(np.diff(clk))) < 1e-5
        c1 = rx.get("C1C", "G", al.sats)
        l1 = rx.get("L1C", "G", al.sats) * LAM["L1C"]
        cmp_ = l1 - c1  # across the jump, code minus phase moves by the ionosphere (cm), not by 300 km
        k = int(np.searchsorted(_ms(al.time), _ms(e.time_tag)))
        step = cmp_[k] - cmp_[k - 1]
        assert np.isfinite(step).sum() >= 4 and np.nanmax(np.abs(step)) < 1.0, step
    # detect_clock_jumps on the raw clock series says the same
    ev, k_cum = detect_clock_jumps(obs[0], sols[0].clock_s, "GPS-2")
    assert [x.index for x in ev] == [x.index for x in al.events if x.receiver == "GPS-2"]
    assert k_cum[-1] == int(round(sum(x.jump_s for x in ev) / 1e-3))
