"""`make demo`: start the API and a worker in the background on the embedded default (SQLite + Huey),
mint a key, simulate a CASSIOPE-like observation set, submit it over HTTP, wait, print the products.
`make stop` stops what the demo started. Uses only the `gnssatt` command and HTTP. The job is the attitude job;
its accuracy against the simulator's truth is printed at the end."""
from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx

from client.api import GnssattClient


def _gnssatt(*args: str) -> list[str]:
    return [sys.executable, "-m", "client.cli", *args]


def _pidfile(data_dir: Path, name: str) -> Path:
    return data_dir / "run" / f"{name}.pid"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
        return True
    except OSError:
        return False


def stop(data_dir: Path) -> None:
    stopped = 0
    for name in ("worker", "api"):
        pf = _pidfile(data_dir, name)
        if not pf.exists():
            continue
        pid = int(pf.read_text())
        if _alive(pid):
            os.kill(pid, signal.SIGINT if name == "worker" else signal.SIGTERM)
            for _ in range(100):
                if not _alive(pid):
                    break
                time.sleep(0.1)
            else:
                os.kill(pid, signal.SIGKILL)
            stopped += 1
        pf.unlink(missing_ok=True)
    print(f"stopped {stopped} process(es)" if stopped else "nothing was running")


def _start(name: str, args: list[str], data_dir: Path, env: dict) -> int:
    pf = _pidfile(data_dir, name)
    if pf.exists() and _alive(int(pf.read_text())):
        return int(pf.read_text())
    (data_dir / "logs").mkdir(parents=True, exist_ok=True)
    log = open(data_dir / "logs" / f"{name}.log", "ab")
    proc = subprocess.Popen(args, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    pf.parent.mkdir(parents=True, exist_ok=True)
    pf.write_text(str(proc.pid))
    return proc.pid


@contextlib.contextmanager
def step(what: str):
    """Say what the demo is doing before it starts and how long it took after (issue 16: every step that may take
    over 5 s says what it is doing)."""
    print(f"==> {what} ...", flush=True)
    t0 = time.monotonic()
    yield
    print(f"    done in {time.monotonic() - t0:.1f} s", flush=True)


class JobProgress:
    """on_update callback of GnssattClient.wait: a line when the job's state or stage changes, and every
    `every_s` seconds while it stays, with the progress and the time since submission."""

    def __init__(self, every_s: float = 5.0):
        self.t0, self.every_s = time.monotonic(), every_s
        self.last: tuple | None = None
        self.last_t = 0.0

    def __call__(self, job: dict) -> None:
        key = (job["state"], job.get("stage") or "")
        now = time.monotonic()
        if key == self.last and now - self.last_t < self.every_s:
            return
        self.last, self.last_t = key, now
        what = {"queued": "queued (a worker's first start loads the filter kernels: a cold cache compiles them "
                          "once, ~60-100 s)"}.get(job["state"], job["state"])
        stage = f": {key[1]}" if key[1] and key[1] != job["state"] else ""
        print(f"    {now - self.t0:6.1f} s  {what}{stage}  {float(job.get('progress') or 0.0) * 100:5.1f}%",
              flush=True)


def _wait_ready(url: str, data_dir: Path, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/readyz", timeout=1).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    sys.exit(f"the API did not come up in {timeout_s:g} s; see {data_dir / 'logs' / 'api.log'}")


def demo(port: int, data_dir: Path, scenario: str, duration_s: float, job_type: str) -> None:
    env = dict(os.environ, GNSSATT_DATA_DIR=str(data_dir))
    url = f"http://127.0.0.1:{port}"
    print(f"data directory: {data_dir}")
    with step(f"starting the API on {url} and a worker (logs: {data_dir / 'logs'})"):
        _start("api", _gnssatt("serve", "--port", str(port)), data_dir, env)
        _start("worker", _gnssatt("worker"), data_dir, env)
        _wait_ready(url, data_dir)
    out = subprocess.run(_gnssatt("admin", "create-key", "--team", "demo"), env=env, capture_output=True,
                         text=True, check=True)
    key = out.stdout.strip().splitlines()[-1]
    sample = data_dir / "demo-set"
    with step(f"simulating an observation set, scenario {scenario}, {duration_s:g} s, into {sample}"):
        subprocess.run(_gnssatt("simulate", "--scenario", scenario, "--duration-s", str(duration_s),
                                "--out", str(sample)), env=env, check=True, stdout=subprocess.DEVNULL)
    files = sorted(p for p in sample.rglob("*") if p.is_file() and "truth" not in p.relative_to(sample).parts)
    with GnssattClient(url, key) as client:
        with step(f"uploading {len(files)} files over HTTP"):
            obs_set = client.upload_set(files, name=f"demo {scenario}")
        print(f"uploaded observation set {obs_set['id']} ({len(obs_set['files'])} files)")
        with step(f"running the {job_type} job (submitted over HTTP, followed until it ends)"):
            job = client.submit_job(job_type, [obs_set["id"]], {})
            print(f"    job {job['id']}")
            job = client.wait(job["id"], on_update=JobProgress())
        if job["state"] != "succeeded":
            sys.exit(f"job {job['id']} {job['state']}: {job.get('error')}")
        print(f"job {job['id']} succeeded after {job['attempts']} attempt(s). Products:")
        with step("downloading the products"):
            local = client.download_products(job["id"], data_dir / "demo-products" / job["id"])
        for prod, path in zip(client.products(job["id"]), local):
            print(f"  {prod['url']}\n    -> {path}")
        folder = data_dir / "demo-products" / job["id"]
        attitude = folder / "attitude.csv"
        if attitude.is_file():
            print_accuracy(attitude, sample / "truth" / "attitude.csv")
        print_quality(folder)
    print(f"\nAPI docs: {url}/docs   conventions: {url}/docs/conventions   API key: {key}")
    print("The service keeps running in the background. Stop it with: make stop\n")
    for line in final_lines(url, key, job["id"], folder):
        print(line)


def final_lines(url: str, key: str, job_id: str, folder: Path) -> list[str]:
    """The demo's last three lines: the job page (a sign-in link whose key travels in the URL fragment, which the
    browser keeps to itself), the report, the products folder."""
    from urllib.parse import quote

    page = f"{url}/ui/login?next={quote('/ui/jobs/' + job_id, safe='')}#key={quote(key, safe='')}"
    report = folder / "report.html"
    return [f"job page: {page}", f"report:   {report if report.is_file() else url + '/ui/jobs/' + job_id + '/report'}",
            f"products: {folder}"]


def print_quality(folder: Path) -> None:
    from client.cli import print_quality as _print

    _print(folder)


def _read_quaternions(path: Path) -> dict[str, tuple]:
    import csv

    with open(path) as fh:
        return {r["time_gps"]: (float(r["qe_w"]), float(r["qe_x"]), float(r["qe_y"]), float(r["qe_z"]),
                                int(r["fixed"]), float(r.get("sigma_yaw_deg") or "nan"))
                for r in csv.DictReader(fh)}


def print_accuracy(attitude_csv: Path, truth_csv: Path) -> None:
    """Attitude error against the simulator's truth: rotation angle of R(q_est) R(q_true)^T (CONVENTIONS.md)."""
    import numpy as np

    est, truth = _read_quaternions(attitude_csv), _read_quaternions(truth_csv)
    common = [t for t in est if t in truth]
    if not common:
        print("no epoch of attitude.csv matches the truth")
        return
    q_est = np.array([est[t][:4] for t in common])
    q_true = np.array([truth[t][:4] for t in common])
    fixed = np.array([est[t][4] == 1 for t in common])
    err_deg = np.degrees(2 * np.arccos(np.clip(np.abs(np.sum(q_est * q_true, axis=1)), 0.0, 1.0)))
    print(f"\nAccuracy against the simulator's truth ({len(common)} epochs, {fixed.mean() * 100:.1f}% fixed):")
    for label, mask in (("fixed", fixed), ("float", ~fixed)):
        if mask.any():
            e = err_deg[mask]
            print(f"  {label:5s} epochs: attitude error median {np.median(e):.3f} deg, "
                  f"95% {np.percentile(e, 95):.3f} deg, max {e.max():.3f} deg")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--port", type=int, default=8000)
    p.add_argument("--data-dir", default="var")
    p.add_argument("--scenario", default="earth-pointing")
    p.add_argument("--duration-s", type=float, default=600.0)
    p.add_argument("--job-type", default="attitude")
    p.add_argument("--stop", action="store_true")
    args = p.parse_args()
    data_dir = Path(args.data_dir).resolve()
    if args.stop:
        stop(data_dir)
    else:
        demo(args.port, data_dir, args.scenario, args.duration_s, args.job_type)


if __name__ == "__main__":
    main()
