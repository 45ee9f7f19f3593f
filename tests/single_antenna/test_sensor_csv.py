"""Sensor CSV readers: good files parse; bad ones name the file, line and column (CONVENTIONS.md sensor logs)."""
from __future__ import annotations

import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.sensor_csv import read_sensor_csv

ACC = ("time_gps,ax_m_s2,ay_m_s2,az_m_s2\n"
       "2013-04-01T10:00:00.000,0.1,0.2,-9.81\n"
       "2013-04-01T10:00:00.100,0.1,0.2,-9.80\n"
       "2013-04-01T10:00:00.200,0.1,0.3,-9.79\n")
MAG = ("gps_week,gps_sow,bx_nT,by_nT,bz_nT,temperature_c\n"
       "1734,122400.0,20000,1000,43000,21.5\n"
       "1734,122400.1,20025,1000,43000,21.5\n")


def test_good_files_parse():
    a = read_sensor_csv(ACC.encode(), "accelerometer", "acc.csv")
    assert a.values.shape == (3, 3) and abs(a.t_s[-1] - 0.2) < 1e-9 and a.values[2, 2] == -9.79
    assert list(a.line_no) == [2, 3, 4]
    m = read_sensor_csv(MAG.encode(), "magnetometer", "mag.csv")
    assert m.extra["temperature_c"].tolist() == [21.5, 21.5] and abs(m.t_s[1] - 0.1) < 1e-9


def _err(text, kind="accelerometer"):
    with pytest.raises(ParseError) as info:
        read_sensor_csv(text.encode(), kind, "bad.csv")
    e = info.value
    assert e.path == "bad.csv" and "bad.csv" in str(e)
    return e


@pytest.mark.parametrize("text,kind,line,column,words", [
    # wrong columns: a unit-less name, a swapped order, an unknown extra column
    ("time_gps,ax,ay,az\n2013-04-01T10:00:00,0,0,9.8\n", "accelerometer", 1, 10, "ax_m_s2"),
    ("time_gps,ay_m_s2,ax_m_s2,az_m_s2\n", "accelerometer", 1, 10, "ax_m_s2"),
    ("time_gps,ax_m_s2,ay_m_s2,az_m_s2,speed\n", "accelerometer", 1, 34, "optional"),
    ("t,ax_m_s2,ay_m_s2,az_m_s2\n", "accelerometer", 1, 1, "header"),
    # unsorted and duplicate times
    (ACC + "2013-04-01T10:00:00.150,0.1,0.2,-9.8\n", "accelerometer", 5, 1, "increasing"),
    (ACC + "2013-04-01T10:00:00.200,0.1,0.2,-9.8\n", "accelerometer", 5, 1, "duplicate"),
    # NaN, a word, a missing field
    (ACC + "2013-04-01T10:00:00.300,0.1,NaN,-9.8\n", "accelerometer", 5, 29, "finite number in column 'ay_m_s2'"),
    (ACC + "2013-04-01T10:00:00.300,0.1,abc,-9.8\n", "accelerometer", 5, 29, "finite number"),
    (ACC + "2013-04-01T10:00:00.300,0.1,0.2\n", "accelerometer", 5, 32, "4 comma-separated fields"),
    (ACC + "2013/04/01 10:00,0.1,0.2,9.8\n", "accelerometer", 5, 1, "ISO 8601"),
    # wrong units by orders of magnitude: milli-g, micro-tesla, pico-tesla, deg/s, cm/s
    (ACC + "2013-04-01T10:00:00.300,0.1,0.2,-1000.0\n", "accelerometer", 5, 33, "mg or cm/s^2"),
    ("time_gps,bx_nT,by_nT,bz_nT\n2013-04-01T10:00:00,20.0,1.0,43.0\n", "magnetometer", 2, 30, "uT, gauss"),
    ("time_gps,bx_nT,by_nT,bz_nT\n2013-04-01T10:00:00,2e7,1e6,4.3e7\n", "magnetometer", 2, 29, "pT"),
    ("time_gps,wx_rad_s,wy_rad_s,wz_rad_s\n2013-04-01T10:00:00,0,0,45.0\n", "gyro", 2, 25, "deg/s"),
    ("time_gps,vx_ecef_m_s,vy_ecef_m_s,vz_ecef_m_s\n2013-04-01T10:00:00,15000,200,100\n", "velocity", 2, 21,
     "cm/s"),
    ("", "accelerometer", 1, 1, "header"),
    ("time_gps,ax_m_s2,ay_m_s2,az_m_s2\n", "accelerometer", 2, 1, "data rows"),
])
def test_bad_files_name_line_and_column(text, kind, line, column, words):
    e = _err(text, kind)
    assert (e.line_no, e.column) == (line, column), str(e)
    assert words in str(e)
