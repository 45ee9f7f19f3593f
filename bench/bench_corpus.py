"""Benchmark: every file of the reader corpus (tests/corpus/manifest.csv, 379 third-party files) through gnssatt's
readers, against the manifest's label, the independent raw-line re-read, georinex (observation files up to
`--georinex-max-mb` decompressed) and RTKLIB (pyrtklib readrnx / readsp3: navigation and SP3). tests/corpus runs a fixed
subset of the same checks; this runs all of them.

    PYTHONPATH=$PWD python bench/bench_corpus.py [--georinex-max-mb 1] [--json out.json]

Prints, per label, files read / refused and the expectation failures; per reference, files compared, values
compared and disagreements (each named with its first differing value).
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.corpus_check import (check_expectation, georinex_check, load_manifest, raw_check, read_row,  # noqa: E402
                                rtklib_nav_check, rtklib_sp3_check)


def _plain_size(row) -> int:
    """Decompressed size (georinex takes ~10 s per MB of multi-GNSS text)."""
    from bench.corpus_check import decompressed_text

    return len(decompressed_text(row.file))


def _try(fn, *args) -> tuple[int | None, str | None]:
    try:
        return fn(*args), None
    except Exception as exc:   # a disagreement or the other reader refusing the file: reported, never hidden
        return None, f"{type(exc).__name__}: {str(exc)[:240]}"


def run(georinex_max_mb: float) -> dict:
    rows = load_manifest()
    work = Path(tempfile.mkdtemp(prefix="corpus-"))
    per_label: Counter = Counter()
    refs: dict[str, Counter] = {k: Counter() for k in ("raw", "georinex", "rtklib")}
    problems: list[dict] = []
    slowest = (0.0, "")
    t_all = time.perf_counter()
    for k, row in enumerate(rows):
        print(f"[{k + 1}/{len(rows)}] {row.path}", file=sys.stderr, flush=True)
        out = read_row(row)
        slowest = max(slowest, (out.seconds, row.path))
        per_label[(row.label, "refused" if out.error is not None else "read")] += 1
        ok, why = _try(check_expectation, row, out)
        if why:
            problems.append({"file": row.path, "check": "label", "detail": why})
        if out.error is not None:
            continue
        checks = [("raw", raw_check, (row, out.result))]
        if row.kind == "obs" and _plain_size(row) <= georinex_max_mb * 1e6:
            checks.append(("georinex", georinex_check, (row, out.result)))
        if row.kind == "nav":
            checks.append(("rtklib", rtklib_nav_check, (row, out.result, work)))
        if row.kind == "sp3":
            checks.append(("rtklib", rtklib_sp3_check, (row, out.result, work)))
        for ref, fn, args in checks:
            n, why = _try(fn, *args)
            if why is None:
                refs[ref]["files"] += 1
                refs[ref]["values"] += n
            else:
                refs[ref]["disagreements_or_refusals"] += 1
                problems.append({"file": row.path, "check": ref, "detail": why})
    return {"files": len(rows), "per_label": {f"{a} {b}": n for (a, b), n in sorted(per_label.items())},
            "references": {k: dict(v) for k, v in refs.items()}, "problems": problems,
            "slowest_read_s": round(slowest[0], 2), "slowest_file": slowest[1],
            "elapsed_s": round(time.perf_counter() - t_all, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--georinex-max-mb", type=float, default=1.0, help="largest decompressed file for georinex")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    res = run(args.georinex_max_mb)
    print(f"{res['files']} files, {res['elapsed_s']} s; slowest read {res['slowest_read_s']} s ({res['slowest_file']})")
    for k, v in res["per_label"].items():
        print(f"  {k:16s} {v}")
    for k, v in res["references"].items():
        print(f"  {k:9s} {v}")
    for p in res["problems"]:
        print(f"  [{p['check']}] {p['file']}: {p['detail']}")
    if args.json:
        args.json.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
