"""Product identity across two code trees (issue 15 Done-when): the attitude job's pipeline, the same code the worker
runs (`run(ctx, config)` on a JobContext as the runner builds it), on the same input files in the current tree and in
a baseline git revision; attitude.csv, baselines.csv, events.csv and summary.json compared column by column.

    OPENBLAS_NUM_THREADS=1 nice .venv/bin/python -m bench.bench_products_identity [--baseline-rev 3a2b406]
        [--passes clean,realistic,hard,slew] [--minutes 106] [--no-real] [--cache /tmp/gnssatt-identity]

Inputs (simulated ONCE, by the baseline tree, and reused by both: only the processing differs; cached in --cache):
- the four simulated passes, seed 0, --minutes (106) at 1 Hz, three antennas, L1 C/A + L2 P(Y): `clean` (preset
  `earth-pointing` with CLEAN: no PCV/PCO/multipath, white noise), `realistic` (`earth-pointing` as it is), `hard`
  (preset `hard`: free clocks with jumps, slips, gaps, outages, multipath, 25 mm PCV) and `slew` (preset `slew`:
  seed 000 Fig. 6's yaw/roll slew, clean), each run as `kinematic`, `dynamic`, `dynamic + smoother` and
  `dynamic + smoother_adaptive_noise` (the job's default data selection otherwise);
- the two real sets of tests/attitude/test_real_nagoya.py and test_real_upc.py (bench.real_sets platforms), with
  those tests' configs (Nagoya: kinematic, elevation weights, systems G/E/C/J; UPC: kinematic, the whole hour),
  and in dynamic mode.

Each tree runs in its own subprocess (bench/_identity_runner.py) with the tree as working directory and first on
sys.path; the baseline tree is a `git worktree add --detach` under --cache. The baseline's products are cached per
revision; the current tree's are made on every run.

Comparison per case and product: same columns and rows; numeric columns by unit (name suffix `_deg`, `_m`, `_s` /
`gps_sow`: max |difference| in deg, m, s; quaternion columns q*_w..z: the rotation angle between the two rows, deg);
other cells (names, flags, counts, times) identical text; events.csv rows identical; summary.json: the same keys and
values, numbers by the same unit rule (`_mm` in m; unitless floats within UNITLESS_RTOL), except the keys in
SUMMARY_IGNORED (run times and versions). A difference of
one unit in the last printed digit ("last-digit flips", a rounding-boundary crossing of two values that may differ by
far less) is counted separately. Exit status 1 when any difference exceeds TOLERANCE (1e-6 deg, 1e-6 m, 1e-6 s) -
flips included unless --allow-last-digit - or event rows differ, or a product is missing on one side.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import io
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.real_sets import NAGOYA, NAGOYA_PLATFORM, REAL_DATA_DIR, UPC, UPC_PLATFORM, nagoya_files, upc_files  # noqa: E402

RUNNER = Path(__file__).resolve().parent / "_identity_runner.py"
SEED = 0
CLEAN = {"pcv": False, "pco": False, "multipath": False, "noise_grows_with_cn0": False}
#: label -> (simulator preset, overrides besides duration_s)
PASSES = {"clean": ("earth-pointing", CLEAN), "realistic": ("earth-pointing", {}), "hard": ("hard", {}),
          "slew": ("slew", CLEAN)}
#: label -> attitude job config of the simulated passes
SIM_CONFIGS = {"kinematic": {"mode": "kinematic"}, "dynamic": {"mode": "dynamic"},
               "dynamic+smoother": {"mode": "dynamic", "smoother": True},
               "dynamic+smoother_adaptive": {"mode": "dynamic", "smoother": True, "smoother_adaptive_noise": True}}
NAGOYA_CONFIG = {"weighting": "elevation", "systems": ["G", "E", "C", "J"]}   # tests/attitude/test_real_nagoya.py
COMPARED = ("attitude.csv", "baselines.csv", "events.csv", "summary.json")
#: summary.json keys (any depth) that are not products of the numbers: run times and software versions (the attitude
#: summary of 3a2b406 has none of them; a tree that adds one is not penalised for it)
SUMMARY_IGNORED = ("processing_seconds", "cpu_seconds", "wall_seconds", "elapsed_s", "software_version", "version",
                   "created_at", "generated_at")
TOLERANCE = {"deg": 1e-6, "m": 1e-6, "s": 1e-6}
#: summary.json numbers without a unit (DOPs, rates, noise-model exponents): relative difference accepted, a
#: summation-order change of float64 sums (~1e-16 per operation over ~1e6 terms) stays below it
UNITLESS_RTOL = 1e-9


# ------------------------------------------------------------------------------------------------ inputs ---
def sim_files(d: Path) -> list[tuple[str, str, str]]:
    files = [(f"obs/{p.name}", "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
    files += [("nav/brdc.rnx", "rinex_nav", d / "nav/brdc.rnx"), ("platform.json", "platform", d / "platform.json"),
              ("platform.sp3", "sp3", d / "platform.sp3"),
              ("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv")]
    return [(n, k, str(p)) for n, k, p in files if Path(p).exists()]


def cases(cache: Path, passes: list[str], minutes: float, real: bool) -> tuple[list[dict], list[dict]]:
    """(simulation spec, job cases) of the run."""
    sims, jobs = [], []
    for label in passes:
        preset, over = PASSES[label]
        d = cache / "inputs" / f"{label}_{minutes:g}min_seed{SEED}"
        sims.append({"out": str(d), "preset": preset, "seed": SEED,
                     "overrides": {"duration_s": minutes * 60.0, **over}})
        jobs += [{"case": f"{label}/{name}", "files": d, "config": cfg} for name, cfg in SIM_CONFIGS.items()]
    if real:
        plat_dir = cache / "inputs" / "real"
        plat_dir.mkdir(parents=True, exist_ok=True)
        for name, platform, files_of, extra in ((NAGOYA, NAGOYA_PLATFORM, nagoya_files, NAGOYA_CONFIG),
                                                 (UPC, UPC_PLATFORM, upc_files, {})):
            if not (REAL_DATA_DIR / name).is_dir():
                print(f"real set {name} not found under {REAL_DATA_DIR}: skipped", flush=True)
                continue
            plat = plat_dir / f"{name}.json"
            plat.write_text(json.dumps(platform))
            files = [(n, k, str(p)) for n, k, p in files_of(REAL_DATA_DIR / name, plat)]
            short = "upc" if name == UPC else "nagoya"
            jobs += [{"case": f"{short}/{mode}", "files": files, "config": {"mode": mode, **extra}}
                     for mode in ("kinematic", "dynamic")]
    return sims, jobs


# ------------------------------------------------------------------------------------------------- trees ---
def baseline_tree(rev: str, cache: Path) -> tuple[Path, str]:
    """(work tree of rev under cache, full sha), made with `git worktree add --detach` when absent."""
    sha = subprocess.run(["git", "rev-parse", "--verify", f"{rev}^{{commit}}"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    tree = cache / f"tree-{sha[:7]}"
    if not (tree / ".git").exists():
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), sha], cwd=ROOT, check=True,
                       capture_output=True)
    return tree, sha


def run_in(tree: Path, args: list[str], log: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1", "PYTHONDONTWRITEBYTECODE": "1"}
    with open(log, "ab") as fh:
        proc = subprocess.run([sys.executable, str(RUNNER), *args], cwd=tree, env=env, stdout=fh,
                              stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        sys.exit(f"runner failed in {tree} ({' '.join(args[:1])}); see {log}:\n{log.read_text()[-3000:]}")


def run_cases(tree: Path, jobs: list[dict], out: Path, log: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    spec = [{**j, "files": sim_files(j["files"]) if isinstance(j["files"], Path) else j["files"]} for j in jobs]
    spec_path = out / "spec.json"
    spec_path.write_text(json.dumps(spec, indent=1))
    run_in(tree, ["run", str(spec_path), str(out)], log)


# -------------------------------------------------------------------------------------------- comparison ---
def unit_of(column: str) -> str | None:
    if column.endswith("_deg"):
        return "deg"
    if column.endswith("_m"):
        return "m"
    if column.endswith("_s") or column == "gps_sow":
        return "s"
    return None


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text and "e" not in text.lower() else 0


def _num(text: str) -> float | None:
    if text == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        return None


class Diff:
    """Differences of one product: max |diff| per unit, last-digit flips, other mismatching cells / rows."""

    def __init__(self) -> None:
        self.max = {"deg": 0.0, "m": 0.0, "s": 0.0, "q_deg": 0.0}
        self.max_not_flip = {"deg": 0.0, "m": 0.0, "s": 0.0}
        self.flips = 0
        self.other: list[str] = []

    def number(self, where: str, unit: str | None, a_text: str, b_text: str) -> None:
        a, b = _num(a_text), _num(b_text)
        if a_text == b_text:
            return
        if a is None or b is None or math.isnan(a) != math.isnan(b) or unit is None:
            self.other.append(f"{where}: {a_text!r} / {b_text!r}")
            return
        d = abs(a - b)
        quantum = 10.0 ** -max(_decimals(a_text), _decimals(b_text))
        if TOLERANCE[unit] < d <= quantum * (1 + 1e-9):
            self.flips += 1
        else:
            self.max_not_flip[unit] = max(self.max_not_flip[unit], d)
        self.max[unit] = max(self.max[unit], d)

    def failed(self, allow_last_digit: bool) -> bool:
        """Any difference above TOLERANCE (last-digit flips not counted with allow_last_digit), or any other."""
        m = self.max_not_flip if allow_last_digit else self.max
        # quaternions are printed to 1e-12: a last-digit flip is ~1e-10 deg, far below the tolerance
        over = any(m[u] > TOLERANCE[u] for u in ("deg", "m", "s")) or self.max["q_deg"] > TOLERANCE["deg"]
        return over or bool(self.other)


def _rows(text: str) -> tuple[list[str], list[list[str]]]:
    rows = list(csv.reader(io.StringIO(text)))
    return (rows[0], rows[1:]) if rows else ([], [])


def compare_csv(a_text: str, b_text: str) -> Diff:
    diff = Diff()
    ha, ra = _rows(a_text)
    hb, rb = _rows(b_text)
    if ha != hb:
        diff.other.append(f"columns differ: {ha} / {hb}")
        return diff
    if len(ra) != len(rb):
        diff.other.append(f"rows {len(ra)} / {len(rb)}")
        return diff
    for col, name in enumerate(ha):
        unit = unit_of(name)
        for k, (x, y) in enumerate(zip(ra, rb)):
            if x[col] != y[col]:
                diff.number(f"row {k + 2} {name}", unit, x[col], y[col])
    for prefix in ("qe", "qi"):
        idx = [ha.index(f"{prefix}_{c}") for c in "wxyz"] if f"{prefix}_w" in ha else None
        if idx is None:
            continue
        # the quaternion columns carry no unit: the difference is the rotation between the two rows
        diff.other = [o for o in diff.other if not any(f" {prefix}_{c}:" in o for c in "wxyz")]
        for x, y in zip(ra, rb):
            qa, qb = [float(x[i]) for i in idx], [float(y[i]) for i in idx]
            dot = min(1.0, abs(sum(p * q for p, q in zip(qa, qb))) / math.sqrt(sum(p * p for p in qa) *
                                                                             sum(q * q for q in qb)))
            diff.max["q_deg"] = max(diff.max["q_deg"], math.degrees(2.0 * math.acos(dot)))
    return diff


def compare_events(a_text: str, b_text: str) -> Diff:
    diff = Diff()
    la, lb = a_text.splitlines(), b_text.splitlines()
    bad = sum(x != y for x, y in zip(la, lb)) + abs(len(la) - len(lb))
    if bad:
        diff.other.append(f"{bad} of {max(len(la), len(lb)) - 1} event rows differ")
    return diff


def _flatten(doc, prefix: str = "") -> dict[str, object]:
    if isinstance(doc, dict):
        out = {}
        for k, v in doc.items():
            if k not in SUMMARY_IGNORED:
                out.update(_flatten(v, f"{prefix}{k}."))
        return out
    if isinstance(doc, list):
        out = {}
        for i, v in enumerate(doc):
            out.update(_flatten(v, f"{prefix}{i}."))
        return out
    return {prefix[:-1]: doc}


def compare_summary(a_text: str, b_text: str) -> Diff:
    diff = Diff()
    fa, fb = _flatten(json.loads(a_text)), _flatten(json.loads(b_text))
    for key in sorted(set(fa) ^ set(fb)):
        diff.other.append(f"key {key} only in {'baseline' if key in fa else 'current'}")
    for key in sorted(set(fa) & set(fb)):
        x, y = fa[key], fb[key]
        if x == y:
            continue
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (x, y))
        last = key.rsplit(".", 1)[-1]
        if numeric and last.endswith("_mm"):
            diff.max["m"] = max(diff.max["m"], abs(float(x) - float(y)) * 1e-3)
        elif numeric and unit_of(last):
            diff.max[unit_of(last)] = max(diff.max[unit_of(last)], abs(float(x) - float(y)))
        elif numeric and (math.isnan(x) and math.isnan(y) or isinstance(x, float) and isinstance(y, float)
                          and abs(x - y) <= UNITLESS_RTOL * max(abs(x), abs(y))):
            continue
        else:
            diff.other.append(f"{key}: {x!r} / {y!r}")
    return diff


def compare_case(a_dir: Path, b_dir: Path) -> dict[str, Diff | str]:
    out: dict[str, Diff | str] = {}
    for name in COMPARED:
        pa, pb = a_dir / "products" / name, b_dir / "products" / name
        if not pa.exists() and not pb.exists():
            out[name] = "absent in both"
            continue
        if pa.exists() != pb.exists():
            d = Diff()
            d.other.append(f"only in {'baseline' if pa.exists() else 'current'}")
            out[name] = d
            continue
        a, b = pa.read_text(), pb.read_text()
        out[name] = (compare_events if name == "events.csv" else compare_summary if name.endswith(".json")
                     else compare_csv)(a, b)
    return out


def other_products(a_dir: Path, b_dir: Path) -> tuple[int, list[str]]:
    """(products outside COMPARED with identical bytes, names of those that differ or exist on one side only)."""
    sha = lambda p: hashlib.sha256(p.read_bytes()).hexdigest()  # noqa: E731
    names = {p.name for d in (a_dir, b_dir) for p in (d / "products").glob("*")} - set(COMPARED)
    same = [n for n in names if (a_dir / "products" / n).exists() and (b_dir / "products" / n).exists()
            and sha(a_dir / "products" / n) == sha(b_dir / "products" / n)]
    return len(same), sorted(names - set(same))


# ---------------------------------------------------------------------------------------------------- main ---
def _fmt(x: float) -> str:
    return "0" if x == 0 else f"{x:.1e}"


def report(jobs: list[dict], base_out: Path, cur_out: Path, allow_last_digit: bool) -> tuple[list[str], bool]:
    tb = json.loads((base_out / "timing.json").read_text())
    tc = json.loads((cur_out / "timing.json").read_text())
    lines = [f"Layouts: baseline {tb['layout']}; current {tc['layout']}.", "",
             "| case | product | max diff deg | max diff m | max diff s | quaternion angle deg | last-digit flips | "
             "other differences | status |", "|---|---|---|---|---|---|---|---|---|"]
    ok = True
    other_lines = []
    for job in jobs:
        case = job["case"]
        diffs = compare_case(base_out / case, cur_out / case)
        for name, d in diffs.items():
            if isinstance(d, str):
                lines.append(f"| {case} | {name} | - | - | - | - | - | {d} | ok |")
                continue
            bad = d.failed(allow_last_digit)
            ok &= not bad
            lines.append(f"| {case} | {name} | {_fmt(d.max['deg'])} | {_fmt(d.max['m'])} | {_fmt(d.max['s'])} | "
                         f"{_fmt(d.max['q_deg'])} | {d.flips} | {len(d.other)}"
                         + (f" (first: {d.other[0]})" if d.other else "") + f" | {'DIFFERS' if bad else 'ok'} |")
        same, differ = other_products(base_out / case, cur_out / case)
        cb, cc = tb["cases"][case]["cpu_s"], tc["cases"][case]["cpu_s"]
        other_lines.append(f"| {case} | {cb:.1f} | {cc:.1f} | {cc / cb:.2f} | {same} | {', '.join(differ) or '-'} |")
    lines += ["", "Job CPU s per tree (the pipeline, plots and report included; one run each, context only) and the "
              "other products by sha256:", "",
              "| case | baseline CPU s | current CPU s | ratio | other products identical | differing |",
              "|---|---|---|---|---|---|"] + other_lines
    return lines, ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline-rev", default="3a2b406")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/gnssatt-identity"))
    ap.add_argument("--passes", default=",".join(PASSES))
    ap.add_argument("--minutes", type=float, default=106.0)
    ap.add_argument("--no-real", action="store_true")
    ap.add_argument("--allow-last-digit", action="store_true",
                    help="accept differences of one unit in the last printed digit (rounding-boundary flips)")
    ap.add_argument("--rerun-baseline", action="store_true", help="ignore the baseline products in the cache")
    ap.add_argument("--compare-only", action="store_true", help="compare the cached products of both trees again")
    args = ap.parse_args()
    t_start = time.perf_counter()
    cache = args.cache.resolve()
    cache.mkdir(parents=True, exist_ok=True)
    tree, sha = baseline_tree(args.baseline_rev, cache)
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT, capture_output=True,
                           text=True).stdout.strip()
    sims, jobs = cases(cache, [p for p in args.passes.split(",") if p], args.minutes, not args.no_real)
    log = cache / "runner.log"
    spec = cache / "inputs" / "simulate.json"
    spec.parent.mkdir(parents=True, exist_ok=True)
    spec.write_text(json.dumps(sims, indent=1))
    # products per set of cases (a change of passes or minutes is another directory) and, for the current tree, per
    # checkout (two worktrees may run the harness on one cache at once)
    key = hashlib.sha256(json.dumps([{**j, "files": str(j["files"])} for j in jobs], sort_keys=True).encode())
    key_hex = key.hexdigest()[:12]
    base_out = cache / "products" / f"{sha[:12]}-{key_hex}"
    cur_out = cache / "products" / f"current-{hashlib.sha256(str(ROOT).encode()).hexdigest()[:8]}-{key_hex}"
    if not args.compare_only:
        run_in(tree, ["simulate", str(spec)], log)                 # once, by the baseline tree
        done = base_out / "done"
        if args.rerun_baseline or not done.exists():
            run_cases(tree, jobs, base_out, log)
            done.write_text("")
        run_cases(ROOT, jobs, cur_out, log)
    lines, ok = report(jobs, base_out, cur_out, args.allow_last_digit)
    head_lines = [f"Product identity: baseline {sha[:7]} against the current tree {head.strip()}"
                  f"{' (uncommitted changes)' if dirty else ''}; {len(jobs)} cases; tolerance 1e-6 deg / 1e-6 m / "
                  f"1e-6 s; summary keys ignored: {', '.join(SUMMARY_IGNORED)}. Wall "
                  f"{time.perf_counter() - t_start:.0f} s.", ""]
    print("\n".join(head_lines + lines))
    print("\nRESULT:", "identical within tolerance" if ok else "DIFFERENCES above tolerance")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
