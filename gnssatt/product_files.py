"""Product files as the service stores them (worker.context.JobContext.write_product): a dict or list as JSON
(indent 2, keys in insertion order, numpy values as Python numbers, a final newline), text as UTF-8, bytes as
they are. The library's `write_products` of each capability writes through here, so a product written without a
server has the bytes of the service's."""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping

__all__ = ["product_bytes", "write_product_files"]


def _json_default(value: Any):
    """numpy scalars and arrays and paths, as the worker's JobContext.write_product writes them."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def product_bytes(content: str | bytes | dict | list) -> bytes:
    """The bytes of one product (see the module docstring)."""
    if isinstance(content, (dict, list)):
        content = json.dumps(content, indent=2, sort_keys=False, default=_json_default) + "\n"
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
