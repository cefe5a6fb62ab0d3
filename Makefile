# inkmotion — two commands: `make demo` and `make test`.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
DEMO_OUT ?= results/demo
DEMO_INPUT ?= text:inkmotion

.PHONY: demo demo-picture test venv test-venv redis postgres browser gallery lint bench docs clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip

# setuptools says "Editable installation ... folders with the same name as your package" on
# every editable install of a package-dir layout like ours: a notice, not a problem to fix
$(VENV)/.installed: pyproject.toml | $(VENV)/bin/python
	PYTHONWARNINGS="ignore:Editable installation" $(PIP) install -q -e .
	touch $@

# the test extras, and plugins written outside the package (tests/plugin_package, the
# example of docs/plugins.md in examples/), installed like any third-party plugin so the
# tests can check they are picked up. --no-compile: pip would byte-compile every module of
# every package (torch's thousands among them), 100 of the install's 177 s here, for the
# few hundred a test run imports; `make test` lets Python cache those as it first imports
# them instead (below)
$(VENV)/.installed-test: pyproject.toml tests/plugin_package/pyproject.toml examples/inkmotion-example-plugin/pyproject.toml | $(VENV)/bin/python
	PYTHONWARNINGS="ignore:Editable installation" $(PIP) install -q --no-compile -e ".[test]"
	PYTHONWARNINGS="ignore:Editable installation" $(PIP) install -q -e tests/plugin_package
	PYTHONWARNINGS="ignore:Editable installation" $(PIP) install -q -e examples/inkmotion-example-plugin
	touch $@ $(VENV)/.installed

venv: $(VENV)/.installed

test-venv: $(VENV)/.installed-test

## demo: create .venv, install, fit a word written in a Hershey script font, print where
demo: $(VENV)/.installed
	$(VENV)/bin/inkmotion run fit "$(DEMO_INPUT)" --out $(DEMO_OUT)
	@echo "Results: $(abspath $(DEMO_OUT)) (open drawing.svg, overlay.png, speed.png;" \
	      "replay with: $(VENV)/bin/inkmotion view $(DEMO_OUT)/recording.rrd)"

## demo-picture: the same from a picture: trace the shipped brush scan, then fit it
demo-picture: $(VENV)/.installed
	$(VENV)/bin/inkmotion trace sample:brush-scan --out $(DEMO_OUT)-strokes --force
	$(VENV)/bin/inkmotion run fit sample:brush-scan --varying-width --out $(DEMO_OUT)-picture --force
	@echo "Results: $(abspath $(DEMO_OUT))-strokes/strokes.png (the strokes found, in order)" \
	      "and $(abspath $(DEMO_OUT))-picture/overlay.png (the motion over the picture)"

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

## browser: the gallery's browser tests drive Debian's Chromium; install it if missing
browser:
	@{ command -v chromium >/dev/null && command -v chromedriver >/dev/null; } || { \
	  echo "installing chromium and chromium-driver (Debian packages)"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && $$SUDO apt-get install -y -qq chromium chromium-driver >/dev/null; }

## test: create .venv with the test extras, run the whole suite in TEST_JOBS processes
## (pytest-xdist; most tests wait on servers, workers and subprocesses, so two processes
## finish in about 60 % of the time even on 2 cores); TEST_JOBS=0 runs it in this one.
## PYTHONDONTWRITEBYTECODE is emptied for the run: the test venv is installed without
## bytecode (--no-compile above), and Python writes it as the tests first import a module
TEST_JOBS ?= 2
test: test-venv redis postgres browser
	$(VENV)/bin/ruff check .
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -n $(TEST_JOBS)

## gallery: the curated example set (Hershey words; one with a spray preview, its simulated drawing
## and its evaluation) -> gallery/out, its site -> gallery/site, screenshots -> gallery/screenshots;
## only missing results are computed again
GALLERY_WORDS := $(shell cat gallery/words.txt)
GALLERY_SPRAY ?= motion
GALLERY_FITS := $(GALLERY_WORDS:%=gallery/out/fit-%/plan.json)

gallery/out/fit-%/plan.json: | $(VENV)/.installed
	$(VENV)/bin/inkmotion run fit "text:$*" --size 500 \
	  $(if $(filter $*,$(GALLERY_SPRAY)),--spray-preview) --out gallery/out/fit-$*

gallery/out/robot-$(GALLERY_SPRAY)/job.json: gallery/out/fit-$(GALLERY_SPRAY)/plan.json
	$(VENV)/bin/inkmotion run simulate $< --out gallery/out/robot-$(GALLERY_SPRAY)

gallery/out/evaluate-$(GALLERY_SPRAY)/job.json: gallery/out/fit-$(GALLERY_SPRAY)/plan.json
	$(VENV)/bin/inkmotion run evaluate $< --out gallery/out/evaluate-$(GALLERY_SPRAY)

gallery: test-venv browser $(GALLERY_FITS) gallery/out/robot-$(GALLERY_SPRAY)/job.json \
         gallery/out/evaluate-$(GALLERY_SPRAY)/job.json
	$(VENV)/bin/inkmotion gallery build --no-store --from gallery/out --out gallery/site \
	  --title "inkmotion: the curated gallery"
	$(PY) -m inkmotion.gallery.browser gallery/site gallery/screenshots run-fit-$(GALLERY_SPRAY)-

## docs: regenerate docs/cli.md, the command-line reference, from the kinds' declarations
## and the command tree (tests/test_docs.py fails when it is out of date)
docs: $(VENV)/.installed
	$(PY) -m inkmotion.cli.reference > docs/cli.md.tmp && mv docs/cli.md.tmp docs/cli.md

lint: test-venv
	$(VENV)/bin/ruff check .

bench: venv
	$(VENV)/bin/inkmotion bench

clean:
	rm -rf $(VENV) results .pytest_cache
