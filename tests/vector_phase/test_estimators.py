"""Estimators of seed 003 eq. 44-45 on simulated truth: the dipole's two angles from six satellites, the
unobservable rotation of a cylindrically symmetric antenna named and not reported, and three angles of a
non-symmetric antenna with errors consistent with the estimators' own sigma (issue 20 "Done when")."""
import numpy as np
import pytest

from gnssatt.vector_phase.antenna import AsymmetricPatch, RhcpPatch, ShortDipole
from gnssatt.vector_phase.batch import BatchOptions, batch_solve
from gnssatt.vector_phase.ekf import EkfOptions, ekf_solve
from gnssatt.vector_phase.phase_model import ReceiverState
from gnssatt.vector_phase.rotation import error_rotvec_body
from gnssatt.vector_phase.scenario import ScenarioSpec, simulate
from gnssatt.vector_phase.solution import euler_rows

L1_MM = 299792458.0 / 1575.42e6 * 1e3


def _initial(truth):
    return ReceiverState(truth.position_ecef_m, 0.0, truth.R_body_from_ecef[0])


def _truth_rows(sol, truth, bore):
    from dataclasses import replace
    return euler_rows(replace(sol, R_body_from_ecef=truth.R_body_from_ecef, null_rotation_body=np.full_like(
        sol.null_rotation_body, np.nan)), truth.R_ned_from_ecef, bore)


def _error_over_sigma(sol, truth, mount):
    bore = mount.R_ant_from_body[2]
    est, tru = euler_rows(sol, truth.R_ned_from_ecef, bore), _truth_rows(sol, truth, bore)
    err = (est.euler_deg - tru.euler_deg + 180.0) % 360.0 - 180.0
    return err / est.sigma_deg


def test_short_dipole_two_angles_from_six_satellites():
    """seed 003 sec. I (Krall and Bahder): a dipole tracking six satellites gives position, clock and the
    direction of its axis (yaw and pitch of body x here); the rotation about its axis is unobservable."""
    obs, truth, mount = simulate(ScenarioSpec(ShortDipole(), n_sats=6, n_epochs=12, sigma_phase_cyc=1e-9))
    sol = batch_solve(obs, mount, _initial(truth), BatchOptions(min_sats=6, tolerance_cyc=1e-9))
    assert sol.valid.all() and (sol.rank == 6).all()
    assert all("antenna x axis" in text for text in sol.observability)
    assert np.abs(sol.null_rotation_body - [1.0, 0.0, 0.0]).max() < 1e-6    # antenna x = body x here
    # noise-free: the 6 x 6 system is exact; 1e-9 cycles of noise and the 1e-9 cycle stop leave < 1 um
    assert np.abs(sol.position_ecef_m - truth.position_ecef_m).max() < 1e-6
    axis_est = sol.R_body_from_ecef[:, 0]                       # body x (the dipole axis) in ECEF
    axis_true = truth.R_body_from_ecef[:, 0]
    angle_deg = np.degrees(np.arccos(np.clip(np.sum(axis_est * axis_true, -1), -1, 1)))
    # the 1e-9 cycle noise and stop through the dipole's weak angular sensitivity (~0.03 cyc/rad): ~1e-6 rad
    assert angle_deg.max() < 1e-3
    rows = euler_rows(sol, truth.R_ned_from_ecef, mount.R_ant_from_body[2])
    assert rows.determined[:, :2].all() and not rows.determined[:, 2].any()   # yaw, pitch yes; roll no
    assert np.isnan(rows.euler_deg[:, 2]).all() and np.isnan(rows.sigma_deg[:, 2]).all()


@pytest.mark.parametrize("solver", [batch_solve, ekf_solve], ids=["batch", "ekf"])
def test_rhcp_patch_names_the_unobservable_rotation_and_does_not_report_it(solver):
    """Ideal RHCP: a turn about the boresight changes every satellite's phase alike (the receiver clock)."""
    tilt_over_sigma = []
    for seed in (1, 2, 3, 4):
        obs, truth, mount = simulate(ScenarioSpec(RhcpPatch(), n_sats=8, n_epochs=20, sigma_phase_cyc=5e-4,
                                                  pitch_amp_deg=0.0, roll_amp_deg=0.0, seed=seed))
        sol = solver(obs, mount, _initial(truth))
        assert sol.valid.all() and (sol.rank == 6).all()
        assert all("antenna boresight" in t and "receiver clock" in t for t in sol.observability)
        rows = euler_rows(sol, truth.R_ned_from_ecef, mount.R_ant_from_body[2])
        # boresight up: yaw is the unobservable angle, never reported; pitch and roll only where a free turn about
        # the boresight moves them by < 0.5 deg (observability.UNDETERMINED_SPREAD_DEG), i.e. hardly ever at a
        # few degrees of estimated tilt; what is determined is the boresight's direction (tilt from up, ~0 here)
        assert np.isnan(rows.euler_deg[:, 0]).all() and np.isnan(rows.sigma_deg[:, 0]).all()
        assert not rows.determined[:, 0].any()
        tilt_over_sigma.append(rows.boresight_deg[1:, 0] / rows.sigma_boresight_deg[1:, 0])   # epoch 0: the start
    tilt_over_sigma = np.concatenate(tilt_over_sigma)
    # the tilt is the length of a 2-D error near zero: RMS tilt / sigma is sqrt(2) for an honest sigma; one
    # 19-epoch run scatters 0.6-2.3 (its epochs are correlated), four pooled stay under 2
    assert np.all(np.isfinite(tilt_over_sigma)) and np.sqrt(np.mean(tilt_over_sigma ** 2)) < 2.0


