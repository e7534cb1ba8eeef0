"""Calibration measurements as CSV."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.errors import CalibrationError
from kinematics.io.measurements import parse_measurements_csv

JOINTS = ("a", "b")


def test_columns_by_name_in_any_order_and_poses():
    text = "# comment\nb,a,x,y,z,qw,qx,qy,qz\n\n0.2,0.1,1,2,3,0,1,0,0\n"
    m = parse_measurements_csv(text, JOINTS)
    assert m.q.tolist() == [[0.1, 0.2]] and m.positions is None
    assert np.allclose(m.poses[0], [[1, 0, 0, 1], [0, -1, 0, 2], [0, 0, -1, 3], [0, 0, 0, 1]])


@pytest.mark.parametrize("text,match", [
    ("a,x,y,z\n1,2,3,4\n", "lacks the joint column"),
    ("a,b,x,y\n1,2,3,4\n", "x,y,z"),
    ("a,b,z,y,x\n1,2,3,4,5\n", "x,y,z"),
    ("a,b,x,y,z\n1,2,3,4\n", "row 1: 4 values"),
    ("a,b,x,y,z\n1,2,3,4,oops\n", "row 1: a value that is not a number"),
    ("a,a,x,y,z\n1,2,3,4,5\n", "repeats"),
    ("a,b,x,y,z,qw,qx,qy,qz\n0,0,1,2,3,2,0,0,0\n", "unit norm"),
    ("a,b,x,y,z\n", "no row"),
    ("", "empty"),
])
def test_bad_csv_is_refused_naming_the_problem(text, match):
    with pytest.raises(CalibrationError, match=match):
        parse_measurements_csv(text, JOINTS)
