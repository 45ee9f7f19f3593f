"""The CLI against the real app in-process (TestClient's transport) with an immediate queue, so a job runs inside
the command; run_cli gives (exit code, stdout, stderr) of one command."""
from __future__ import annotations

import sys

import pytest
from fastapi.testclient import TestClient

import client.cli as cli
from app.keys import create_key
from app.main import create_app
from client.api import GnssattClient
from core.settings import Settings
from worker import runner
from worker.main import build_runtime


@pytest.fixture
def service(tmp_path, monkeypatch):
    settings = Settings(data_dir=tmp_path / "var")
    rt = build_runtime(settings, immediate=True, name="cli-test-worker")
    app = create_app(settings)
    with TestClient(app, raise_server_exceptions=False) as tc:
        app.state.huey = rt.huey
        with rt.Session.begin() as s:
            key, _ = create_key(s, "team-cli")
        monkeypatch.setattr(cli, "_client", lambda args: GnssattClient("http://testserver", args.key,
                                                                         transport=tc._transport))
        tc.rt, tc.key = rt, key
        tc.headers["Authorization"] = f"Bearer {key}"
        yield tc
    runner.set_runtime(None)
    rt.engine.dispose()


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    code = 0
    try:
        cli.main(list(argv))
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
        if isinstance(exc.code, str):
            print(exc.code, file=sys.stderr)
    out = capsys.readouterr()
    return code, out.out, out.err
