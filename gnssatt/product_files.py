"""Product files as the service stores them (worker.context.JobContext.write_product): a dict or list as JSON
(indent 2, keys in insertion order, numpy values as Python numbers, paths as strings, a final newline), text as
UTF-8, bytes as they are. The worker's JobContext and the library's `write_products` of each capability write
through here, so a product written without a server has the bytes of the service's.

Implements: RFC 8259 JSON via the standard library's json.dumps.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

__all__ = ["json_default", "product_json", "product_bytes", "write_product_files"]


def json_default(value: Any):
    """json.dumps `default`: numpy scalars and arrays (anything with .tolist()) and paths; otherwise TypeError."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def product_json(content: dict | list) -> str:
    """The text of a JSON product."""
    return json.dumps(content, indent=2, sort_keys=False, default=json_default) + "\n"


def product_bytes(content: str | bytes | dict | list) -> bytes:
    """The bytes of one product (see the module docstring)."""
    if isinstance(content, (dict, list)):
        content = product_json(content)
    return content.encode("utf-8") if isinstance(content, str) else bytes(content)


def write_product_files(products: Mapping[str, str | bytes | dict | list], out_dir: str | Path) -> dict[str, Path]:
    """Write each product (name -> content) into out_dir (created); returns product name -> path."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = {}
    for name, content in products.items():
        path = out_dir / name
        path.write_bytes(product_bytes(content))
        written[name] = path
    return written
