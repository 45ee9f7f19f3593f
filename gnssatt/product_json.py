"""The text of a JSON product (summary.json, calibration and TTFF documents) as the service stores it and the
library writes it: two-space indent, keys in insertion order, a final newline; numpy scalars and arrays as JSON
numbers and lists, paths as strings. One function for both, so a local run's products equal the service's bytes.

Implements: RFC 8259 JSON via the standard library's json.dumps.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["product_json", "json_default"]


def json_default(value: Any):
    """json.dumps `default`: numpy scalars and arrays (anything with .tolist()) and paths; otherwise TypeError."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def product_json(content: Any) -> str:
    """The product text of `content` (dict or list)."""
    return json.dumps(content, indent=2, sort_keys=False, default=json_default) + "\n"
