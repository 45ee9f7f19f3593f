"""The gyro CSV reader (docs/formats/gyro_csv.md; the one sensor-log reader, kind "gyro"): round trip, and every
malformed line refused with its line, column, what was expected and what was found."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.time import GpsTime
from gnssatt.gyro.gyro_csv import gyro_csv_text, is_gyro_header, read_gyro_csv

HEAD = "time_gps,wx_rad_s,wy_rad_s,wz_rad_s,temperature_c"
ROW1 = "2018-06-06T12:20:00.100,1.0e-3,-2.0e-5,3.1e-6,20.5"
ROW2 = "2018-06-06T12:20:00.200,1.1e-3,-2.1e-5,3.2e-6,20.5"


def test_round_trip_of_written_log():
    t = GpsTime.from_iso("2018-06-06T12:20:00") + np.arange(1, 51) * 0.1
    w = np.random.default_rng(1).normal(0, 1e-3, (50, 3))
    log = read_gyro_csv(gyro_csv_text(t, w, np.full(50, 21.0)), "g.csv")
    # the writer keeps 13 significant digits: 1e-15 rad/s relative is far below any gyro's resolution
    assert np.allclose(log.rate_rad_s, w, rtol=1e-11, atol=1e-18)
    assert np.allclose(log.time - t, 0.0, atol=1e-6)       # 1 ms text resolution, on the 0.1 s grid exactly
    assert log.temperature_c is not None and np.all(log.temperature_c == 21.0)
    assert log.interval_s == pytest.approx(0.1, abs=1e-9)


def test_week_sow_columns_and_optional_temperature():
    text = "gps_week,gps_sow,wx_rad_s,wy_rad_s,wz_rad_s\n2000,100.0,0,0,1e-3\n2000,100.5,0,0,2e-3\n"
    log = read_gyro_csv(text)
    assert log.temperature_c is None
    assert log.time[1] - log.time[0] == pytest.approx(0.5)
    assert is_gyro_header("time_gps, wx_rad_s, wy_rad_s, wz_rad_s") and not is_gyro_header("time_gps,frame,qw")


@pytest.mark.parametrize("line, column, words", [
    ("2018-06-06T12:20:00.300,1.0e-3,abc,3.1e-6,20.5", 32, "'wy_rad_s'"),
    ("2018-06-06T25:20:00.300,1.0e-3,0,3.1e-6,20.5", 1, "time_gps as ISO 8601"),
    ("12:20:00.300,1.0e-3,0,3.1e-6,20.5", 1, "time_gps as ISO 8601"),
    ("2018-06-06T12:20:00.300,1.0e-3,0,3.1e-6", 40, "5 comma-separated"),
    ("2018-06-06T12:20:00.300,1.0e-3,0,3.1e-6,20.5,7", 46, "5 comma-separated"),
    ("2018-06-06T12:20:00.300,1.0e-3,0,nan,20.5", 34, "'wz_rad_s'"),
    ("2018-06-06T12:20:00.300,,0,0,20.5", 25, "'wx_rad_s'"),
    ("2018-06-06T12:20:00.300,57.3,0,0,20.5", 25, "deg/s"),
    ("2018-06-06T12:20:00.150,1.0e-3,0,0,20.5", 1, "increasing order"),
    ("2018-06-06T12:20:00.200,1.0e-3,0,0,20.5", 1, "duplicate time"),
    ("2018-06-06T12:20:00.300,1.0e-3,0,0,hot", 36, "'temperature_c'"),
], ids=["bad-rate", "hour-25", "no-date", "short-row", "long-row", "nan-rate", "empty-rate", "deg-per-s",
        "time-order", "duplicate-time", "bad-temperature"])
def test_malformed_line_names_line_column_expected_and_found(line, column, words):
    with pytest.raises(ParseError) as e:
        read_gyro_csv("\n".join([HEAD, ROW1, ROW2, line]) + "\n", "gyro.csv")
    err = e.value
    assert (err.path, err.line_no, err.column) == ("gyro.csv", 4, column)
    assert words in err.expected
    assert err.found == line
    assert "gyro.csv, line 4, column" in str(err)


def test_week_sow_malformed():
    head = "gps_week,gps_sow,wx_rad_s,wy_rad_s,wz_rad_s\n2000,100.0,0,0,1e-3\n"
    for row, words in [("-1,100.5,0,0,0", "non-negative"), ("2000,604800,0,0,0", "[0, 604800)")]:
        with pytest.raises(ParseError) as e:
            read_gyro_csv(head + row + "\n")
        assert e.value.line_no == 3 and words in e.value.expected, row


def test_bad_header_and_empty_file():
    with pytest.raises(ParseError) as e:
        read_gyro_csv("time_gps,wx,wy,wz\n" + ROW1)
    assert (e.value.line_no, e.value.column) == (1, 10) and "'wx_rad_s'" in e.value.expected
    with pytest.raises(ParseError) as e:
        read_gyro_csv("time_gps,wx_rad_s,wy_rad_s,wz_rad_s,humidity\n" + ROW1)
    assert (e.value.line_no, e.value.column) == (1, 37) and "temperature_c" in e.value.expected
    with pytest.raises(ParseError):
        read_gyro_csv("")
    with pytest.raises(ParseError) as e:
        read_gyro_csv(HEAD + "\n")
    assert "at least one data row" in e.value.expected
