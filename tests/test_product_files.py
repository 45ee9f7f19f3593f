"""gnssatt.product_files: the one encoder of products (library write_products and the worker's JobContext)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gnssatt.product_files import json_default, product_json


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


def test_the_text_is_json_dumps_indent_2_byte_for_byte():
    """product_json walks dicts/lists itself and hands flat number lists to the C encoder: the text must stay the
    standard library's json.dumps(indent=2) one for every shape a product has (the products' bytes are compared
    across versions, tests/test_bench_products_identity.py)."""
    rng = np.random.default_rng(3)
    cases = [{}, [], {"a": []}, {"a": {}}, [[1, 2], [3.5, None]], (1, 2, (3, [4, {}])),
             {"x": np.arange(3), "y": np.float64(0.1), "z": np.bool_(True), "p": Path("a/b")},
             {1: 2, "a": {2.5: "x", None: [1]}},
             {"s": "é\"\\\n\t", "n": [float("nan"), float("inf"), -float("inf"), True, False, None, 1e300, -0.0]},
             {"a": [{"b": [1.0] * 3, "c": "x"}, [], [[]]]}, "text", 5, None, [True, 1], [np.int64(3), np.float32(0.25)],
             {"chart": {"x": rng.normal(size=500).tolist(), "fixed": rng.integers(0, 2, 500).tolist(),
                        "series": [{"values": (rng.normal(size=500) * 10.0 ** rng.integers(-12, 12, 500)).tolist()}]}},
             {"k": np.array([[1.5, 2.0], [3.0, 4.0]])}]
    for case in cases:
        assert product_json(case) == json.dumps(case, indent=2, default=json_default) + "\n", case
