"""The `gnssatt` command: run the service (serve, worker, admin) and use it (submit, status, fetch, simulate).

The client commands talk HTTP only. serve/worker/admin import the service lazily, inside the command.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from client.api import ApiError, GnssattClient


def _client(args) -> GnssattClient:
    url = args.url or os.environ.get("GNSSATT_URL") or "http://127.0.0.1:8000"
    key = args.key or os.environ.get("GNSSATT_API_KEY")
    if not key:
        sys.exit("gnssatt: no API key: pass --key or set GNSSATT_API_KEY (an operator mints one with "
                 "'gnssatt admin create-key --team NAME')")
    return GnssattClient(url, key)


def _progress_bar(job: dict) -> None:
    width = 30
    frac = float(job.get("progress") or 0.0)
    filled = int(round(frac * width))
    stage = (job.get("stage") or "")[:40]
    line = f"\r[{'#' * filled}{'.' * (width - filled)}] {frac * 100:5.1f}% {job['state']:<9} {stage:<40}"
    if sys.stderr.isatty():
        sys.stderr.write(line)
    else:
        sys.stderr.write(line.strip("\r") + "\n")
    sys.stderr.flush()


def cmd_serve(args) -> None:
    import uvicorn

    from app.main import create_app
    from core.settings import Settings

    settings = Settings()
    uvicorn.run(create_app(settings), host=args.host, port=args.port, log_level=settings.log_level.lower(),
                timeout_graceful_shutdown=5)


def cmd_worker(args) -> None:
    # One BLAS thread per job: workers scale by processes and job slots, and multi-threaded BLAS on small
    # per-epoch matrices only oversubscribes the cores (measured 4-8x slower fan-out tasks on 2 cores).
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    from core.settings import Settings
    from worker.main import run_worker

    run_worker(Settings(), concurrency=args.concurrency)


def _admin_session():
    from core.db import make_engine, make_sessionmaker
    from core.migrate import migrate
    from core.settings import Settings

    settings = Settings()
    engine = make_engine(settings)
    migrate(engine, settings)
    return make_sessionmaker(engine)


def cmd_create_key(args) -> None:
    from app.keys import create_key

    Session = _admin_session()
    with Session.begin() as s:
        key, _ = create_key(s, args.team, args.label)
    print(f"API key for team {args.team!r} (shown once; store it safely):")
    print(key)


def cmd_revoke_key(args) -> None:
    from app.keys import revoke_key

    Session = _admin_session()
    with Session.begin() as s:
        n = revoke_key(s, args.key)
    print(f"revoked {n} key(s)")
    if n == 0:
        sys.exit(1)


def _read_config(path: str | None) -> dict:
    if not path:
        return {}
    try:
        config = json.loads(Path(path).read_text())
    except OSError as exc:
        sys.exit(f"gnssatt: cannot read the config file {path}: {exc.strerror}")
    except json.JSONDecodeError as exc:
        sys.exit(f"gnssatt: {path}, line {exc.lineno}, column {exc.colno}: not JSON ({exc.msg})")
    if not isinstance(config, dict):
        sys.exit(f"gnssatt: {path}: the config must be a JSON object, not {type(config).__name__}")
    return config


def check_job_request(c: GnssattClient, job_type: str, config: dict) -> dict:
    """Before any upload: the job type exists and the server accepts the config (a submit without sets, which
    the server refuses for the set count only after it has validated the type and the config; nothing is
    queued). Exits with one line naming the problem; returns the job type's description."""
    types = {t["name"]: t for t in c.job_types()}
    spec = types.get(job_type)
    if spec is None:
        sys.exit(f"gnssatt: unknown job type {job_type!r}; the service has: {', '.join(sorted(types))}")
    if spec.get("min_sets", 1) >= 1:
        try:
            c.submit_job(job_type, [], config)
        except ApiError as exc:
            if not str(exc.problem.get("type", "")).endswith("wrong-set-count"):
                field = f" (field {exc.problem['field']})" if exc.problem.get("field") else ""
                sys.exit(f"gnssatt: config refused before upload{field}: {exc.problem.get('detail', exc)}")
        else:  # pragma: no cover - a server that queued a job without sets breaks its own contract
            sys.exit("gnssatt: the server accepted a job without observation sets; not uploading")
    return spec


