# `make run` and `make test` set up everything they need (venv, Python packages, npm packages,
# UI build) and redo only what changed since the last time.

SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
UI := webui/frontend
PY_STAMP := $(VENV)/.installed
NPM_STAMP := $(UI)/node_modules/.installed
UI_BUILT := $(UI)/dist/index.html
UI_SOURCES := $(shell find $(UI)/src $(UI)/public -type f 2>/dev/null) \
	$(UI)/index.html $(UI)/vite.config.ts $(UI)/tsconfig.json $(UI)/tsconfig.node.json
ARGS ?=

.PHONY: setup run test lint bench ui clean screenshots

setup: $(PY_STAMP) $(UI_BUILT)

$(PY_STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	# Byte-compiled at install (not --no-compile): where PYTHONDONTWRITEBYTECODE is set, as on
	# this project's machines, nothing is compiled later, and every process would compile every
	# module it imports, every time (the suite ran 4 minutes longer).
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $@

$(NPM_STAMP): $(UI)/package.json $(UI)/package-lock.json
	cd $(UI) && npm ci --no-audit --no-fund
	touch $@

$(UI_BUILT): $(NPM_STAMP) $(UI_SOURCES)
	cd $(UI) && npm run build

ui: $(UI_BUILT)

run: setup
	$(BIN)/openpendant run $(ARGS)

lint: $(PY_STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

# The whole suite (tests/suite.py: real-time tests one at a time, the rest and the lint
# alongside them); with ARGS, the lint, then pytest with those (e.g. ARGS="-k jog").
test: setup
ifeq ($(strip $(ARGS)),)
	$(BIN)/python -m tests.suite
else
	$(MAKE) lint
	$(BIN)/pytest $(ARGS)
endif

# Every panel on a tablet and a phone, dark and light, into docs/screenshots/.
screenshots: setup
	$(BIN)/python -m tests.screenshots $(ARGS)

bench: setup
	$(BIN)/openpendant bench --json bench-results/latest.json $(ARGS)

clean:
	rm -rf $(VENV) $(UI)/node_modules $(UI)/dist .mypy_cache .ruff_cache .pytest_cache
