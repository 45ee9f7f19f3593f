"""gnssatt.product_files: the one encoder of products (library write_products and the worker's JobContext)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gnssatt.product_files import product_json


def test_numpy_values_and_paths_become_json():
    text = product_json({"n": np.int64(3), "x": np.float64(0.5), "ok": np.bool_(True), "a": np.arange(3),
                         "p": Path("obs/a.rnx"), "nested": [{"v": np.float32(0.25)}]})
    assert text.endswith("}\n") and text.startswith('{\n  "n": 3,')
    assert json.loads(text) == {"n": 3, "x": 0.5, "ok": True, "a": [0, 1, 2], "p": "obs/a.rnx",
                                "nested": [{"v": 0.25}]}


def test_keys_keep_their_order():
    assert list(json.loads(product_json({"b": 1, "a": 2}))) == ["b", "a"]


def test_other_objects_are_refused_by_name():
    with pytest.raises(TypeError, match="object"):
        product_json({"x": object()})


def test_the_worker_writes_json_products_with_it(tmp_path):
    from worker.context import JobContext

    stored = {}

    def store(path):
        stored["bytes"] = Path(path).read_bytes()
        return "h", len(stored["bytes"])

    ctx = JobContext(job_id="j", attempt=1, sets=[], workdir=tmp_path, _store_blob=store)
    doc = {"x": np.float64(1.5), "a": np.arange(2)}
    ctx.write_product("summary.json", doc)
    assert stored["bytes"] == product_json(doc).encode()
