"""The upload sniffer tells every input kind of the job types apart by content (gnssatt.gnss.io.sniff.identify):
sensor logs by their columns (docs/formats/inertial_csv.md, gyro_csv.md), a reference attitude CSV otherwise
(CONVENTIONS.md), and the JSON inputs by their top-level keys (platform.json, stations.json, satellites.json,
antenna_pattern.json); a malformed one is refused naming the file."""
from __future__ import annotations

import json

import pytest

from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.sniff import identify

_T = ("2024-03-01T00:00:00.000", "2024-03-01T00:00:00.100", "2024-03-01T00:00:00.200")


def _csv(tmp_path, name, header, row):
    path = tmp_path / name
    path.write_text(header + "\n" + "".join(f"{t},{row}\n" for t in _T))
    return path


@pytest.mark.parametrize("kind, header, row", [
    ("accelerometer", "time_gps,ax_m_s2,ay_m_s2,az_m_s2", "0.1,0.2,9.81"),
    ("magnetometer", "time_gps,bx_nT,by_nT,bz_nT", "21000,-1500,43000"),
    ("gyro", "time_gps,wx_rad_s,wy_rad_s,wz_rad_s,temperature_c", "0.001,-0.002,0.0005,21.5"),
    ("velocity", "time_gps,vx_ecef_m_s,vy_ecef_m_s,vz_ecef_m_s", "10.0,-3.0,0.5"),
])
def test_sensor_logs_by_their_columns(tmp_path, kind, header, row):
    found, summary = identify(_csv(tmp_path, f"log_{kind}.csv", header, row), f"log_{kind}.csv")
    assert found == kind
    assert summary["rows"] == 3 and summary["time_first"].startswith("2024-03-01T00:00:00.000")
    assert summary["median_interval_s"] == pytest.approx(0.1, abs=1e-9)


def test_sensor_log_with_a_bad_value_names_file_and_line(tmp_path):
    path = tmp_path / "acc.csv"
    path.write_text("time_gps,ax_m_s2,ay_m_s2,az_m_s2\n" f"{_T[0]},0.1,0.2,9.81\n" f"{_T[1]},0.1,nan,9.81\n")
    with pytest.raises(ParseError) as err:
        identify(path, "acc.csv")
    assert err.value.path == "acc.csv" and err.value.line_no == 3


def test_reference_attitude_stays_what_it_was(tmp_path):
    path = tmp_path / "reference_attitude.csv"
    path.write_text("time_gps,frame,qw,qx,qy,qz\n" f"{_T[0]},GCRF,1,0,0,0\n" f"{_T[1]},GCRF,1,0,0,0\n")
    assert identify(path, "reference_attitude.csv")[0] == "reference_attitude"


def _json(tmp_path, name, doc):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_stations_json(tmp_path):
    doc = {"stations": {"3034": {"position_ecef_m": [-3857167.6, 3108694.9, 4004041.5]}}}
    kind, summary = identify(_json(tmp_path, "stations.json", doc), "stations.json")
    assert kind == "stations" and summary["stations"] == ["3034"]


def test_satellites_json(tmp_path):
    doc = {"satellites": {"J02": {"aux_antenna_m": [-1.2, 0.4, 1.3], "attitude_model": "orbit-normal"}}}
    kind, summary = identify(_json(tmp_path, "satellites.json", doc), "satellites.json")
    assert kind == "satellites" and summary["satellites"] == ["J02"]


def test_antenna_pattern_json(tmp_path):
    doc = {"model": "asymmetric-patch", "frequency": "L1", "asymmetry": 0.5, "harmonic": 2}
    assert identify(_json(tmp_path, "antenna_pattern.json", doc), "antenna_pattern.json")[0] == "antenna_pattern"


@pytest.mark.parametrize("name, doc", [
    ("stations.json", {"stations": {"X": {"position_ecef_m": [1.0, 2.0]}}}),
    ("satellites.json", {"satellites": {"J02": {"aux_antenna_m": "up"}}}),
    ("antenna_pattern.json", {"model": "horn"}),
])
def test_malformed_json_inputs_are_refused_naming_the_file(tmp_path, name, doc):
    with pytest.raises(ParseError) as err:
        identify(_json(tmp_path, name, doc), name)
    assert err.value.path == name


def test_platform_json_is_still_a_platform(tmp_path):
    from gnssatt.sim.sample_set import platform_doc

    kind, summary = identify(_json(tmp_path, "platform.json", platform_doc()), "platform.json")
    assert kind == "platform" and summary["format"] == "platform.json" and len(summary["antennas"]) == 3
