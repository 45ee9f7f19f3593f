"""The readers' quirk warnings of the files a job used, as one list for its summary.json and report.html.

Each uploaded file's summary (gnssatt.gnss.io.sniff, stored with the file) carries the `ParseWarning`s its
reader gave (docs/reader_policy.md: a quirk is read with a structured warning in the set's summary and the job's
report). A job does not re-read its files for this: it collects those lists.
"""
from __future__ import annotations

__all__ = ["reader_warnings"]


def _set_label(s) -> str:
    return str(getattr(s, "name", None) or getattr(s, "id", "") or "")


def reader_warnings(sets) -> list[dict]:
    """One row per warning of every file of `sets` (objects with `files`, each with `name` and `summary`):
    {"set", "file", "code", "line", "message"}, in set and file order; [] when no file has a warning."""
    rows: list[dict] = []
    for s in sets:
        for f in getattr(s, "files", []) or []:
            summary = getattr(f, "summary", None) or {}
            for w in summary.get("warnings", []) or []:
                if not isinstance(w, dict):
                    continue
                rows.append({"set": _set_label(s), "file": getattr(f, "name", ""), "code": w.get("code", ""),
                             "line": w.get("line_no"), "message": w.get("message", "")})
    return rows