def print_quality(out_dir: Path) -> None:
    """The quality block of summary.json (attitude jobs), one line per item, to stdout after the product paths."""
    path = Path(out_dir) / "summary.json"
    try:
        quality = json.loads(path.read_text()).get("quality")
    except (OSError, ValueError, AttributeError):
        return
    if not isinstance(quality, dict):
        return
    print(f"quality: {str(quality.get('verdict', '')).upper()}")
    for it in quality.get("items", []):
        print(f"  {it.get('verdict', ''):<5}  {it.get('label', '')}: {it.get('text', '')}")


def cmd_submit(args) -> None:
    config = _read_config(args.config)
    missing_files = [p for p in args.paths if not Path(p).exists()]
    if missing_files:
        sys.exit(f"gnssatt: no such file: {missing_files[0]}")
    with _client(args) as c:
        check_job_request(c, args.type, config)
        obs_set = c.upload_set([Path(p) for p in args.paths], name=args.name)
        print(f"observation set {obs_set['id']}: {len(obs_set['files'])} file(s)", file=sys.stderr)
        job = c.submit_job(args.type, [obs_set["id"]], config)
        print(f"job {job['id']} ({job['type']}) queued", file=sys.stderr)
        if args.no_wait:
            print(job["id"])
            return
        job = c.wait(job["id"], on_update=_progress_bar)
        sys.stderr.write("\n")
        _finish(c, job, args.out)


def _finish(c: GnssattClient, job: dict, out: str | None) -> None:
    if job["state"] != "succeeded":
        err = job.get("error") or {}
        print(f"job {job['id']} {job['state']}: {err.get('title', '')}: {err.get('detail', '')}", file=sys.stderr)
        sys.exit(2)
    out_dir = Path(out or f"gnssatt-{job['id']}")
    for p in c.download_products(job["id"], out_dir):
        print(p)
    print_quality(out_dir)


def resolve_id(c: GnssattClient, given: str, what: str = "job") -> str:
    """A full job (or set) id, or the one job (set) of the team whose id starts with `given` (the 8-character ids
    the pages show); exits naming the candidates when the prefix is ambiguous or matches nothing."""
    given = given.strip().lower()
    if len(given) == 32:
        return given
    if len(given) < 4:
        sys.exit(f"gnssatt: {what} id prefix {given!r} is too short (give at least 4 characters)")
    listing = c.list_jobs if what == "job" else c.list_sets
    matches, offset = [], 0
    while True:
        page = listing(limit=500, offset=offset)
        matches += [j["id"] for j in page["items"] if j["id"].startswith(given)]
        if page.get("next_offset") is None or len(matches) > 1:
            break
        offset = page["next_offset"]
    if not matches:
        sys.exit(f"gnssatt: no {what} of your team has an id starting with {given!r}")
    if len(matches) > 1:
        sys.exit(f"gnssatt: {what} id prefix {given!r} is ambiguous: {', '.join(m[:12] for m in matches[:5])} ...")
    return matches[0]


def resolve_job_id(c: GnssattClient, given: str) -> str:
    """resolve_id for a job."""
    return resolve_id(c, given, "job")


def cmd_delete(args) -> None:
    """Delete a finished job (its products, and their blobs nothing else uses) or an observation set."""
    what = "job" if args.what == "job" else "observation set"
    with _client(args) as c:
        full = resolve_id(c, args.id, "job" if args.what == "job" else "set")
        (c.delete_job if args.what == "job" else c.delete_set)(full)
    print(f"deleted {what} {full}")


def cmd_status(args) -> None:
    with _client(args) as c:
        if args.job_id:
            print(json.dumps(c.get_job(resolve_job_id(c, args.job_id)), indent=2))
        else:
            for job in c.list_jobs(state=args.state, limit=args.limit)["items"]:
                print(f"{job['id']}  {job['type']:<12} {job['state']:<9} {job['progress'] * 100:5.1f}%  "
                      f"{job['created_at']}")


def cmd_fetch(args) -> None:
    with _client(args) as c:
        job_id = resolve_job_id(c, args.job_id)
        job = c.get_job(job_id)
        if args.wait:
            job = c.wait(job_id, on_update=_progress_bar)
            sys.stderr.write("\n")
        _finish(c, job, args.out)