def test_non_symmetric_antenna_batch_errors_match_sigma():
    ratios = []
    for seed in range(16):
        obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(), n_sats=8, n_epochs=10, seed=seed,
                                                  sigma_phase_cyc=5e-4))
        sol = batch_solve(obs, mount, _initial(truth))
        assert (sol.rank == 7).all() and all(t == "all seven unknowns observable" for t in sol.observability)
        ratios.append(_error_over_sigma(sol, truth, mount)[1:])
    rms = np.sqrt(np.mean(np.concatenate(ratios) ** 2, axis=0))
    assert np.all((rms > 0.8) & (rms < 1.25)), rms


def test_non_symmetric_antenna_ekf_errors_match_sigma():
    """1 mm of phase noise (5e-3 cycles), 8 satellites, yaw 0.5 deg/s, pitch and roll +-10 / 8 deg."""
    ratios, sigmas = [], []
    for seed in range(8):
        obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(), n_sats=8, n_epochs=60, seed=seed,
                                                  sigma_phase_cyc=5e-3))
        sol = ekf_solve(obs, mount, _initial(truth))
        assert (sol.rank == 7).all()
        r = _error_over_sigma(sol, truth, mount)
        ratios.append(r[10:])
        sigmas.append(euler_rows(sol, truth.R_ned_from_ecef).sigma_deg[-1])
        err = np.degrees(np.linalg.norm(error_rotvec_body(sol.R_body_from_ecef, truth.R_body_from_ecef), axis=-1))
        sigma_3d = np.degrees(np.sqrt(np.trace(sol.P[:, 4:, 4:], axis1=1, axis2=2)))
        assert np.all(err[1:] < 5 * sigma_3d[1:])                 # no divergence: within 5 sigma at every epoch
    rms = np.sqrt(np.mean(np.concatenate(ratios) ** 2, axis=0))
    assert np.all((rms > 0.8) & (rms < 1.25)), rms
    assert np.max(sigmas) < 8.0          # the filter after 60 s, deg: 1 mm of phase noise gives degrees (bench)


def test_seven_satellites_ekf_errors_match_sigma():
    """Exactly seven satellites (no redundancy in a snapshot) on a static antenna modelled static: consistent at
    0.1 mm of phase noise (5e-4 cycles): 0.92 / 0.97 / 0.95. With the former position random walk (1 mm/sqrt(s))
    the same runs gave 1.08 / 1.26 / 1.31 (docs/vector_phase.md "Consistency"); at 1-3 mm one run in four still
    loses the pitch (not asserted here)."""
    ratios = []
    for seed in range(4):
        obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(), n_sats=7, n_epochs=120, seed=seed,
                                                  sigma_phase_cyc=5e-4))
        sol = ekf_solve(obs, mount, _initial(truth))
        ratios.append(_error_over_sigma(sol, truth, mount)[30:])
    rms = np.sqrt(np.mean(np.concatenate(ratios) ** 2, axis=0))
    assert np.all((rms > 0.8) & (rms < 1.25)), rms


def _seven(seed: int, noise_mm: float, options=None):
    obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(asymmetry=0.5, harmonic=2), n_sats=7, n_epochs=120,
                                              seed=seed, sigma_phase_cyc=noise_mm / L1_MM))
    sol = ekf_solve(obs, mount, _initial(truth), options)
    bore = mount.R_ant_from_body[2]
    err = (euler_rows(sol, truth.R_ned_from_ecef, bore).euler_deg - _truth_rows(sol, truth, bore).euler_deg
           + 180.0) % 360.0 - 180.0
    return sol, err, _error_over_sigma(sol, truth, mount)


