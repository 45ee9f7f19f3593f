"""ORBEX attitude records: round trip, an independent reader written here from the ORBEX 0.09 description
(docs/formats/orbex.md), and bad input."""
import numpy as np
import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.rotations import dcm_to_quat
from gnssatt.gnss.time import GpsTime
from gnssatt.satyaw.attitude_models import R_ecef_from_body
from gnssatt.satyaw.orbex import OrbexAttitude, parse_orbex, read_orbex, write_orbex


def _hamilton(p, q):
    """Hamilton product p q of scalar-first quaternions (independent of gnssatt.gnss.rotations)."""
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _independent_reader(text):
    """Reads ORBEX as its description says: '##' epoch lines 'yyyy mm dd hh mm ss n', then n records
    ' ATT ID N q0 q1 q2 q3' inside +EPHEMERIS/DATA; returns [(iso, id, q)]."""
    out, inside, epoch = [], False, None
    for line in text.splitlines():
        if line.startswith("+EPHEMERIS/DATA"):
            inside = True
        elif line.startswith("-EPHEMERIS/DATA"):
            inside = False
        elif inside and line.startswith("##"):
            f = line.split()
            epoch = "%s-%s-%sT%s:%s:%06.3f" % (f[1], f[2], f[3], f[4], f[5], float(f[6]))
        elif inside and line.startswith(" ATT"):
            f = line.split()
            assert f[2] == "4"
            out.append((epoch, f[1], np.array([float(v) for v in f[3:7]])))
    return out


def _attitudes():
    rng = np.random.default_rng(7)
    n = 6
    # orbital frames and yaws -> R_ecef_from_body -> gnssatt q_body_from_ecef
    A = rng.normal(size=(n, 3, 3))
    R_o = np.linalg.qr(A)[0].transpose(0, 2, 1)
    R_o *= np.sign(np.linalg.det(R_o))[:, None, None]
    yaw = rng.uniform(-180, 180, n)
    R_eb = R_ecef_from_body(R_o, yaw)
    q = dcm_to_quat(np.swapaxes(R_eb, -1, -2))
    t = GpsTime.from_calendar(2021, 9, 22, 6, 30, 0.0)
    times = GpsTime(t.s + np.repeat([0, 30, 60], 2), np.zeros(6))
    return OrbexAttitude(times, np.array(["J01", "J02"] * 3), q), R_eb


def test_round_trip_and_independent_reader(tmp_path):
    att, R_eb = _attitudes()
    text = write_orbex(tmp_path / "yaw.obx", att)
    back = read_orbex(tmp_path / "yaw.obx")
    assert list(back.sat) == list(att.sat)
    assert np.all(back.time.s == att.time.s)
    # %19.16f keeps 16 decimals: the quaternions agree to 1e-15
    np.testing.assert_allclose(back.q_body_from_ecef, att.q_body_from_ecef, atol=1e-15)
    assert back.header["FRAME_TYPE"] == "ECEF" and back.header["TIME_SYSTEM"] == "GPS"
    recs = _independent_reader(text)
    assert [r[1] for r in recs] == list(att.sat)
    assert recs[2][0] == "2021-09-22T06:30:30.000"
    for k, (_, _, q) in enumerate(recs):
        # (0,B) = q (0,T) q^-1 takes the body axes, written in ECEF, to the unit vectors
        for axis in range(3):
            v_t = np.concatenate(([0.0], R_eb[k][:, axis]))
            v_b = _hamilton(_hamilton(q, v_t), q * [1, -1, -1, -1])
            np.testing.assert_allclose(v_b[1:], np.eye(3)[axis], atol=1e-12)


def test_bad_records_name_file_and_line(tmp_path):
    att, _ = _attitudes()
    text = write_orbex(tmp_path / "yaw.obx", att)
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith(" ATT"))
    broken = "\n".join(lines[:k] + [lines[k].replace("J01", "J01 x")] + lines[k + 1:])
    with pytest.raises(ParseError, match=rf"bad.obx, line {k + 1}"):
        parse_orbex(broken, "bad.obx")
    short = "\n".join(lines[:k] + lines[k + 1:])          # the epoch announces 2 records, 1 follows
    with pytest.raises(ParseError, match="more record"):
        parse_orbex(short, "short.obx")
    with pytest.raises(ParseError, match="ORBEX"):
        parse_orbex("hello\n", "x.obx")
