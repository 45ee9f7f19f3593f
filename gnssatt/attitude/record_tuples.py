"""Keyword builders of the compiled kernels' records (gnssatt.attitude.qc_records, update_records): a function
taking a NamedTuple layout's fields by keyword only (all of them, no others) and returning them as a plain tuple in
field order, what tuple(Record(...)) gives at a third to a fifth of the cost (no namedtuple in between). Numba
types a plain tuple of arrays by its C fingerprint, a namedtuple through Python, so the kernels take plain tuples.

Implements: the generation of collections.namedtuple's __new__ from `_fields` (so the builder cannot disagree with
the layout); bench/design/qc_record_calls.py times the choices.
"""
from __future__ import annotations

from typing import Callable

__all__ = ["plain_tuple_builder"]


def plain_tuple_builder(record: type, name: str | None = None) -> Callable[..., tuple]:
    """f(*, field_1, ..., field_n) -> (field_1, ..., field_n) for `record`'s _fields; `name` names the function
    (default: the record's name in snake case)."""
    fields = record._fields
    name = name or "".join("_" + c.lower() if c.isupper() else c for c in record.__name__).lstrip("_")
    namespace: dict = {}
    exec(f"def {name}(*, {', '.join(fields)}):\n    return ({', '.join(fields)},)\n", namespace)  # noqa: S102
    fn = namespace[name]
    fn.__module__ = record.__module__
    fn.__doc__ = (f"The plain tuple of a {record.__name__} ({', '.join(fields)}), fields by keyword, as the kernels "
                  "take it.")
    return fn
