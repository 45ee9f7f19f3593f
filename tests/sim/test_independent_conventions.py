"""The simulator keeps its own small rotation and Earth-rotation helpers on purpose: it scores the product,
so a convention slip in gnssatt/gnss/rotations.py or frames.py must not be copied into the truth. Here the
two independent implementations of ../shared/CONVENTIONS.md are held to agree."""
from __future__ import annotations

import numpy as np

from gnssatt.gnss import frames, rotations
from gnssatt.gnss.time import GpsTime
from gnssatt.sim import _frames as sim_frames
from gnssatt.sim import _rot as sim_rot


def _random_quats(n, seed=0):
    q = np.random.default_rng(seed).normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return np.where(q[:, :1] < 0, -q, q)


def test_quaternion_matrices_agree():
    q = _random_quats(500)
    np.testing.assert_allclose(sim_rot.dcm_from_quat(q), rotations.quat_to_dcm(q), atol=1e-15)
    R = rotations.quat_to_dcm(q)
    np.testing.assert_allclose(sim_rot.quat_from_dcm(R), rotations.dcm_to_quat(R), atol=1e-13)


def test_quaternion_products_agree():
    p, q = _random_quats(300, 1), _random_quats(300, 2)
    a = sim_rot.quat_mul(p, q)
    b = rotations.quat_multiply(p, q)
    a = np.where(a[:, :1] < 0, -a, a)
    b = np.where(b[:, :1] < 0, -b, b)
    np.testing.assert_allclose(a, b, atol=1e-14)


def test_euler_321_agrees():
    rng = np.random.default_rng(3)
    yaw, pitch, roll = rng.uniform(-179, 179, 400), rng.uniform(-89, 89, 400), rng.uniform(-179, 179, 400)
    np.testing.assert_allclose(sim_rot.dcm_from_euler321_deg(yaw, pitch, roll),
                               rotations.euler321_to_dcm(yaw, pitch, roll), atol=1e-14)
    R = rotations.euler321_to_dcm(yaw, pitch, roll)
    for a, b in zip(sim_rot.euler321_deg_from_dcm(R), rotations.dcm_to_euler321(R)):
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_earth_rotation_agrees_with_the_data_layer():
    t0 = GpsTime.from_calendar(2018, 6, 6, 12, 20, 0.0)
    dt = np.linspace(0.0, 6360.0, 97)
    R_sim = sim_frames.EarthRotation(int(t0.s), (0.0, 6360.0)).R_ecef_from_gcrf(dt)
    R_lib = frames.R_ecef_from_gcrf(t0 + dt)
    M = R_sim @ np.swapaxes(R_lib, -1, -2)
    axis = np.stack([M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1) / 2
    angle = np.linalg.norm(axis, axis=-1)  # sin(angle), exact for small angles (arccos of the trace is not)
    assert np.max(angle) < 1e-9  # rad: both are IAU 2006/2000A with zero EOP (measured 4e-11)
