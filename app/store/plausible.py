"""Values a sniffer accepts but no real observation set has: refused at upload (422 naming file and field),
instead of failing later inside a job as an internal error.

- times: every time in a file's summary lies in GPS time's era, 1980-01-06 to 2200 (RINEX epoch seconds of
  1e18 would give a year of 31688740525);
- numbers: every number in a summary is finite;
- platform.json: antenna positions and boresights are finite, positions within 10 km of the body origin
  (a rigid platform's lever arms; CONVENTIONS.md), boresights not zero; its name and antenna ids fit the
  columns that keep them (so PostgreSQL, which refuses longer strings, and SQLite, which keeps them, agree).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path

from app.problems import ProblemError

MAX_LEVER_ARM_M = 10_000.0
MAX_PLATFORM_NAME = 300  # observation_sets.platform_name
MAX_ANTENNA_ID = 100  # as pcv_maps.first_antenna
FIRST_YEAR, LAST_YEAR = 1980, 2200
_ISO_YEAR = re.compile(r"^(-?\d+)-\d\d-\d\dT")


def _refuse(name: str, field: str, detail: str) -> ProblemError:
    return ProblemError(422, "implausible-value", f"{name}: implausible value",
                        f"{name}: {field} {detail}", file=name, field=field)


def _walk(value, path: str):
    if isinstance(value, dict):
        for k, v in value.items():
            yield from _walk(v, f"{path}.{k}" if path else str(k))
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from _walk(v, f"{path}.{i}")
    else:
        yield path, value


def check_plausible(kind: str, summary: dict, plain_path: Path, name: str) -> None:
    """Raise a 422 problem when the file's summary (or platform.json) holds an impossible value."""
    for field, value in _walk(summary, ""):
        if isinstance(value, float) and not math.isfinite(value):
            raise _refuse(name, field, f"is {value}; expected a finite number")
        if isinstance(value, str):
            match = _ISO_YEAR.match(value)
            if match and not FIRST_YEAR <= int(match.group(1)) <= LAST_YEAR:
                raise _refuse(name, field, f"is {value[:40]!r}; expected a GPS time between {FIRST_YEAR} "
                              f"and {LAST_YEAR} (an epoch's seconds field out of range?)")
    if kind == "platform":
        _check_platform(json.loads(plain_path.read_bytes()), name)


def _check_platform(doc: dict, name: str) -> None:
    if isinstance(doc.get("name"), str) and len(doc["name"]) > MAX_PLATFORM_NAME:
        raise _refuse(name, "name", f"has {len(doc['name'])} characters; at most {MAX_PLATFORM_NAME}")
    for antenna, spec in (doc.get("antennas") or {}).items():
        if len(antenna) > MAX_ANTENNA_ID:
            raise _refuse(name, "antennas", f"has an antenna id of {len(antenna)} characters; at most "
                          f"{MAX_ANTENNA_ID}")
        if not isinstance(spec, dict):
            continue
        for key, limit in (("position_m", MAX_LEVER_ARM_M), ("boresight", None)):
            vec = spec.get(key)
            if vec is None:
                continue
            field = f"antennas.{antenna}.{key}"
            if not isinstance(vec, list) or len(vec) != 3 or not all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in vec):
                raise _refuse(name, field, "must be a list of three numbers")
            if not all(math.isfinite(x) for x in vec):
                raise _refuse(name, field, "holds a number that is not finite")
            if limit is not None and max(abs(x) for x in vec) > limit:
                raise _refuse(name, field, f"is {vec}; expected metres in the body frame within {limit:g} m "
                              "of its origin")
            if limit is None and not any(vec):
                raise _refuse(name, field, "is the zero vector; expected a direction")
