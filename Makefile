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
UI_SOURCES := $(shell find $(UI)/src $(UI)/public -type f -not -path '*/generated/*' 2>/dev/null) \
	$(UI)/index.html $(UI)/vite.config.ts $(UI)/tsconfig.json $(UI)/tsconfig.node.json
# The UI's API types, generated from the services' own models (webui/openapi.py) by
# openapi-typescript, which has a package of its own (it needs TypeScript 5's compiler API).
API_TOOL := $(UI)/tools/openapi
API_TOOL_STAMP := $(API_TOOL)/node_modules/.installed
API_JSON := $(UI)/src/generated/openapi.json
API_CHECKED := $(UI)/src/generated/.checked
API_TYPES := $(UI)/src/generated/api.d.ts
PY_SOURCES := $(shell find runtime webui blockly_blocks plugins device_drivers sandbox \
	-name '*.py' -not -path '*/node_modules/*' 2>/dev/null)
ARGS ?=

.PHONY: setup run test lint bench ui clean screenshots

setup: $(PY_STAMP) $(UI_BUILT)

$(PY_STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	# Byte-compiled at install (not --no-compile): where PYTHONDONTWRITEBYTECODE is set, as on
	# this project's machines, nothing is compiled later, and every process would compile every
	# module it imports, every time (the suite ran 4 minutes longer).
	$(BIN)/python -m pip install --quiet -e '.[dev,rr]'
	touch $@

$(NPM_STAMP): $(UI)/package.json $(UI)/package-lock.json
	cd $(UI) && npm ci --no-audit --no-fund
	touch $@

$(API_TOOL_STAMP): $(API_TOOL)/package.json $(API_TOOL)/package-lock.json
	cd $(API_TOOL) && npm ci --no-audit --no-fund
	touch $@

# Asked again whenever a Python file changed; rewritten (and the UI rebuilt) only if the
# document did.
$(API_CHECKED): $(PY_STAMP) $(PY_SOURCES)
	$(BIN)/openpendant openapi --out $(API_JSON)
	touch $@

$(API_JSON): $(API_CHECKED) ;

$(API_TYPES): $(API_JSON) $(API_TOOL_STAMP)
	cd $(API_TOOL) && node_modules/.bin/openapi-typescript --default-non-nullable false \
		$(CURDIR)/$(API_JSON) -o $(CURDIR)/$@

$(UI_BUILT): $(NPM_STAMP) $(UI_SOURCES) $(API_TYPES)
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
	rm -rf $(VENV) $(UI)/node_modules $(UI)/dist $(API_TOOL)/node_modules $(UI)/src/generated \
		.mypy_cache .ruff_cache .pytest_cache
