"""Benchmark: gnssatt navigation / SP3 / RINEX clock readers against georinex and RTKLIB (pyrtklib).

Usage:  .venv/bin/python bench/bench_nav_sp3.py [--runs 5] [--shared ../shared]

Inputs are the real files of ../shared/data/real (no generated data, so no seed): they are decompressed once
into a temporary directory and every reader parses the same plain file from disk (RTKLIB would otherwise spawn
an external gzip). Per reader and file: one warm-up, then the median of N wall-clock runs, and MB/s of the plain
file. Peak RSS is measured in a fresh subprocess per reader and file (ru_maxrss after the read) next to the same
process after imports only, so the difference is what the read itself costs.
Prints a markdown table with machine, commit and date, for docs/BENCHMARKS.md ("Navigation / SP3 readers").
"""
from __future__ import annotations

import argparse
import datetime as dt
import gzip
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

FILES = [  # (kind, set, file)
    ("nav", "static_1m_mosaicx5_nagoya_2024", "base.nav"),
    ("nav", "qzss_l1s_geonet3034_sept_2021", "SEPT2650.21P"),
    ("nav", "leo_grace_a_2007080", "brdc0800.07n.gz"),
    ("sp3", "leo_grace_a_2007080", "cod14193.sp3.gz"),
    ("clk", "leo_grace_a_2007080", "cod14193.clk.gz"),
]

# Reader snippets: (setup code, call code); `P` is the plain file path.
READERS = {
    "nav": {
        "gnssatt": ("from gnssatt.gnss.io.rinex_nav import read_rinex_nav", "read_rinex_nav(P)"),
        "georinex": ("import georinex", "georinex.load(P)"),
        "rtklib": ("import pyrtklib as rk",
                   "rk.readrnx(P, 1, '', rk.obs_t(), rk.nav_t(), rk.sta_t())"),
    },
    "sp3": {
        "gnssatt": ("from gnssatt.gnss.io.sp3 import read_sp3", "read_sp3(P)"),
        "georinex": ("import georinex", "georinex.load_sp3(P, None)"),
        "rtklib": ("import pyrtklib as rk", "rk.readsp3(P, rk.nav_t(), 0)"),
    },
    "clk": {
        "gnssatt": ("from gnssatt.gnss.io.rinex_clock import read_rinex_clock", "read_rinex_clock(P)"),
        "rtklib": ("import pyrtklib as rk", "rk.readrnxc(P, rk.nav_t())"),
        # georinex has no RINEX clock reader.
    },
}


def _time_reader(setup: str, call: str, path: str, runs: int) -> float:
    ns: dict = {"P": path}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        exec(setup, ns)
        exec(call, ns)  # warm-up
        times = []
        for _ in range(runs):
            t0 = time.perf_counter()
            exec(call, ns)
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


# VmHWM (the peak RSS of this process image) rather than ru_maxrss: Linux carries ru_maxrss over fork+exec
# from the (large) parent, VmHWM starts afresh with the new image.
_RSS_SNIPPET = """
import sys, warnings
warnings.simplefilter('ignore')
sys.path.insert(0, {repo!r})
def hwm_kb():
    for ln in open('/proc/self/status'):
        if ln.startswith('VmHWM:'):
            return int(ln.split()[1])
P = {path!r}
{setup}
base = hwm_kb()
if {do_read}:
    {call}
print(base, hwm_kb())
"""


def _peak_rss_mb(setup: str, call: str, path: str) -> tuple[float, float]:
    """(peak RSS after imports only, peak RSS after one read), MB, in a fresh process."""
    code = _RSS_SNIPPET.format(repo=str(REPO), path=path, setup=setup, call=call, do_read=True)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    return int(out[0]) / 1024.0, int(out[1]) / 1024.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per reader and file (median reported)")
    ap.add_argument("--shared", default=str(REPO.parent / "shared"), help="path of ../shared")
    args = ap.parse_args(argv)
    real = Path(args.shared) / "data" / "real"
    tmp = Path(tempfile.mkdtemp(prefix="bench_nav_sp3_"))
    try:
        commit = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
              f"Python {platform.python_version()}, {platform.system()} {platform.release()}")
        print(f"commit: {commit}, date: {dt.date.today().isoformat()}, runs: median of {args.runs} after 1 warm-up")
        print()
        print("| file | kind | size MB | reader | median s | MB/s | x gnssatt time | peak RSS MB (read - imports) |")
        print("|---|---|---|---|---|---|---|---|")
        for kind, set_name, fname in FILES:
            src = real / set_name / fname
            plain = tmp / fname.removesuffix(".gz")
            if fname.endswith(".gz"):
                with gzip.open(src, "rb") as f_in, open(plain, "wb") as f_out:
                    shutil.copyfileobj(f_in, f_out)
            else:
                shutil.copyfile(src, plain)
            size_mb = plain.stat().st_size / 1e6
            ours = None
            for reader, (setup, call) in READERS[kind].items():
                try:
                    med = _time_reader(setup, call, str(plain), args.runs)
                    base_mb, peak_mb = _peak_rss_mb(setup, call, str(plain))
                except Exception as exc:  # a baseline that cannot read the file is reported, not fatal
                    print(f"| {plain.name} | {kind} | {size_mb:.2f} | {reader} | failed: {type(exc).__name__} "
                          f"| | | |")
                    continue
                if reader == "gnssatt":
                    ours = med
                ratio = f"{med / ours:.2f}" if ours else ""
                print(f"| {plain.name} | {kind} | {size_mb:.2f} | {reader} | {med:.4f} | {size_mb / med:.1f} | "
                      f"{ratio} | {peak_mb:.0f} ({peak_mb - base_mb:+.0f}) |")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
