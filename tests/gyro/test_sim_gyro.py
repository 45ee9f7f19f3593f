"""The simulator's gyro logs and GPS fault injection against their own definitions (gnssatt.sim.gyro,
gnssatt.sim.gps_faults)."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.gnss import rotations as rot
from gnssatt.gyro.ekf import propagate_attitude
from gnssatt.gyro.gyro_csv import read_gyro_csv
from gnssatt.sim.gps_faults import PhaseFault, inject_outage, inject_phase_faults
from gnssatt.sim.gyro import DriftFault, GyroErrorModel, simulate_gyro, true_rates


def _spin(n=2001, dt=0.1):
    t = np.arange(n) * dt
    th = np.stack([1e-3 * t, 2e-3 * np.sin(t / 30), 5e-4 * t ** 1.5 / 10], 1)
    return t, rot.quat_from_rotvec(th)


def test_true_rates_integrate_back_to_the_attitude():
    t, q = _spin()
    w = true_rates(t, q)
    qq = propagate_attitude(q[0].copy(), np.zeros(3), w, np.diff(t))
    # exact per interval (the rotation vector of each step is taken as the rate times dt): 1e-9 rad
    assert np.degrees(np.linalg.norm(rot.quat_to_rotvec(rot.quat_multiply(qq, rot.quat_conjugate(q[-1]))))) < 1e-7


def test_gyro_noise_statistics_and_fault():
    t, q = _spin(n=20001)
    m = GyroErrorModel(drift_sigma_rad_s=0.0, quantum_rad=0.0, faults=(DriftFault(axis=0, start_s=1000.0,
                                                                                    size_rad_s=4.8e-4),))
    w, truth = simulate_gyro(t, q, m, np.random.default_rng(3))
    err = w - truth["true_rate_rad_s"]
    before = err[t[1:] < 1000.0]
    # ARW: rate noise N / sqrt(dt); 10000 samples give the std to 1.4 %, so 5 %
    assert np.allclose(before.std(axis=0), m.arw_rad_sqrt_s / np.sqrt(0.1), rtol=0.05)
    after = err[t[1:] >= 1000.0]
    assert abs(after[:, 0].mean() - 4.8e-4) < 5 * m.arw_rad_sqrt_s / np.sqrt(0.1) / np.sqrt(len(after))
    assert abs(after[:, 1].mean()) < 5 * m.arw_rad_sqrt_s / np.sqrt(0.1) / np.sqrt(len(after))


def test_drift_gauss_markov_and_quantisation():
    t, q = _spin(n=20001)
    m = GyroErrorModel(drift_tau_s=50.0, quantum_rad=1e-5)
    w, truth = simulate_gyro(t, q, m, np.random.default_rng(4))
    d = truth["drift_rad_s"]
    # 2000 s / tau 50 s ~ 40 independent stretches per axis, 120 over 3 axes: the std to ~7 %, so 25 %
    assert np.std(d) == pytest.approx(m.drift_sigma_rad_s, rel=0.25)
    angles = np.cumsum(w * 0.1, axis=0)
    assert np.allclose(np.round(angles / 1e-5) * 1e-5, angles, atol=1e-9)     # the running angle is quantised


def test_phase_fault_and_outage_in_rinex(gyro_set, tmp_path):
    from gnssatt.gnss.io.rinex_obs import read_rinex_obs

    ant, path = next(iter(gyro_set.sim.obs.items()))
    clean = tmp_path / "clean.rnx"
    clean.write_text(path.read_text())
    o0 = read_rinex_obs(clean)
    t_s = o0.time.s.astype(float) + o0.time.frac
    k = 30
    faulty = tmp_path / "faulty.rnx"
    faulty.write_text(clean.read_text())
    lines = clean.read_text().split("\n")
    first_sat = next(ln[:3] for ln in lines[lines.index(next(x for x in lines if "END OF HEADER" in x)) + 2:]
                     if ln[:1] == "G")
    n = inject_phase_faults(faulty, [PhaseFault(ant, first_sat, t_s[k], t_s[k + 2], 0.35)])
    assert n == 3
    a, b = clean.read_text().split("\n"), faulty.read_text().split("\n")
    diffs = [(x, y) for x, y in zip(a, b) if x != y]
    assert len(diffs) == 3 and all(x[:3] == first_sat for x, _ in diffs)
    for x, y in diffs:                      # L1C is the 2nd field (C1C L1C ...): 0.35 cycle to the 0.001 text
        assert abs(float(y[19:33]) - float(x[19:33]) - 0.35) < 1e-6
    assert inject_outage([faulty], t_s[10], t_s[15]) == 6
    o1 = read_rinex_obs(faulty)
    assert len(o1.time) == len(o0.time) - 6
    gy = read_gyro_csv(gyro_set.gyro_csv.read_bytes())
    assert abs(gy.interval_s - 0.1) < 1e-6 and len(gy.time) == 6000
