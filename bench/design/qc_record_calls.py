"""How a Python caller hands a numba kernel its records (the choice of gnssatt/attitude/qc_records.py), timed.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/design/qc_record_calls.py

1. Building one 9-field per-epoch record from attributes: `tuple(Record(f=...))` (namedtuple by keyword, then a
   plain tuple), the keyword-only builder of record_tuples.plain_tuple_builder, and a bare tuple display (no names:
   an order mix-up would pass silently).
2. Calling a do-nothing kernel with 30 arrays: positional, as 5 plain tuples of 6, as 5 namedtuples of 6 (numba
   types a namedtuple through Python, a plain tuple by its C fingerprint), and as 5 plain tuples carrying 10
   arrays more than the kernel reads (every field is typed and unboxed, read or not).
Prints the minimum per call over interleaved rounds (the machine's load makes medians wander).
On the 2-core shared build machine (numba 0.68.1, CPython 3.11), three runs: 1. 650-1200 / 140-250 / 70-100 ns;
2. 2.2-2.5 / 2.1-2.2 / 4.4-6.7 / 2.7-4.6 us (~70 ns per array, read or not). Hence: plain tuples, the keyword-only
builders for the records built every epoch, and records holding what their kernel reads.
"""
from __future__ import annotations

import sys
import timeit
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from gnssatt.attitude.record_tuples import plain_tuple_builder  # noqa: E402


class Six(NamedTuple):
    a: np.ndarray               # any array
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    e: np.ndarray
    f: np.ndarray


class Nine(NamedTuple):
    f0: np.ndarray              # any array
    f1: np.ndarray
    f2: np.ndarray
    f3: np.ndarray
    f4: np.ndarray
    f5: np.ndarray
    f6: np.ndarray
    f7: np.ndarray
    f8: np.ndarray


@njit(nogil=True)
def positional(*arrays):
    """The former calling convention: every array its own argument (the dispatcher types each one as it did the
    kernels' 13-38 parameters; numba packs them into a tuple only after that)."""
    return arrays[0].size


@njit(nogil=True)
def records(r0, r1, r2, r3, r4):
    return r0[0].size


def best_ns(stmts: dict[str, str], g: dict, number: int = 2000, rounds: int = 60) -> dict[str, float]:
    """Minimum ns per call of each statement, the statements interleaved round by round (the load of a shared
    machine drifts; interleaving and minima keep the comparison fair)."""
    out = {k: float("inf") for k in stmts}
    for _ in range(rounds):
        for k, stmt in stmts.items():
            out[k] = min(out[k], timeit.timeit(stmt, globals=g, number=number) / number * 1e9)
    return out


def main() -> None:
    class Epoch:
        pass

    ep = Epoch()
    for i in range(9):
        setattr(ep, f"x{i}", np.zeros((2, 30, 2)))
    build = plain_tuple_builder(Nine)
    g = {"ep": ep, "Nine": Nine, "build": build}
    kw = ", ".join(f"f{i}=ep.x{i}" for i in range(9))
    print("1. one 9-field record, ns:")
    for k, v in best_ns({"tuple(Nine(...)) by keyword": f"tuple(Nine({kw}))", "keyword-only builder": f"build({kw})",
                         "bare tuple display": "(" + ", ".join(f"ep.x{i}" for i in range(9)) + ")"}, g).items():
        print(f"   {k:32s}{v:6.0f}")

    arrays = [np.zeros((2, 30, 2), bool if i % 3 else float) for i in range(40)]
    plain = [tuple(arrays[6 * r:6 * r + 6]) for r in range(5)]
    named = [Six(*t) for t in plain]
    fat = [tuple(arrays[6 * r:6 * r + 6]) + tuple(arrays[30 + 2 * r:32 + 2 * r]) for r in range(5)]
    positional(*arrays[:30])
    for recs in (plain, named, fat):
        records(*recs)
    g = {"positional": positional, "records": records}
    g.update({f"a{i}": a for i, a in enumerate(arrays[:30])})
    g.update({f"{c}{r}": t for c, recs in (("p", plain), ("n", named), ("w", fat)) for r, t in enumerate(recs)})
    print("2. a kernel of 30 arrays, us:")
    for k, v in best_ns({"positional": "positional(" + ", ".join(f"a{i}" for i in range(30)) + ")",
                         "5 plain tuples": "records(p0, p1, p2, p3, p4)",
                         "5 namedtuples": "records(n0, n1, n2, n3, n4)",
                         "5 plain tuples, +10 unread": "records(w0, w1, w2, w3, w4)"}, g).items():
        print(f"   {k:32s}{v / 1e3:6.2f}")


if __name__ == "__main__":
    main()
