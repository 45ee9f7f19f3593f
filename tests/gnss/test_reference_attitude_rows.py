"""The reference attitude CSV's row checks (CONVENTIONS.md "Reference attitude"): a quaternion that is not unit
within NORM_TOLERANCE, or holds NaN / inf, is refused naming its line; a unit one passes unchanged."""
from __future__ import annotations

import math

import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.reference_attitude import NORM_TOLERANCE, read_reference_attitude

HEAD = "time_gps,frame,qw,qx,qy,qz,sigma_arcsec\n"
GOOD = "2018-06-06T12:20:00.000,GCRF,0.5,0.5,-0.5,0.5,3.0\n"


def test_a_unit_quaternion_passes_unchanged():
    ref = read_reference_attitude(HEAD + GOOD)
    assert ref.q_body_from_frame.tolist() == [[0.5, 0.5, -0.5, 0.5]] and ref.sigma_arcsec.tolist() == [3.0]


@pytest.mark.parametrize("q", [f"{1 + 3 * NORM_TOLERANCE},0,0,0", "nan,0,0,1", "1,0,0,inf", "1e200,0,0,0",
                               "0.5,0.5,0.5,0.5001"])
def test_a_quaternion_not_unit_or_not_finite_is_refused_with_its_line(q):
    with pytest.raises(ParseError) as err:
        read_reference_attitude(HEAD + GOOD + f"2018-06-06T12:20:01.000,GCRF,{q},3.0\n")
    assert err.value.line_no == 3 and "unit quaternion" in str(err.value)


def test_a_quaternion_within_the_tolerance_passes():
    w = math.sqrt(1.0 - 0.36) * (1 + 0.4 * NORM_TOLERANCE)
    ref = read_reference_attitude(HEAD + f"2018-06-06T12:20:00.000,ECEF,{w!r},0.6,0,0,\n")
    assert ref.frame.tolist() == ["ECEF"] and math.isnan(ref.sigma_arcsec[0])
