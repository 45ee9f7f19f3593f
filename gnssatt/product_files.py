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
    """The text of a JSON product: json.dumps(content, indent=2, default=json_default) + a newline, byte for byte.
    With an indent the standard library encodes in Python, ~2 us per number; `_indented` walks the dicts and lists
    itself and hands each flat list of numbers to the C encoder (the job page's charts.json of a 106-min pass:
    ~5e5 numbers, 0.12 -> ~0.03 s CPU)."""
    return "".join(_indented(content, "\n")) + "\n"


#: element types of a list the C encoder writes as json.dumps(indent=2) would, once re-indented (numbers, null)
_FLAT_TYPES = frozenset((float, int, type(None)))
_COMPACT = json.JSONEncoder(separators=(",", ":"))     # no indent: the C encoder (same float/int texts)


def _indented(o: Any, nl: str) -> list[str]:
    """Pieces of the indent=2 JSON text of o at the nesting whose line break + indent is nl; what json's
    _iterencode gives: str, None, bool, int, float leaves as JSON writes them, list/tuple and dict (str keys, in
    order) one item per line, anything else through json_default. Dicts with other keys: json.dumps itself."""
    if isinstance(o, (str, int, float)) or o is None:      # bool is an int
        return [json.dumps(o)]
    if isinstance(o, (list, tuple)):
        if not o:
            return ["[]"]
        inner = nl + "  "
        if set(map(type, o)) <= _FLAT_TYPES:
            return ["[", inner, _COMPACT.encode(o)[1:-1].replace(",", "," + inner), nl, "]"]
        out = ["["]
        for i, v in enumerate(o):
            out.append(inner if i == 0 else "," + inner)
            out += _indented(v, inner)
        out += [nl, "]"]
        return out
    if isinstance(o, dict):
        if not o:
            return ["{}"]
        if not all(type(k) is str for k in o):
            return [json.dumps(o, indent=2, default=json_default).replace("\n", nl)]
        inner = nl + "  "
        out = ["{"]
        for i, (k, v) in enumerate(o.items()):
            out += [inner if i == 0 else "," + inner, json.dumps(k), ": "]
            out += _indented(v, inner)
        out += [nl, "}"]
        return out
    return _indented(json_default(o), nl)


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
