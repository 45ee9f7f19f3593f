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
    for pkg in sorted(packages | {"pyproject.toml", "requirements"}):
        assert pkg in copied, f"docker/Dockerfile does not COPY {pkg}"


def test_dockerfile_installs_from_the_lock():
    """The image gets the tested versions: the hash-checked lock, and the project without resolving again."""
    text = (REPO_ROOT / "docker" / "Dockerfile").read_text()
    assert re.search(r"pip install .*--require-hashes .*-r requirements/lock\.txt", text)
    project = [line for line in text.splitlines() if re.search(r"pip install .* \.$", line)]
    assert project and all("--no-deps" in line for line in project), project


def test_lock_pins_every_package_with_hashes():
    """Every requirement of the lock is `name==version` with at least one sha256, and pyproject's direct
    dependencies are all in it (a dependency added to pyproject without `make lock` fails here)."""
    lock = (REPO_ROOT / "requirements" / "lock.txt").read_text()
    entries = re.findall(r"^([A-Za-z0-9_.-]+)==(\S+) \\\n((?:\s+--hash=sha256:[0-9a-f]{64}(?: \\)?\n)+)", lock, re.M)
    names = {n.lower().replace("_", "-") for n, _, _ in entries}
    assert len(entries) == len(re.findall(r"^[A-Za-z0-9]", lock, re.M)), "an entry without version or hash"
    import tomllib

    proj = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]
    direct = proj["dependencies"] + proj["optional-dependencies"]["test"]
    for req in direct:
        name = re.match(r"[A-Za-z0-9_.-]+", req).group(0).lower().replace("_", "-")
        assert name in names, f"{name} is in pyproject.toml but not in requirements/lock.txt (run make lock)"


def test_readme_documents_every_setting():
    readme = (REPO_ROOT / "README.md").read_text()
    for name in Settings.model_fields:
        assert f"GNSSATT_{name.upper()}" in readme, name
