"""The vector-phase model (seed 003 eq. 32) against the textbook phase wind-up (Wu et al. 1993), written out
here independently and as the multi-antenna simulator implements it (RTKLIB windupcorr form)."""
import numpy as np

from gnssatt.sim.observables import windup_cycles
from gnssatt.vector_phase.antenna import AsymmetricPatch, RhcpPatch, ShortDipole, h_cartesian_antenna, table_of
from gnssatt.vector_phase.phase_model import AntennaMount, delta_rad
from gnssatt.vector_phase.rotation import D_eq26, rotation_matrix

# 1e-6 cycles is the bound (0.2 um at L1); float64 rounding of the two formulas is ~1e-14 cycles
WU_TOLERANCE_CYC = 1e-6


def _wu_cycles(k, x_r, y_r, x_s, y_s):
    """Wu et al. 1993 eq. 5-7 written from the paper: D' = x_s - k (k.x_s) - k x y_s, D = x_r - k (k.x_r) + k x y_r,
    delta_phi = sign(k . (D' x D)) arccos(D'.D / |D'||D|), in cycles (not unwrapped)."""
    dot = lambda a, b: np.sum(a * b, axis=-1)  # noqa: E731
    d_s = x_s - k * dot(k, x_s)[..., None] - np.cross(k, y_s)
    d_r = x_r - k * dot(k, x_r)[..., None] + np.cross(k, y_r)
    c = dot(d_s, d_r) / (np.linalg.norm(d_s, axis=-1) * np.linalg.norm(d_r, axis=-1))
    return np.sign(dot(k, np.cross(d_s, d_r))) * np.arccos(np.clip(c, -1, 1)) / (2 * np.pi)


def _random_geometry(n_ep=120, n_sv=9, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n_ep)
    A = rotation_matrix(np.outer(t, [0.7, -1.3, 2.9]) + rng.normal(size=3))   # body axes in ECEF (columns)
    e = rng.normal(size=(n_sv, 3))
    e /= np.linalg.norm(e, axis=-1, keepdims=True)
    e = np.broadcast_to(e, (n_ep, n_sv, 3)).copy()
    B = rotation_matrix(rng.normal(size=(n_sv, 3)))
    x_s = np.broadcast_to(B[:, :, 0], e.shape)
    y_s = np.broadcast_to(B[:, :, 1], e.shape)
    return np.swapaxes(A, -1, -2), A, e, x_s, y_s


def _wrap(c):
    return c - np.round(c)


def test_ideal_rhcp_reproduces_wu_windup_to_1e6_cycles():
    R_body_from_ecef, A, e, x_s, y_s = _random_geometry()
    mount = AntennaMount(RhcpPatch(), np.eye(3))
    delta_cyc = delta_rad(mount, R_body_from_ecef, e, x_s, y_s) / (2 * np.pi)
    x_r = np.broadcast_to(A[:, None, :, 0], e.shape)
    y_r = np.broadcast_to(A[:, None, :, 1], e.shape)
    independent = _wu_cycles(-e, x_r, y_r, x_s, y_s)
    assert np.max(np.abs(_wrap(delta_cyc - independent))) < WU_TOLERANCE_CYC
    simulator = windup_cycles(e, A[:, :, 0], A[:, :, 1], x_s, y_s)        # unwrapped along the epochs
    unwrapped = np.unwrap(delta_cyc * 2 * np.pi, axis=0) / (2 * np.pi)
    offset = np.round(simulator[0] - unwrapped[0])
    assert np.max(np.abs(unwrapped + offset - simulator)) < WU_TOLERANCE_CYC


def test_a_full_turn_about_the_line_of_sight_adds_one_cycle():
    """The wind-up's defining property: one revolution of the receiver about the line of sight = one cycle."""
    k = np.array([0.0, 0.0, -1.0])                       # satellite overhead, wave travelling down
    chi = np.linspace(0.0, 2 * np.pi, 361)
    A = rotation_matrix(np.outer(chi, [0.0, 0.0, 1.0]))   # receiver (boresight up) turned about the vertical
    mount = AntennaMount(RhcpPatch(), np.eye(3))
    d = delta_rad(mount, np.swapaxes(A, -1, -2), np.broadcast_to(-k, (361, 1, 3)),
                  np.array([1.0, 0, 0]), np.array([0, -1.0, 0]))
    turns = (np.unwrap(d[:, 0]) - d[0, 0]) / (2 * np.pi)
    assert abs(abs(turns[-1]) - 1.0) < 1e-9
    assert np.max(np.abs(np.abs(turns) - chi / (2 * np.pi))) < 1e-9   # and linearly so, for a wave on boresight


