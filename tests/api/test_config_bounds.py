"""Every number a job config takes is bounded, and the bound is in the schema the API serves; the probe's
simulate/ttff overrides (duration_s 1e9, count 1e6) are refused at submit; NaN/Infinity, wrong types in
calibrated_baselines and over-long names are 422, on every database alike (issue 22, defects 4 and 10)."""
from __future__ import annotations

import pytest

from tests.api.test_observation_sets import _files, sample_items


def _unbounded(schema: dict, defs: dict, path: str, out: list) -> None:
    if "$ref" in schema:
        _unbounded(defs[schema["$ref"].split("/")[-1]], defs, path, out)
        return
    for key in ("anyOf", "oneOf", "allOf"):
        for sub in schema.get(key, []):
            _unbounded(sub, defs, path, out)
    if schema.get("type") in ("number", "integer"):
        if not ({"minimum", "exclusiveMinimum"} & set(schema) and {"maximum", "exclusiveMaximum"} & set(schema)):
            out.append(path)
    for name, sub in schema.get("properties", {}).items():
        _unbounded(sub, defs, f"{path}.{name}", out)
    if isinstance(schema.get("items"), dict):
        _unbounded(schema["items"], defs, f"{path}[]", out)
    if isinstance(schema.get("additionalProperties"), dict):
        _unbounded(schema["additionalProperties"], defs, f"{path}{{}}", out)


def test_every_numeric_config_field_of_every_job_type_is_bounded_in_the_schema(api):
    types = api.get("/v1/job-types").json()
    assert len(types) >= 6
    missing = []
    for jt in types:
        schema = jt["config_schema"]
        _unbounded(schema, schema.get("$defs", {}), jt["name"], missing)
    assert not missing, f"numbers without a minimum and maximum in the served schema: {missing}"


@pytest.mark.parametrize("config", [
    {"type": "simulate", "config": {"overrides": {"duration_s": 1e9}}},
    {"type": "simulate", "config": {"overrides": {"count": 1000000}}},
    {"type": "simulate", "config": {"overrides": {"count": 100, "duration_s": 86400}}},   # 8.6 M epochs
    {"type": "simulate", "config": {"overrides": {"interval_s": 0.01, "duration_s": 86400}}},
    {"type": "simulate", "config": {"overrides": {"nav_file": "/etc/passwd"}}},
    {"type": "simulate", "config": {"overrides": {"vtec_tecu": 1e300}}},
    {"type": "simulate", "config": {"overrides": {"waypoints": [[0.0, 1.0, 2.0, 3.0]] * 5000}}},
    {"type": "ttff", "config": {"simulate": {"count": 1, "overrides": {"count": 1000000}}}},
    {"type": "ttff", "config": {"simulate": {"count": 1, "overrides": {"duration_s": 1e9}}}},
    {"type": "ttff", "config": {"simulate": {"count": 1000000}}},
    {"type": "selftest", "config": {"duration_s": 1e308}},
])
def test_oversized_configs_are_422_at_submit(api, config):
    resp = api.post("/v1/jobs", json=config)
    assert resp.status_code == 422, resp.text
    assert resp.json()["field"].startswith("config")
    assert api.get("/v1/jobs").json()["total"] == 0


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_422(api, literal):
    body = '{"type": "selftest", "config": {"duration_s": %s}}' % literal
    resp = api.post("/v1/jobs", content=body.encode(), headers={"Content-Type": "application/json"})
    assert resp.status_code == 422, resp.text
    body = '{"type": "selftest", "config": {"extra": {"deep": [1, %s]}}}' % literal
    resp = api.post("/v1/jobs", content=body.encode(), headers={"Content-Type": "application/json"})
    assert resp.status_code == 422 and "finite" in resp.text, resp.text


@pytest.mark.parametrize("cal", [
    {"baselines": [{"from": "GPS-2", "to": "GPS-0", "calibrated_m": "abc"}]},
    {"baselines": [{"from": "GPS-2", "to": "GPS-0", "calibrated_m": [1.0, 0.0]}]},
    {"baselines": [{"from": "GPS-2", "to": "GPS-0", "calibrated_m": [1e308, 0.0, 0.0]}]},
    {"baselines": [{"from": ["GPS-2"], "to": "GPS-0", "calibrated_m": [1.0, 0.0, 0.0]}]},
    {"baselines": "GPS-2>GPS-0"},
    {"baselines": []},
])
def test_wrong_types_in_calibrated_baselines_are_422(api, cal):
    set_id = api.post("/v1/observation-sets", files=_files(*sample_items(5))).json()["id"]
    resp = api.post("/v1/jobs", json={"type": "attitude", "observation_set_ids": [set_id],
                                      "config": {"calibrated_baselines": cal}})
    assert resp.status_code == 422, resp.text
    assert resp.json()["field"].startswith("config.calibrated_baselines")


def test_names_longer_than_their_columns_are_422(api):
    items = sample_items(5)
    resp = api.post("/v1/observation-sets", files=_files(*items), data={"name": "n" * 301})
    assert resp.status_code == 422 and resp.json()["field"] == "name"
    resp = api.post("/v1/observation-sets", files=_files(*items[1:], ("G" * 501 + ".rnx", items[0][1])))
    assert resp.status_code == 422 and resp.json()["type"].endswith("/name-too-long")
    assert api.get("/v1/observation-sets").json()["total"] == 0
