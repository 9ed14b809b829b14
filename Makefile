# volcal: the two commands of the README are `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: all install test lint demo bench study clean browser-deps linuxcnc-deps

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

# LinuxCNC's standalone G-code interpreter rs274 (Debian package linuxcnc-uspace, in
# bookworm main): the part-program tests run the generated ISO and LinuxCNC programs
# through it. Run as root. Does nothing when rs274 is present; the tests skip with the
# reason when it cannot be installed.
linuxcnc-deps:
	@if command -v rs274 >/dev/null; then :; else \
	  apt-get update -q && apt-cache policy linuxcnc-uspace | grep -q 'Candidate: [0-9]' && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
	    linuxcnc-uspace || echo "linuxcnc-uspace not available: the rs274 tests will skip"; fi

test: $(STAMP) browser-deps linuxcnc-deps
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
	$(BIN)/python benchmarks/study.py --false-alarms 60 --runs 2 --design all
	$(BIN)/python benchmarks/families.py --machines 20 --markdown --quiet

clean:
	rm -rf $(VENV) demo-output .pytest_cache .ruff_cache
