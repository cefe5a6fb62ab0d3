# inkmotion — two commands: `make demo` and `make test`.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
DEMO_OUT ?= results/demo
DEMO_INPUT ?= text:inkmotion

.PHONY: demo test venv test-venv redis postgres lint bench clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip

$(VENV)/.installed: pyproject.toml | $(VENV)/bin/python
	$(PIP) install -q -e .
	touch $@

# the test extras, and plugins written outside the package (tests/plugin_package, the
# example of docs/plugins.md in examples/), installed like any third-party plugin so the
# tests can check they are picked up
$(VENV)/.installed-test: pyproject.toml tests/plugin_package/pyproject.toml examples/inkmotion-example-plugin/pyproject.toml | $(VENV)/bin/python
	$(PIP) install -q -e ".[test]"
	$(PIP) install -q -e tests/plugin_package
	$(PIP) install -q -e examples/inkmotion-example-plugin
	touch $@ $(VENV)/.installed

venv: $(VENV)/.installed

test-venv: $(VENV)/.installed-test

## demo: create .venv, install, fit a word written in a Hershey script font, print where
demo: $(VENV)/.installed
	$(VENV)/bin/inkmotion run fit "$(DEMO_INPUT)" --out $(DEMO_OUT)
	@echo "Results: $(abspath $(DEMO_OUT)) (open drawing.svg, overlay.png, speed.png;" \
	      "replay with: $(VENV)/bin/inkmotion view $(DEMO_OUT)/recording.rrd)"

## redis: the test suite starts its own redis-server; install the Debian package if missing
redis:
	@command -v redis-server >/dev/null || { \
	  echo "installing redis-server (Debian package)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq redis-server >/dev/null; }

## postgres: the PostgreSQL tests start their own server; install the Debian package if missing
postgres:
	@ls /usr/lib/postgresql/*/bin/postgres >/dev/null 2>&1 || command -v postgres >/dev/null || { \
	  echo "installing postgresql (Debian package)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq postgresql >/dev/null; }

## test: create .venv with the test extras, run the whole suite
test: test-venv redis postgres
	$(VENV)/bin/ruff check .
	$(PY) -m pytest -q

lint: test-venv
	$(VENV)/bin/ruff check .

bench: venv
	$(VENV)/bin/inkmotion bench

clean:
	rm -rf $(VENV) results .pytest_cache