def cmd_simulate(args) -> None:
    from gnssatt.sim import list_scenarios, simulate_scenario

    if args.list:
        for name, params in list_scenarios().items():
            print(name, json.dumps(params))
        return
    overrides = {}
    for item in args.set or []:
        key, _, value = item.partition("=")
        try:
            overrides[key] = json.loads(value)
        except json.JSONDecodeError:
            overrides[key] = value
    if args.duration_s is not None:
        overrides["duration_s"] = args.duration_s
    if args.count is not None:
        overrides["count"] = args.count
    try:
        result = simulate_scenario(args.scenario, Path(args.out), seed=args.seed, overrides=overrides)
    except ValueError as exc:
        sys.exit(f"gnssatt simulate: {exc}")
    for entry in result.sets:
        print(entry["dir"])


def cmd_run(args) -> None:
    """Run a job here, without a server: the worker's pipeline on local files (worker/local.py)."""
    from gnssatt.gnss.io.errors import ParseError
    from worker.errors import JobInputError
    from worker.local import ANSWER_KEY_FOLDER, local_set, run_job_locally

    for d in [*(args.paths or []), *(args.set or [])]:
        if (Path(d) / ANSWER_KEY_FOLDER).is_dir():
            print(f"note: {Path(d) / ANSWER_KEY_FOLDER}/ left out (a simulated set's answer key, not an input)",
                  file=sys.stderr)
    config = json.loads(Path(args.config).read_text()) if args.config else {}
    pcv_maps = {}
    for item in args.pcv_map or []:
        map_id, sep, path = item.partition("=")
        pcv_maps[map_id if sep else Path(map_id).stem] = Path(path if sep else map_id)
    try:
        sets = ([local_set([Path(p) for p in args.paths], "set-1")] if args.paths else [])
        for d in args.set or []:  # numbered after the sets before it (a comprehension would see len(sets) fixed)
            sets.append(local_set([Path(d)], f"set-{len(sets) + 1}"))
        written = run_job_locally(args.type, sets, config, Path(args.out), pcv_maps=pcv_maps,
                                  progress=None if args.quiet else _stderr_progress())
    except JobInputError as exc:
        sys.exit(f"gnssatt run: {exc.title}: {exc.detail}")
    except ParseError as exc:
        sys.exit(f"gnssatt run: {exc}")
    for path in written.values():
        print(path)


