"""Markdown tables of bench_gyro_fusion.py results (docs/BENCHMARKS.md "GPS + gyro fusion").

    PYTHONPATH=. python bench/gyro_fusion_table.py RESULT.json [RESULT.json ...]
"""
from __future__ import annotations

import json
import sys

import numpy as np


def _axes(v):
    return " / ".join(f"{x:.3f}" for x in v)


def _kind(d: dict) -> str:
    if d["clean"]:
        return "clean"
    return "faults, gyro step" if d.get("gyro_fault") == "step" else "faults"


def main(paths: list[str]) -> None:
    docs = [json.load(open(p)) for p in paths]
    print("| run | orbit | seed | fused rms x/y/z deg | GPS rms | gyro rms | fused err/sigma | GPS err/sigma |")
    print("|---|---|---|---|---|---|---|---|")
    for p, d in zip(paths, docs):
        a = d["attitude"]
        kind = _kind(d)
        print(f"| {kind} | {d['orbit']} | {d['seed']} | {_axes(a['fused']['rms_deg'])} | {_axes(a['gps']['rms_deg'])} |"
              f" {_axes(a['gyro']['rms_deg'])} | {_axes(a['fused']['error_over_sigma_rms'])} |"
              f" {_axes(a['gps']['error_over_sigma_rms'])} |")
    print()
    print("| run | orbit | seed | faults on used sats | missed | isolated right | false alarms / clean epochs |"
          " false share of detections | epochs with a wrong integer | gyro false events | gyro delay s by propagator |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for d in docs:
        f, i, g = d["gps_fdi"], d["integers"], d["gyro_fdi"]
        delays = g["faults"][0]["delay_s_by_propagator"] if g["faults"] else {}
        ds = ", ".join(f"{j}: {delays[j]:.0f}" if j in delays else f"{j}: -" for j in map(str, range(1, 6))) \
            if g["faults"] else "no fault"
        print(f"| {_kind(d)} | {d['orbit']} | {d['seed']} | "
              f"{f['faults_on_used_satellites']} | {f['missed']} | {f['isolated_right']}/{f['detected']} | "
              f"{f['false_alarms']}/{f['clean_epochs']} ({100 * f['false_alarm_rate_per_clean_epoch']:.1f} %) | "
              f"{100 * f['false_share_of_detections']:.1f} % | {i['epochs_with_wrong_integer']}/{i['epochs_checked']} | "
              f"{g['false_events']} | {ds} |")
    print()
    print("| run | orbit | seed | span s | fuse s (median) | fuse CPU s | write products s | x real time |")
    print("|---|---|---|---|---|---|---|---|")
    for d in docs:
        print(f"| {_kind(d)} | {d['orbit']} | {d['seed']} | {d['duration_s']:.0f} | "
              f"{d['fuse_s_median']} | {d.get('fuse_cpu_s_median', '')} | {d['write_products_s']} | "
              f"{d['faster_than_real_time']} |")
    ratios = np.array([d["attitude"]["fused"]["error_over_sigma_rms"] for d in docs])
    print(f"\nfused error/sigma over runs: mean {_axes(ratios.mean(0))}, min {_axes(ratios.min(0))}, "
          f"max {_axes(ratios.max(0))}")


if __name__ == "__main__":
    main(sys.argv[1:])