def test_seven_satellites_start_hypotheses_leave_the_wrong_minimum():
    """Seed 1 at 3 mm: one filter from zero rate settles on a pitch ~50 deg off in the first ~20 s, a second
    minimum of the batch cost (3.6 / 13.7 / 38.7 above the truth's over 30 / 60 / 120 s, docs/vector_phase.md);
    the bank of initial-rate hypotheses (the default) follows the truth's minimum."""
    _, err_one, _ = _seven(1, 3.0, EkfOptions(rate_hypotheses_step_deg_s=0.0))
    sol, err_bank, ratio = _seven(1, 3.0)
    assert np.nanmax(np.abs(err_one[30:, 1])) > 45.0          # the failure the bank is for (measured 64 deg)
    assert np.nanmax(np.abs(err_bank[30:, 1])) < 30.0         # measured 24 deg: ~3 sigma at its worst epoch
    assert sol.start_hypotheses["members"] == 28 and sol.start_hypotheses["decided_epoch"] < 119
    assert sol.start_hypotheses["kept"] != "single filter (zero rate)"      # measured: (0, 1, 1) deg/s at epoch 70
    assert sol.start_hypotheses["mixture_covariance_epochs"] > 30            # the Gaussian sum while they lived


def test_mixture_covariance_is_the_spread_about_the_reported_state():
    """Two members of equal cost 2 deg apart about body z, each with a 1 deg sigma: about the first one's state the
    mixture's z variance is 1 + 0.5 * 2^2 = 3 deg^2 (sum_i w_i (P_i + d_i d_i^T)); a member 20 units of cost worse
    (weight e^-10) adds < 1e-3 deg^2."""
    from gnssatt.vector_phase.rate_bank import mixture_covariance
    from gnssatt.vector_phase.rotation import perturb_body
    P = np.diag([1e-6] * 3 + [1.0] + [np.radians(1.0) ** 2] * 3)
    r, R = np.zeros(3), np.eye(3)
    other = perturb_body(R, np.radians([0.0, 0.0, 2.0]))
    mix = mixture_covariance([(5.0, r, 0.0, R, P), (5.0, r, 0.0, other, P)], (r, 0.0, R))
    assert abs(np.degrees(np.sqrt(mix[6, 6])) - np.sqrt(3.0)) < 1e-6
    assert abs(np.degrees(np.sqrt(mix[4, 4])) - 1.0) < 1e-9                  # no spread about x
    far = perturb_body(R, np.radians([0.0, 0.0, 2.0]))
    one = mixture_covariance([(0.0, r, 0.0, R, P), (20.0, r, 0.0, far, P)], (r, 0.0, R))
    assert 0.0 <= np.degrees(np.degrees(one[6, 6])) - 1.0 < 1e-3


def test_start_bank_with_eight_satellites_is_the_single_filter():
    """One minimum (8 satellites, 3 mm): every other hypothesis merges into the single filter, whose solution is
    then the result, to the last bit: the bank cannot degrade what one filter does right. Its covariance is the
    single filter's from the decision on; before, while other members lived, it is their Gaussian sum about the
    single filter's state (weighted member covariances plus their spread; not wider in every direction, because
    the members' own rate prior is narrower than the single filter's)."""
    obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(asymmetry=0.5, harmonic=2), n_sats=8, n_epochs=80,
                                              seed=0, sigma_phase_cyc=3.0 / L1_MM))
    one = ekf_solve(obs, mount, _initial(truth), EkfOptions(rate_hypotheses_step_deg_s=0.0))
    bank = ekf_solve(obs, mount, _initial(truth))
    assert bank.start_hypotheses["kept"] == "single filter (zero rate)" and not bank.start_hypotheses["ambiguous"]
    assert bank.start_hypotheses["decided_epoch"] < 79
    assert np.array_equal(bank.R_body_from_ecef, one.R_body_from_ecef)
    k = bank.start_hypotheses["decided_epoch"]
    assert np.array_equal(bank.P[k:], one.P[k:])
    assert not np.array_equal(bank.P[:k], one.P[:k])         # the spread is there while the members lived


@pytest.mark.parametrize("noise_mm", [1.0, 3.0], ids=["1mm", "3mm"])
def test_seven_satellites_ekf_errors_match_sigma_at_mm_noise(noise_mm):
    """Issue 20 line 1 at 7 satellites, 8 runs x 120 s, statistics after 30 s, the bank of start hypotheses with
    its Gaussian-sum covariance while several members live. Measured: 1 mm 0.93 / 0.92 / 0.95; 3 mm 1.08 / 1.14 /
    0.94 (seeds 8-15: 1.13 / 0.96 / 1.13). With the kept member's own covariance instead: 1 mm 0.94 / 0.98 / 0.96,
    3 mm 1.12 / 1.30 / 0.97 (seed 4's pitch 1.85 -> 0.94); one filter from zero rate 1.47 / 3.65 / 1.07."""
    ratios = [_seven(seed, noise_mm)[2][30:] for seed in range(8)]
    rms = np.sqrt(np.mean(np.concatenate(ratios) ** 2, axis=0))
    assert np.all((rms > 0.8) & (rms < 1.25)), rms