def _stderr_progress():
    from worker.local import stderr_progress

    return stderr_progress


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gnssatt", description="GNSS attitude determination service and client.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("serve", help="run the HTTP API")
    s.add_argument("--host", default="127.0.0.1")
    s.add_argument("--port", type=int, default=8000)
    s.set_defaults(func=cmd_serve)

    s = sub.add_parser("worker", help="run a worker that processes jobs")
    s.add_argument("--concurrency", type=int, default=None)
    s.set_defaults(func=cmd_worker)

    admin = sub.add_parser("admin", help="operator commands (talk to the database directly)")
    asub = admin.add_subparsers(dest="admin_command", required=True)
    s = asub.add_parser("create-key", help="mint an API key for a team (created if new)")
    s.add_argument("--team", required=True)
    s.add_argument("--label", default=None)
    s.set_defaults(func=cmd_create_key)
    s = asub.add_parser("revoke-key", help="revoke a key (give the key, or its first 10 characters)")
    s.add_argument("key")
    s.set_defaults(func=cmd_revoke_key)

    def client_opts(sp):
        sp.add_argument("--url", default=None, help="API base URL (env GNSSATT_URL)")
        sp.add_argument("--key", default=None, help="API key (env GNSSATT_API_KEY)")

    s = sub.add_parser("submit", help="upload files, run a job, wait, download its products")
    client_opts(s)
    s.add_argument("--type", required=True)
    s.add_argument("--config", default=None, help="JSON file with the job config")
    s.add_argument("--name", default=None, help="name of the observation set")
    s.add_argument("--out", default=None, help="directory for the products")
    s.add_argument("--no-wait", action="store_true", help="print the job id and return")
    s.add_argument("paths", nargs="+")
    s.set_defaults(func=cmd_submit)

    s = sub.add_parser("run", help="run a job here on local files, without a server (same pipeline as the worker)")
    s.add_argument("type", help="job type (inspect, attitude, calibration, ttff, simulate, selftest)")
    s.add_argument("paths", nargs="*", help="files (or directories) of the first observation set")
    s.add_argument("--set", action="append", metavar="DIR", help="one more observation set: a directory of files "
                   "(repeat for jobs taking several sets, e.g. calibration)")
    s.add_argument("--config", default=None, help="JSON file with the job config")
    s.add_argument("--pcv-map", action="append", metavar="[ID=]FILE", help="a PCV map (CONVENTIONS JSON) the "
                   "config names by id (default id: the file's stem)")
    s.add_argument("--out", default="products", help="directory for the products")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_run)

    s = sub.add_parser("status", help="one job, or the list of jobs")
    client_opts(s)
    s.add_argument("job_id", nargs="?", help="a job id or a unique prefix of one (at least 4 characters)")
    s.add_argument("--state", default=None)
    s.add_argument("--limit", type=int, default=20)
    s.set_defaults(func=cmd_status)

    s = sub.add_parser("fetch", help="download a job's products")
    client_opts(s)
    s.add_argument("job_id", help="a job id or a unique prefix of one (at least 4 characters)")
    s.add_argument("--out", default=None)
    s.add_argument("--wait", action="store_true")
    s.set_defaults(func=cmd_fetch)

    s = sub.add_parser("delete", help="delete a finished job (with its products) or an observation set")
    client_opts(s)
    s.add_argument("what", choices=("job", "set"))
    s.add_argument("id", help="a job or set id, or a unique prefix of one (at least 4 characters)")
    s.set_defaults(func=cmd_delete)

    s = sub.add_parser("simulate", help="write a simulated observation set (truth simulator)")
    s.add_argument("--scenario", default="earth-pointing")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--duration-s", type=float, default=None)
    s.add_argument("--count", type=int, default=None)
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a preset parameter")
    s.add_argument("--list", action="store_true", help="list the scenarios and their parameters")
    s.add_argument("--out", default="sim-out")
    s.set_defaults(func=cmd_simulate)
    return p


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line; files may stand after the options too (`gnssatt run attitude --out p/ a.rnx b.rnx`):
    argparse gives a `nargs="*"` positional nothing once an option came first, so such leftovers join `paths`."""
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    if rest:
        if hasattr(args, "paths") and not any(r.startswith("-") for r in rest):
            args.paths = [*(args.paths or []), *rest]
        else:
            parser.error(f"unrecognized arguments: {' '.join(rest)}")
    return args


def one_line_error(exc: BaseException, args) -> str | None:
    """The one line printed for an error a user can fix (server unreachable, key refused, timeouts), or None."""
    import httpx

    url = getattr(args, "url", None) or os.environ.get("GNSSATT_URL") or "http://127.0.0.1:8000"
    if isinstance(exc, ApiError) and exc.status in (401, 403):
        return (f"gnssatt: the service at {url} refused the API key ({exc.status} {exc.problem.get('title', '')}): "
                "check --key / GNSSATT_API_KEY (an operator mints keys with 'gnssatt admin create-key --team NAME')")
    if isinstance(exc, ApiError):
        return f"gnssatt: {exc}"
    if isinstance(exc, httpx.ConnectError):
        return (f"gnssatt: cannot connect to the service at {url} ({exc}): is it running ('make demo' or "
                "'gnssatt serve')? Set --url / GNSSATT_URL for another address")
    if isinstance(exc, httpx.TimeoutException):
        return f"gnssatt: the service at {url} did not answer in time ({exc.__class__.__name__})"
    if isinstance(exc, httpx.TransportError):
        return f"gnssatt: connection to {url} failed: {exc.__class__.__name__}: {exc}"
    if isinstance(exc, TimeoutError):
        return f"gnssatt: {exc}"
    return None


def main(argv: list[str] | None = None) -> None:
    args = parse(argv)
    try:
        args.func(args)
    except Exception as exc:  # noqa: BLE001 - errors a user can fix are one line; others keep their traceback
        line = one_line_error(exc, args)
        if line is None:
            raise
        print(line, file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
