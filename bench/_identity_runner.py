"""Child process of bench/bench_products_identity.py: runs in ONE code tree (the tree is the working directory and
first on sys.path) and either simulates the input passes or runs the attitude job's pipeline on a list of cases.

    python _identity_runner.py simulate SPEC.json     # SPEC: [{"out": dir, "preset": .., "seed": .., "overrides": {..}}]
    python _identity_runner.py run SPEC.json OUT_DIR  # SPEC: [{"case": id, "files": [[name, kind, path]], "config": {..}}]

Standard library only at import time, and nothing of the tree that started it: this file is read by the tree under
test, whichever layout it has (`layout()` finds the pipeline, its config model, the job context and the simulator).
"""
from __future__ import annotations

import hashlib
import importlib
import inspect
import json
import os
import shutil
import sys
import time
from pathlib import Path

TREE = Path.cwd().resolve()
_HERE = str(Path(__file__).resolve().parent)
sys.path[:] = [str(TREE)] + [p for p in sys.path if p not in ("", _HERE, str(TREE))]

#: where each piece lives, newest layout first (the first that imports from this tree wins)
CANDIDATES = {
    "run": ["worker.pipelines.attitude:run", "worker.jobs.attitude:run"],
    "config": ["worker.jobs.attitude:AttitudeConfig"],
    "context": ["worker.context:JobContext", "core.context:JobContext", "worker.runtime.context:JobContext"],
    "simulate": ["gnssatt.sim:simulate_scenario", "worker.sim:simulate_scenario"],
}


def _from_tree(spec: str):
    module_name, attr = spec.split(":")
    module = importlib.import_module(module_name)
    path = Path(getattr(module, "__file__", "") or "").resolve()
    if TREE not in path.parents:
        raise ImportError(f"{module_name} comes from {path}, not from {TREE}")
    return getattr(module, attr), module


def layout(names=("run", "config", "context")) -> dict:
    """{piece: object} of this tree, plus "context_module" (InputFile, InputSet beside JobContext) and "found"
    (the module:attr used for each piece)."""
    out, found = {}, {}
    for piece in names:
        errors = []
        for spec in CANDIDATES[piece]:
            try:
                out[piece], module = _from_tree(spec)
                found[piece] = spec
                if piece == "context":
                    out["context_module"] = module
                break
            except (ImportError, AttributeError) as exc:
                errors.append(f"{spec}: {exc}")
        else:
            raise SystemExit(f"no {piece} in {TREE}: " + "; ".join(errors))
    out["found"] = found
    return out


def _store(path: Path):
    data = Path(path).read_bytes()
    return hashlib.sha256(data).hexdigest(), len(data)


def _context(lay: dict, files: list, workdir: Path):
    """A JobContext as the runner builds it (one input set, blobs only hashed); only the arguments the tree's
    JobContext takes are passed."""
    m = lay["context_module"]
    s = m.InputSet(id="set-1", name="identity", files=[m.InputFile(n, k, Path(p), {}) for n, k, p in files],
                   summary={})
    kwargs = {"job_id": "identity", "attempt": 1, "sets": [s], "workdir": workdir, "_store_blob": _store}
    params = inspect.signature(lay["context"]).parameters
    return lay["context"](**{k: v for k, v in kwargs.items() if k in params})


def cmd_simulate(spec: list[dict]) -> None:
    simulate = layout(("simulate",))["simulate"]
    for item in spec:
        out = Path(item["out"])
        if (out / ".complete").exists():
            continue
        t0 = time.perf_counter()
        simulate(item["preset"], out, seed=item["seed"], overrides=item["overrides"])
        (out / ".complete").write_text(json.dumps(item))
        print(f"simulated {out.name} in {time.perf_counter() - t0:.0f} s", flush=True)


def cmd_run(spec: list[dict], out_dir: Path) -> None:
    lay = layout()
    timing = {"layout": lay["found"], "cases": {}}
    for case in spec:
        work = out_dir / case["case"]
        if work.exists():
            shutil.rmtree(work)
        work.mkdir(parents=True)
        ctx = _context(lay, case["files"], work)
        t0, c0 = time.perf_counter(), time.process_time()
        lay["run"](ctx, lay["config"](**case["config"]))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        timing["cases"][case["case"]] = {"wall_s": wall, "cpu_s": cpu}
        print(f"{case['case']}: {wall:.1f} s wall, {cpu:.1f} s CPU", flush=True)
    (out_dir / "timing.json").write_text(json.dumps(timing, indent=1))


if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    command, spec_path = sys.argv[1], Path(sys.argv[2])
    spec_doc = json.loads(spec_path.read_text())
    if command == "simulate":
        cmd_simulate(spec_doc)
    else:
        cmd_run(spec_doc, Path(sys.argv[3]))
