"""docker/ matches the service: the compose file runs api, workers, postgres and redis with the same
settings the README documents, and the Dockerfile copies every package the project installs.
(No Docker engine runs here, so the images themselves are built elsewhere.)"""
from __future__ import annotations

import re
import tomllib

import yaml

from core.settings import Settings
from tests.conftest import REPO_ROOT


def test_compose_services_and_settings():
    doc = yaml.safe_load((REPO_ROOT / "docker" / "compose.yaml").read_text())
    services = doc["services"]
    assert {"api", "worker", "postgres", "redis"} <= set(services)
    assert services["api"]["command"][:2] == ["gnssatt", "serve"]
    assert services["worker"]["command"][:2] == ["gnssatt", "worker"]
    fields = {f"GNSSATT_{name.upper()}" for name in Settings.model_fields}
    for name in ("api", "worker"):
        env = services[name]["environment"]
        assert set(env) <= fields, set(env) - fields
        assert env["GNSSATT_DATABASE_URL"].startswith("postgresql+psycopg://")
        assert env["GNSSATT_QUEUE_URL"].startswith("redis://")


def test_dockerfile_copies_every_package():
    text = (REPO_ROOT / "docker" / "Dockerfile").read_text()
    copied = set(re.findall(r"^COPY (\S+) ", text, re.M))
    # every top-level package pyproject installs (its `include` patterns), read from pyproject itself
    include = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]["find"]
    packages = {pattern.rstrip("*") for pattern in include["include"]}
    assert {"gnssatt", "core", "app", "worker", "client", "migrations"} <= packages, packages
    for pkg in sorted(packages | {"pyproject.toml"}):
        assert pkg in copied, f"docker/Dockerfile does not COPY {pkg}"


def test_readme_documents_every_setting():
    readme = (REPO_ROOT / "README.md").read_text()
    for name in Settings.model_fields:
        assert f"GNSSATT_{name.upper()}" in readme, name
