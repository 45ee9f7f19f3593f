"""The spacecraft path of the vector-phase job: a platform.json of kind "spacecraft" gives Euler angles relative to
the orbital frame of CONVENTIONS.md "Frames" (z_o = -r/|r|, y_o = -(r x v)/|r x v|, x_o = y_o x z_o, with the
inertial velocity v = v_ecef + omega_E x r), 3-2-1 as R_body_from_orbital = Rx(roll) Ry(pitch) Rz(yaw).
The antenna here is static in ECEF (a spacecraft on the ground, under test), so v = omega_E x r: x_o points east,
z_o to the geocentre; the frame is rebuilt below from those formulas, not from the library's."""
import csv
import io
import json

import numpy as np

from gnssatt.gnss.rotations import quat_to_dcm
from gnssatt.sim.vector_phase_set import write_vector_phase_set
from gnssatt.vector_phase.antenna import AsymmetricPatch
from gnssatt.vector_phase.scenario import ScenarioSpec
from worker.local import local_set, run_job_locally

OMEGA_E_RAD_S = 7.2921151467e-5


def _orbital_from_ecef(r_ecef_m: np.ndarray) -> np.ndarray:
    """CONVENTIONS.md orbital frame (rows x_o, y_o, z_o in ECEF) of a point fixed in ECEF."""
    v = np.cross([0.0, 0.0, OMEGA_E_RAD_S], r_ecef_m)
    z = -r_ecef_m / np.linalg.norm(r_ecef_m)
    y = -np.cross(r_ecef_m, v) / np.linalg.norm(np.cross(r_ecef_m, v))
    return np.array([np.cross(y, z), y, z])


def _euler321_deg(R_body_from_ref: np.ndarray) -> np.ndarray:
    """(yaw, pitch, roll) of R = Rx(roll) Ry(pitch) Rz(yaw) (frame rotations): R[0] = (cp cy, cp sy, -sp)."""
    R = R_body_from_ref
    return np.degrees([np.arctan2(R[0, 1], R[0, 0]), -np.arcsin(R[0, 2]), np.arctan2(R[1, 2], R[2, 2])])


def _wrap(d):
    return (np.asarray(d) + 180.0) % 360.0 - 180.0


def test_spacecraft_platform_reports_angles_in_the_orbital_frame(tmp_path):
    paths, obs, truth, mount = write_vector_phase_set(tmp_path / "set", ScenarioSpec(
        AsymmetricPatch(), n_epochs=20, n_sats=8, sigma_phase_cyc=5e-3))
    plat = next(p for p in paths if p.name == "platform.json")
    doc = json.loads(plat.read_text())
    doc["kind"] = "spacecraft"
    plat.write_text(json.dumps(doc))
    config = {"method": "vector-phase", "vector_phase": {"initial_position_ecef_m": truth.position_ecef_m.tolist(),
                                                         "sigma_phase_mm": 0.951}}
    out = run_job_locally("single-antenna-attitude", [local_set(paths, "sc")], config, tmp_path / "out",
                          progress=None)
    rows = list(csv.DictReader(io.StringIO(out["attitude.csv"].read_text())))
    assert len(rows) == 20
    R_orb = _orbital_from_ecef(truth.position_ecef_m)
    assert np.degrees(np.arccos(R_orb[0] @ truth.R_ned_from_ecef[1])) < 1e-6     # x_o is east, as it should be
    for k, row in enumerate(rows):
        R_be = quat_to_dcm(np.array([float(row[c]) for c in ("qe_w", "qe_x", "qe_y", "qe_z")]))
        written = np.array([float(row[c]) for c in ("yaw_deg", "pitch_deg", "roll_deg")])
        # the written angles are the written quaternion's, relative to the orbital frame: the 1e-5 deg of the
        # CSV's 5 decimals plus the estimated position's mm (through the frame's r) bound the difference
        assert np.abs(_wrap(written - _euler321_deg(R_be @ R_orb.T))).max() < 1e-4
        true = _euler321_deg(truth.R_body_from_ecef[k] @ R_orb.T)
        sigma = np.array([float(row[c]) for c in ("sigma_yaw_deg", "sigma_pitch_deg", "sigma_roll_deg")])
        # 1 mm phase noise, 8 satellites: degrees of error, a few sigma at most at a single epoch
        assert np.all(np.abs(_wrap(written - true)) < 5.0 * sigma + 1e-3), (k, written, true, sigma)
    # relative to NED (the terrestrial frame) the same attitude has a yaw ~90 deg away: the orbital frame was used
    yaw_ned = _euler321_deg(truth.R_body_from_ecef[5] @ truth.R_ned_from_ecef.T)[0]
    assert abs(_wrap(float(rows[5]["yaw_deg"]) - yaw_ned)) > 45.0
    comp = json.loads(out["summary.json"].read_text())["reference_comparison"]
    for angle in ("yaw", "pitch", "roll"):
        assert comp[angle]["rms_error_deg"] < 10.0 and comp[angle]["rms_error_over_sigma"] < 2.0
