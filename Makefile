# facepair: the two commands a newcomer needs.
#   make demo   set up .venv and run the demo (the embedded default: SQLite, local files);
#               make demo PORT=8080 HOST=0.0.0.0 to serve elsewhere. It prints the links and
#               the login; pip's, apt's and the demo's own output go to instance/demo.log
#   make test   set up .venv, the Debian packages, axe-core and puppeteer-core the tests need,
#               lint, then run every test
#   make lint   ruff on the whole tree, mypy on the pure packages, the size check of modules,
#               functions and page scripts (also the first step of test)
#   make lock   remake requirements.lock from pyproject.toml's newest allowed versions
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP_RUN := $(VENV)/.installed-runtime
STAMP := $(VENV)/.installed-test
# Every package installed, pinned (pip's -c): the toolchain (pip, ruff, mypy, pytest) and every
# dependency, so a release of one cannot turn CI red; make lock remakes it.
LOCK := requirements.lock
PORT ?= 5000
# pytest-xdist workers for make test (each takes its own test databases: tests/support/services.py).
# One process more than the two cores: a third of a run is spent waiting (browsers, servers,
# sounds, workers starting), and a third process fills it (docs/developer/testing.md). Each
# module's tests go to one process, so a module's fixtures (a trained model, a texture, an
# installed wheel) are built once, not once in every process that gets one of its tests; the
# modules go out in the order tests/conftest.py gives them (the long ones first).
TEST_WORKERS ?= 3
TEST_DIST ?= loadscope --no-loadscope-reorder
HOST ?= 127.0.0.1
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# Debian packages: EGL/Mesa for headless rendering, chromium + driver for browser tests,
# nginx for the front-proxy test (X-Accel-Redirect); espeak-ng, festival with two voices and
# sox for the voices the stimuli tests synthesise; R with lme4, BradleyTerry2 and psychotools,
# the references the analysis tests compare with; npm for axe-core (accessibility checks) and
# puppeteer-core, from Debian only where no npm command is there (a Node.js install may bring
# its own); Firefox ESR (driven by puppeteer-core) and WebKitGTK's driver with Xvfb, its
# display, for the participant flow in every engine (tests/support/engines.py).
DEBS_TEST := chromium chromium-driver firefox-esr webkit2gtk-driver xvfb \
	libegl1 libgl1-mesa-dri libegl-mesa0 nginx-light \
	espeak-ng festival festvox-us-slt-hts festvox-kallpc16k sox \
	r-base-core r-cran-lme4 r-cran-bradleyterry2 r-cran-psychotools
DEBS_DEMO := libegl1 libgl1-mesa-dri libegl-mesa0
# Where the set-up's output goes (pip's and apt's, warnings included): the demo's log file for
# make demo (the greeting names it), .cache/setup.log otherwise; a failed step shows its tail.
DEMO_LOG := instance/demo.log
SETUP_LOG := .cache/setup.log
demo: SETUP_LOG := $(DEMO_LOG)
# Run a set-up command quietly: its output appended to $(SETUP_LOG), shown only if it fails.
logged = mkdir -p $(dir $(SETUP_LOG)) && { echo "== $(1)"; $(1); } >>$(SETUP_LOG) 2>&1 || \
	{ echo "failed: $(1); the end of $(SETUP_LOG):"; tail -n 15 $(SETUP_LOG); exit 1; }

.PHONY: demo test venv debs-test debs-demo axe puppeteer lint lock bench clean

venv: $(STAMP)

# The demo needs the runtime dependencies only; the tests add pytest, playwright, ruff, mypy.
$(STAMP_RUN): pyproject.toml $(LOCK)
	@echo "setting up $(VENV) (the first time: a few minutes; pip's output in $(SETUP_LOG))"
	@test -x $(PY) || { $(call logged,$(PYTHON) -m venv $(VENV)); }
	@$(call logged,$(PY) -m pip install -q -c $(LOCK) --upgrade pip)
	@$(call logged,$(PY) -m pip install -q -c $(LOCK) -e .)
	@touch $(STAMP_RUN)

$(STAMP): $(STAMP_RUN) pyproject.toml $(LOCK)
	@$(call logged,$(PY) -m pip install -q -c $(LOCK) -e '.[test]')
	@touch $(STAMP)

# apt-get update runs once, and only when a package is missing.
debs-test:
	@missing=$$(for p in $(DEBS_TEST); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done; \
	  command -v npm >/dev/null 2>&1 || echo npm); \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages: $$(echo $$missing) (apt's output in $(SETUP_LOG))"; \
	  $(call logged,$(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing); \
	fi

debs-demo:
	@missing=$$(for p in $(DEBS_DEMO); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages: $$(echo $$missing) (apt's output in $(SETUP_LOG))"; \
	  $(call logged,$(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing); \
	fi

# axe-core from the npm registry into .cache/axe-core (its pinned version: tests/support/axe.py);
# the browser tests inject it into every page type.
axe: $(STAMP) debs-test
	$(PY) -m tests.support.axe

# puppeteer-core from the npm registry into .cache/puppeteer-core, with no browser download (its
# pinned version: tests/support/puppeteer.py); it drives Debian's Firefox ESR over WebDriver BiDi.
puppeteer: $(STAMP) debs-test
	$(PY) -m tests.support.puppeteer

test: $(STAMP) debs-test axe puppeteer lint
	$(PY) -m pytest -n $(TEST_WORKERS) --dist $(TEST_DIST)

demo: $(STAMP_RUN) debs-demo
	@$(VENV)/bin/facepair demo --host $(HOST) --port $(PORT) --log $(DEMO_LOG)

# A fresh environment with pyproject.toml's dependencies at their newest allowed versions, frozen
# into requirements.lock (docs/developer/testing.md: run make test on it before committing it).
lock:
	rm -rf .cache/lock-venv
	$(PYTHON) -m venv .cache/lock-venv
	.cache/lock-venv/bin/pip install -q --upgrade pip
	.cache/lock-venv/bin/pip install -q -e '.[test]'
	{ sed -n '1,3p' $(LOCK); .cache/lock-venv/bin/pip freeze --all --exclude-editable; } > $(LOCK).new
	mv $(LOCK).new $(LOCK)
	rm -rf .cache/lock-venv

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy app/stimuli app/analysis app/trials app/leaderboard renderer
	$(PY) -m tests.support.sizes

bench: $(STAMP)
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) .pytest_cache build dist *.egg-info .cache/axe-core .cache/puppeteer-core
