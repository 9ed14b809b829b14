# volcal: the two commands of the README are `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: all install test lint demo bench study clean browser-deps

all: test

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

install: $(STAMP)

# Headless Chromium and poppler (pdftoppm) for the report tests; Debian packages, run as
# root. Does nothing when both are present.
browser-deps:
	@if [ -x /usr/bin/chromium ] && command -v pdftoppm >/dev/null; then :; else \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	    --no-install-recommends chromium poppler-utils; fi

test: $(STAMP) browser-deps
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks

demo: $(STAMP)
	$(BIN)/volcal demo -o demo-output

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

study: $(STAMP)
	$(BIN)/python benchmarks/study.py --design all --machines 10 --markdown --quiet
	$(BIN)/python benchmarks/study.py --drift --design all --machines 10 --markdown --quiet

clean:
	rm -rf $(VENV) demo-output .pytest_cache .ruff_cache