def test_dipole_phase_is_the_angle_of_its_projected_axis():
    """seed 003 sec. I (Krall and Bahder): a short dipole's phase is the angle from u to its axis projected on
    the wave front, whatever its length; independent of a rotation about its own axis."""
    R_body_from_ecef, A, e, x_s, y_s = _random_geometry(n_ep=5)
    for length in (0.05, 0.3):
        mount = AntennaMount(ShortDipole(length), np.eye(3))
        d = delta_rad(mount, R_body_from_ecef, e, x_s, y_s)
        spun = R_body_from_ecef.copy()
        spun = np.swapaxes(rotation_matrix(np.array([0.9, 0, 0])), -1, -2) @ R_body_from_ecef
        assert np.max(np.abs(np.angle(np.exp(1j * (delta_rad(mount, spun, e, x_s, y_s) - d))))) < 1e-12
    k = -e
    axis = A[:, None, :, 0] - k * np.sum(k * A[:, None, :, 0], -1)[..., None]
    from gnssatt.vector_phase.transmitter import polarisation_ecef
    u, v = polarisation_ecef(k, x_s, y_s)
    expected = np.arctan2(np.sum(axis * v, -1), np.sum(axis * u, -1))
    assert np.max(np.abs(np.angle(np.exp(1j * (d - expected))))) < 1e-12


def test_table_reproduces_the_model_it_was_sampled_from():
    ant = AsymmetricPatch(asymmetry=0.4, harmonic=2, phase_deg=20.0)
    table = table_of(ant, theta_step_deg=1.0, phi_step_deg=1.0, theta_max_deg=100.0)
    rng = np.random.default_rng(0)
    s = rng.normal(size=(500, 3))
    s[:, 2] = np.abs(s[:, 2])
    s /= np.linalg.norm(s, axis=-1, keepdims=True)
    exact = h_cartesian_antenna(ant, s)
    interp = h_cartesian_antenna(table, s)
    # bilinear on a 1 deg grid: the phase of h off by (1 deg)^2 / 8 * curvature ~ 1e-4 rad, 2e-5 cycles
    phase_err = np.angle(np.sum(interp * np.conj(exact), -1)) / (2 * np.pi)
    assert np.max(np.abs(phase_err)) < 1e-4
    assert np.max(np.abs(interp - exact)) < 1e-3 * ant.length_m


def test_rhcp_is_single_valued_at_the_boresight():
    near = np.array([[1e-9, 0, 1.0], [0, 1e-9, 1.0], [-1e-9, 0, 1.0]])
    h = h_cartesian_antenna(RhcpPatch(), near / np.linalg.norm(near, axis=-1, keepdims=True))
    assert np.max(np.abs(h - h[0])) < 1e-9


def test_eq26_matrix_is_a_rotation_with_the_papers_third_row():
    a, b, g = 0.3, 1.1, -0.7
    D = D_eq26(a, b, g)
    assert np.allclose(D @ D.T, np.eye(3), atol=1e-14) and abs(np.linalg.det(D) - 1) < 1e-14
    assert np.allclose(D[2], [np.sin(b) * np.cos(a), np.sin(b) * np.sin(a), np.cos(b)], atol=1e-15)
    # z-y-z: D = Rz(g) Ry(b) Rz(a) as frame rotations
    from gnssatt.gnss.rotations import Ry, Rz
    assert np.allclose(D, Rz(g) @ Ry(b) @ Rz(a), atol=1e-14)


def test_pattern_file_round_trip_and_errors():
    import pytest

    from gnssatt.gnss.io.errors import ParseError
    from gnssatt.vector_phase.pattern_file import antenna_pattern_doc, parse_antenna_pattern

    table = table_of(AsymmetricPatch(), theta_step_deg=10.0, phi_step_deg=30.0, theta_max_deg=90.0)
    back = parse_antenna_pattern(antenna_pattern_doc(table))
    assert np.max(np.abs(back.h_theta_m - table.h_theta_m)) < 1e-11
    assert parse_antenna_pattern('{"model": "short-dipole"}').name == "short-dipole"
    with pytest.raises(ParseError) as err:
        parse_antenna_pattern('{"model": "table",\n "theta_deg": [0, 90,]}', name="pat.json")
    assert err.value.line_no == 2 and "pat.json, line 2" in str(err.value)
    with pytest.raises(ParseError, match='"model" one of'):
        parse_antenna_pattern('{"model": "helix"}')
    with pytest.raises(ParseError, match="uniform grid covering 360"):
        parse_antenna_pattern({"model": "table", "theta_deg": [0, 90], "phi_deg": [0, 100, 200],
                               "h_theta_m": [[[1, 0]] * 3] * 2, "h_phi_m": [[[0, 1]] * 3] * 2})
