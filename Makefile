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

.PHONY: venv browser demo stop test test-fast openapi bench clean

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -e ".[test]"
	touch $@

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

test: venv browser
	GNSSATT_TEST_DATABASE_URL="$(GNSSATT_TEST_DATABASE_URL)" GNSSATT_TEST_QUEUE_URL="$(GNSSATT_TEST_QUEUE_URL)" \
	  $(PY) -m pytest -q -p no:cacheprovider

test-fast: venv
	$(PY) -m pytest -q -p no:cacheprovider -m "not e2e"

openapi: venv
	$(PY) -m app.openapi_export openapi/openapi.json

bench: venv
	$(PY) bench/bench_service_load.py

clean:
	rm -rf $(VENV) var .pytest_cache
