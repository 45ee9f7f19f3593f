# gnssatt: two commands on a fresh machine.
#   make demo   set up, start API + worker on the embedded default (SQLite + Huey), run a job, print its products
#   make test   set up and run the whole test suite (also against PostgreSQL + Redis when reachable)
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
GNSSATT := $(VENV)/bin/gnssatt
DEMO_DIR := $(CURDIR)/var
DEMO_PORT ?= 8000
export GNSSATT_DATA_DIR ?= $(DEMO_DIR)

# PostgreSQL + Redis for the scale-out variant of the end-to-end tests (this machine runs both on loopback).
GNSSATT_TEST_DATABASE_URL ?= postgresql+psycopg://postgres@127.0.0.1:5432/test
GNSSATT_TEST_QUEUE_URL ?= redis://127.0.0.1:6379/0

.PHONY: venv browser demo stop test test-fast test-latest lock lock-upgrade openapi bench clean

LOCK := requirements/lock.txt
UV := .venv-tools/bin/uv
LOCK_ARGS := pyproject.toml requirements/build.in --extra test --generate-hashes --python-version 3.11 \
  --python-platform x86_64-unknown-linux-gnu --no-header -o $(LOCK)

# The venv installs the locked versions (hash-checked), then the project itself without resolving anything;
# it is rebuilt when the lock changes (docs/DEPENDENCIES.md).
$(VENV)/.installed: $(LOCK) pyproject.toml
	@echo "==> creating $(VENV) (python: $$($(PYTHON) --version))"
	rm -rf $(VENV)
	$(PYTHON) -m venv $(VENV)
	@echo "==> installing the locked dependencies from $(LOCK) (hash-checked; a first install downloads ~300 MB)"
	$(VENV)/bin/pip install --quiet --require-hashes --no-deps -r $(LOCK)
	$(VENV)/bin/pip install --quiet --no-deps --no-build-isolation -e .
	@echo "==> compiling the filter's numba kernels into the on-disk cache (once)"
	$(PY) -c "import worker.main as m; m._warm_up_kernels()"
	touch $@

$(UV):
	$(PYTHON) -m venv .venv-tools
	.venv-tools/bin/pip install --quiet uv

# Re-resolve the lock from pyproject.toml, keeping the locked versions that still satisfy it.
lock: $(UV)
	$(UV) pip compile $(LOCK_ARGS)

# Move every package of the lock to the newest version pyproject allows (then run `make test`, commit).
lock-upgrade: $(UV)
	$(UV) pip compile --upgrade $(LOCK_ARGS)

# The suite on the newest versions pyproject allows, in a venv of its own (the lock is not used).
test-latest: browser
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/pip install --quiet --upgrade pip
	.venv-latest/bin/pip install --quiet --upgrade -e ".[test]"
	.venv-latest/bin/pip freeze | grep -iE "^(numpy|numba|llvmlite|scipy|fastapi|pydantic)=="
	GNSSATT_TEST_DATABASE_URL="$(GNSSATT_TEST_DATABASE_URL)" GNSSATT_TEST_QUEUE_URL="$(GNSSATT_TEST_QUEUE_URL)" \
	  .venv-latest/bin/python -m pytest -q -p no:cacheprovider

venv: $(VENV)/.installed

demo: venv
	@$(PY) -m client.demo --port $(DEMO_PORT) --data-dir "$(DEMO_DIR)"

stop:
	@$(PY) -m client.demo --stop --data-dir "$(DEMO_DIR)"

# The browser tests drive the system's Chromium (Debian package `chromium`) through Playwright; Playwright never
# downloads a browser of its own here.
browser:
	@command -v chromium >/dev/null 2>&1 || (apt-get update -qq && apt-get install -y -qq chromium >/dev/null) \
	  || echo "could not install chromium (not root?): the browser tests will say so"

# The suite runs on every core (pytest-xdist), a test file per worker process at a time (--dist loadfile: a file's
# module fixtures are built once); the 25 slowest tests are listed at the end.
TEST_WORKERS ?= auto
test: venv browser
	GNSSATT_TEST_DATABASE_URL="$(GNSSATT_TEST_DATABASE_URL)" GNSSATT_TEST_QUEUE_URL="$(GNSSATT_TEST_QUEUE_URL)" \
	  $(PY) -m pytest -q -p no:cacheprovider -n $(TEST_WORKERS) --dist loadfile --durations=25

test-fast: venv
	$(PY) -m pytest -q -p no:cacheprovider -m "not e2e"

openapi: venv
	$(PY) -m app.openapi_export openapi/openapi.json

bench: venv
	$(PY) bench/bench_service_load.py

clean:
	rm -rf $(VENV) .venv-latest .venv-tools var .pytest_cache
