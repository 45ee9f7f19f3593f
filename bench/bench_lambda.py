"""Ambiguity resolution benchmark: MLAMBDA and constrained-search timings per problem size, and single-epoch
success rates of rounding / bootstrapping / ILS (MLAMBDA) / C-LAMBDA / MC-LAMBDA on random GPS-like geometry.

Inputs are generated from the seeds named below (gnssatt/estimation/synthetic.py): random attitude, 8-10 (or
fewer) satellites above 10 deg, undifferenced sigmas phase 3 mm / code 0.3 m, CASSIOPE-like (1.05 m, 1.14 m) or
CubeSat-like (2 x 0.10 m) antennas. One warm-up, then the median of the runs per size.

Reproduce: .venv/bin/python bench/bench_lambda.py [--trials 300] [--write]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench._report import machine_line, replace_section  # noqa: E402
from gnssatt.estimation.ar_validation import bootstrap_success_rate  # noqa: E402
from gnssatt.estimation.constrained_search import constrained_search_float  # noqa: E402
from gnssatt.estimation.lambda_search import AmbiguitySearchError, integer_bootstrap, mlambda  # noqa: E402
from gnssatt.estimation.synthetic import (  # noqa: E402
    CASSIOPE_BODY_M, CUBESAT_BODY_M, L1_WAVELENGTH_M, L2_WAVELENGTH_M, simulate_epoch,
)

SEED_TIMING = 100
SEED_RATES = 200


def _timing_rows(runs: int) -> list[str]:
    rng = np.random.default_rng(SEED_TIMING)
    rows = []
    cases = [("1 bl x L1, 8 sats", CASSIOPE_BODY_M[:1], 8, (L1_WAVELENGTH_M,)),
             ("1 bl x L1, 10 sats", CASSIOPE_BODY_M[:1], 10, (L1_WAVELENGTH_M,)),
             ("2 bl x L1, 8 sats", CASSIOPE_BODY_M, 8, (L1_WAVELENGTH_M,)),
             ("2 bl x L1, 10 sats", CASSIOPE_BODY_M, 10, (L1_WAVELENGTH_M,)),
             ("2 bl x L1+L2, 8 sats", CASSIOPE_BODY_M, 8, (L1_WAVELENGTH_M, L2_WAVELENGTH_M)),
             ("2 bl x L1+L2, 11 sats", CASSIOPE_BODY_M, 11, (L1_WAVELENGTH_M, L2_WAVELENGTH_M))]
    for label, body, ns, wl in cases:
        eps = [simulate_epoch(rng, body, n_sats=ns, wavelengths_m=wl) for _ in range(runs + 1)]
        n = eps[0].sol.a_float_cyc.size
        t_ml, t_cs, nodes_ml, nodes_cs = [], [], [], []
        for i, ep in enumerate(eps):
            t0 = time.perf_counter()
            r = mlambda(ep.sol.a_float_cyc, ep.sol.Q_a)
            t1 = time.perf_counter()
            c = constrained_search_float(ep.sol, body)
            t2 = time.perf_counter()
            if i == 0:
                continue                                   # warm-up
            t_ml.append(t1 - t0)
            t_cs.append(t2 - t1)
            nodes_ml.append(r.n_nodes)
            nodes_cs.append(c.n_nodes)
        kind = "C-LAMBDA" if body.shape[0] == 1 else "MC-LAMBDA"
        rows.append(f"| {label} | {n} | {np.median(t_ml) * 1e3:.1f} | {np.max(t_ml) * 1e3:.1f} | "
                    f"{int(np.median(nodes_ml))} | {kind} | {np.median(t_cs) * 1e3:.1f} | {np.max(t_cs) * 1e3:.1f} | "
                    f"{int(np.median(nodes_cs))} / {int(np.max(nodes_cs))} |")
    return rows


def _rates(body, n_trials, n_sats_range, seed, sigma_code_m=0.3, wavelengths=(L1_WAVELENGTH_M,)):
    rng = np.random.default_rng(seed)
    hits = dict(round=0, boot=0, ils=0, ils_ratio3=0, ils_ratio3_wrong=0, c=0, c_both=0, mc=0, mc_ratio=0,
                mc_ratio_wrong=0, budget=0)
    p_boot = []
    for _ in range(n_trials):
        ep = simulate_epoch(rng, body, n_sats=int(rng.integers(*n_sats_range)), sigma_code_m=sigma_code_m,
                            wavelengths_m=wavelengths)
        s = ep.sol
        hits["round"] += np.array_equal(np.rint(s.a_float_cyc), ep.a_true)
        hits["boot"] += np.array_equal(integer_bootstrap(s.a_float_cyc, s.Q_a), ep.a_true)
        r = mlambda(s.a_float_cyc, s.Q_a)
        p_boot.append(bootstrap_success_rate(r.d))
        ok = np.array_equal(r.fixed[0], ep.a_true)
        hits["ils"] += ok
        if r.ratio >= 3.0:
            hits["ils_ratio3"] += ok
            hits["ils_ratio3_wrong"] += not ok
        both = True
        for i in range(s.n_baselines):
            idx = np.concatenate([np.arange(sl.start, sl.stop) for sl, b in zip(s.ambiguity_slices(), s.blocks)
                                  if b.baseline == i])
            try:
                okc = np.array_equal(constrained_search_float(s.baseline(i), body[i:i + 1]).fixed[0],
                                     ep.a_true[idx])
            except AmbiguitySearchError:             # node budget exhausted: no fix (counted as a failure)
                okc = False
            hits["c"] += okc
            both &= okc
        hits["c_both"] += both
        try:
            mc = constrained_search_float(s, body)
        except AmbiguitySearchError:
            hits["budget"] += 1
            continue
        okm = np.array_equal(mc.fixed[0], ep.a_true)
        hits["mc"] += okm
        if mc.ratio >= 3.0:
            hits["mc_ratio"] += okm
            hits["mc_ratio_wrong"] += not okm
    q = body.shape[0]
    pct = {k: 100.0 * v / n_trials for k, v in hits.items()}
    pct["c"] = 100.0 * hits["c"] / (n_trials * q)
    pct["p_boot"] = 100.0 * float(np.mean(p_boot))
    return pct


def _rate_rows(n_trials: int) -> list[str]:
    rows = []
    cases = [("CASSIOPE-like 1.05/1.14 m, L1, 8-10 sats", CASSIOPE_BODY_M, (8, 11), 0.3, (L1_WAVELENGTH_M,)),
             ("CubeSat-like 2 x 0.10 m, L1, 8-10 sats", CUBESAT_BODY_M, (8, 11), 0.3, (L1_WAVELENGTH_M,)),
             ("CASSIOPE-like, L1, 6-7 sats", CASSIOPE_BODY_M, (6, 8), 0.3, (L1_WAVELENGTH_M,)),
             ("CubeSat-like, L1, 6-7 sats", CUBESAT_BODY_M, (6, 8), 0.3, (L1_WAVELENGTH_M,)),
             ("CASSIOPE-like, L1+L2, 6-7 sats", CASSIOPE_BODY_M, (6, 8), 0.3, (L1_WAVELENGTH_M, L2_WAVELENGTH_M))]
    for k, (label, body, ns, sc, wl) in enumerate(cases):
        p = _rates(body, n_trials, ns, SEED_RATES + k, sc, wl)
        rows.append(f"| {label} | {p['round']:.1f} | {p['boot']:.1f} | {p['p_boot']:.1f} | {p['ils']:.1f} | "
                    f"{p['ils_ratio3']:.1f} / {p['ils_ratio3_wrong']:.1f} | {p['c']:.1f} | {p['c_both']:.1f} | "
                    f"{p['mc']:.1f} | {p['mc_ratio']:.1f} / {p['mc_ratio_wrong']:.1f} | {p['budget']:.1f} |")
        print(rows[-1], flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--trials", type=int, default=300)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()
    t_rows = _timing_rows(args.runs)
    print("\n".join(t_rows), flush=True)
    r_rows = _rate_rows(args.trials)
    body = f"""Machine: {machine_line()}. Pure Python + numpy (no compiled search), one core.

