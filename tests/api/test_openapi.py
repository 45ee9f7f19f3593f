"""openapi/openapi.json is the spec the app serves; regenerate it with `make openapi`."""
from __future__ import annotations

import json

from tests.conftest import REPO_ROOT


def test_committed_spec_matches_served_spec(api):
    served = api.get("/openapi.json").json()
    committed = json.loads((REPO_ROOT / "openapi" / "openapi.json").read_text())
    assert served == committed, "openapi/openapi.json is stale: run `make openapi` and commit it"


def test_every_error_is_documented_as_problem_json(api):
    spec = api.get("/openapi.json").json()
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            for code, resp in op["responses"].items():
                if code[0] in "45":
                    assert list(resp["content"]) == ["application/problem+json"], (method, path, code)
            if path.startswith("/v1"):
                assert "401" in op["responses"], (method, path)


def test_wrong_method_answers_405_with_allow(api):
    resp = api.put("/v1/jobs")
    assert resp.status_code == 405 and resp.headers["allow"] == "GET, POST"
    assert resp.headers["content-type"].startswith("application/problem+json")