Timing: median (and max) wall time per call over {args.runs} random single-epoch problems after one warm-up
(seed {SEED_TIMING}); `mlambda(m=2)` = decorrelation + search for the best two; the constrained search (default
`ratio_cap=3`) includes its own decorrelation, node-bound set-up and the expansions until the second candidate or
3x the best cost. Nodes: visited search-tree nodes (median / max).

| problem | n amb. | mlambda median ms | max ms | nodes | constrained | median ms | max ms | nodes med / max |
|---|---|---|---|---|---|---|---|---|
{chr(10).join(t_rows)}

Single-epoch success rates, % of {args.trials} random epochs (seeds {SEED_RATES}+), undifferenced sigmas phase 3 mm
and code 0.3 m unless stated, satellites uniform in solid angle above 10 deg, random attitude. "round": float
rounded; "boot": bootstrapping after decorrelation, "P_B": its predicted rate (Teunissen 1998, mean over epochs);
"ILS": MLAMBDA best; "ILS r>=3": fixed correctly / wrongly with ratio >= 3 (RTKLIB's acceptance); "C": C-LAMBDA
per baseline (length only); "C both": both baselines right; "MC": MC-LAMBDA both baselines jointly (rotation
unknown); "MC r>=3": correct / wrong among epochs with constrained ratio >= 3; "MC budget": epochs where the
MC search ran out of its 300 000-node budget before a first candidate (counted as not fixed).

| case | round | boot | P_B | ILS | ILS r>=3 ok / wrong | C | C both | MC | MC r>=3 ok / wrong | MC budget |
|---|---|---|---|---|---|---|---|---|---|---|
{chr(10).join(r_rows)}

Reading: with 8-10 satellites and white noise, unconstrained ILS already fixes ~96-97 % of single L1 epochs
(the issue notes the same for RTKLIB on benign data) and C-/MC-LAMBDA fix all; with 6-7 satellites ILS drops to
~30 % while C-LAMBDA keeps ~97 % (1.1 m) / ~100 % (0.1 m) per baseline and MC-LAMBDA 100 %: the known body
geometry is what makes single-epoch single-frequency fixing possible. Rounding the float values without
decorrelation never succeeds on a single epoch. The ratio test at 3 accepted no wrong fix anywhere here, but on
the constrained costs (which carry the full n + 3 degrees of freedom of noise) it also rejects 5-20 % of
correct fixes; the length/angle tests of seed 000 are the main guard. Times are on a shared 2-core machine
(max values are noisy); the search is pure Python, ~10 us per node.
The tests (`tests/estimation/test_constrained_search.py`) assert MC-LAMBDA >= 90 % (CASSIOPE-like) and >= 99 %
(CubeSat-like) on 300 seeded epochs each, and the ordering rounding <= bootstrapping <= ILS <= C <= MC.

Reproduce: `.venv/bin/python bench/bench_lambda.py --runs {args.runs} --trials {args.trials} --write`.
"""
    print(body)
    if args.write:
        replace_section(ROOT / "docs" / "BENCHMARKS.md", "Ambiguity resolution", body)


if __name__ == "__main__":
    main()
