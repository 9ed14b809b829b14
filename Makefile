# volcal: the two commands of the README are `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# One BLAS thread per test worker: two pytest workers on the 2-core box, each with
# OpenBLAS's default of one thread per core, made four busy threads on two cores;
# tests/identify took 134-145 s with them and 91-105 s with one (session 16,
# benchmarks/README.md "make test time"). volcal's own commands keep the default.
ONE_BLAS_THREAD := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1

.PHONY: all install bytecode test lint demo bench study clean browser-deps linuxcnc-deps postgres-deps opcua-deps

all: test

# Python writes the bytecode of what it imports (__pycache__/, ignored by git) in every
# recipe, although this box sets PYTHONDONTWRITEBYTECODE: without it each process compiles
# every module it imports again (numpy, scipy, matplotlib, pandas and volcal: 6.4 s to
# import in place of 2.2 s; make test starts about 70 Python processes).
export PYTHONDONTWRITEBYTECODE :=

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# uv (PyPI) installs the project and its extras in 5-10 s where pip took 77 s (66 s of it
# compiling the bytecode of every installed module, most of which the tests never import;
# benchmarks/README.md, "Session 20: the set-up"); pip when uv cannot be had.
EXTRAS := ".[test,history,dataframe,qif,capture]"
$(STAMP): $(BIN)/python pyproject.toml
	if $(BIN)/python -m pip install --quiet uv && \
	  $(BIN)/uv pip install --python $(BIN)/python --quiet -e $(EXTRAS); then :; \
	else $(BIN)/python -m pip install --quiet -e $(EXTRAS); fi
	touch $(STAMP)

install: $(STAMP) bytecode

# Compile volcal's modules to bytecode (__pycache__/) now, for the `volcal` commands run
# outside make (a shell where PYTHONDONTWRITEBYTECODE is set never writes it and compiles
# every module again at each start: 0.1-0.2 s of every command). Existing bytecode is read
# either way; only changed modules are compiled again.
bytecode: $(STAMP)
	$(BIN)/python -m compileall -q src

# Headless Chromium and poppler (pdftoppm) for the report tests, chromium-driver for the
# capture page's test (Selenium); Debian packages, run as root. Does nothing when all are
# present.
browser-deps:
	@if [ -x /usr/bin/chromium ] && command -v pdftoppm >/dev/null && \
	  command -v chromedriver >/dev/null; then :; else \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	    --no-install-recommends chromium poppler-utils chromium-driver; fi

# The independent OPC UA server of the capture tests: npm node-opcua and the OPC 40502
# CNC nodeset (node-opcua-nodesets) into tests/opcua/node_modules, at the versions of
# tests/opcua/package-lock.json; Node.js and npm from Debian when missing (run as root).
# Does nothing when installed; the OPC UA tests skip with the reason when it cannot be.
opcua-deps:
	@if [ -f tests/opcua/node_modules/node-opcua-nodesets/nodesets/Opc.Ua.CNC.NodeSet.xml ] && \
	  [ -d tests/opcua/node_modules/node-opcua ]; then :; else \
	  { command -v npm >/dev/null || { apt-get update -q && DEBIAN_FRONTEND=noninteractive \
	    apt-get install -y -q --no-install-recommends nodejs npm; }; } && \
	  (cd tests/opcua && npm ci --no-audit --no-fund --loglevel=error) || \
	  echo "node-opcua not available: the OPC UA capture tests will skip"; fi

# LinuxCNC's standalone G-code interpreter rs274 (Debian package linuxcnc-uspace, in
# bookworm main): the part-program tests run the generated ISO and LinuxCNC programs
# through it. Run as root. Does nothing when rs274 is present; the tests skip with the
# reason when it cannot be installed.
linuxcnc-deps:
	@if command -v rs274 >/dev/null; then :; else \
	  apt-get update -q && apt-cache policy linuxcnc-uspace | grep -q 'Candidate: [0-9]' && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
	    linuxcnc-uspace || echo "linuxcnc-uspace not available: the rs274 tests will skip"; fi
	@# halcompile builds the closed loop's HAL component (tests/compensate/hal/*.comp)
	@if command -v halcompile >/dev/null || ! command -v rs274 >/dev/null; then :; else \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	    --no-install-recommends linuxcnc-uspace-dev || \
	    echo "linuxcnc-uspace-dev not available: the LinuxCNC closed loop will skip"; fi

# PostgreSQL server for the history tests (Debian package postgresql, run as root). The
# test fixtures start a throw-away cluster as the unprivileged 'postgres' user the
# package creates (PostgreSQL refuses to run as root); they skip with the reason only
# where the package cannot be installed.
postgres-deps:
	@if ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1; then :; else \
	  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q \
	    --no-install-recommends postgresql || echo "postgresql not available: the PostgreSQL history tests will skip"; fi

# Two workers (pytest-xdist), one per core of the 2-core box; a test file stays on one
# worker (--dist loadfile), so module fixtures (rendered reports, identified sessions, the
# PostgreSQL cluster per worker) are built once. The statistical studies marked `slow`
# (many machines each) run in `make study`; a smaller check of each stays here
# (benchmarks/README.md, "make test time"). --no-loadscope-reorder: the files go out in
# collection order, the longest first (tests/conftest.py, LONGEST_FIRST), instead of
# xdist's default by number of tests, which left the files of one or two long tests
# (test_python_docs.py) to the end, one worker running them alone. Two workers: a third
# fills the core the real-time tests leave idle (337 s -> 258-304 s) but starves the
# capture processes beside LinuxCNC (a resumed capture missed a dwell; benchmarks/README.md,
# "Three workers").
#
# The files that wait on real time (LinuxCNC running its programs, the OPC UA server's
# dwells, the browser, a simulated R-test capture run at 20 times real time until it is
# killed: REALTIME_TESTS; 170-200 s of wall time for about 70 s of CPU in session 24,
# chromium's and the OPC UA server's the most) run in a pytest
# process of their own beside the two workers, which run at nice 10: the capture processes
# beside LinuxCNC get a core when they need it (a resumed capture starved by two busy
# workers missed a dwell), and the workers no longer wait on LinuxCNC's real time (3-5 %
# of the wall time on the 2-core box: 509 / 492 s against 521-534 s; benchmarks/README.md,
# "make test time", session 17). Its output follows the workers'.
REALTIME_TESTS := tests/compensate/test_trt_closed_loop.py tests/capture/test_linuxcnc_capture.py \
	tests/compensate/test_linuxcnc_control.py tests/compensate/test_trt_halcmd.py \
	tests/capture/test_capture_opcua.py tests/capture/test_capture_page_browser.py \
	tests/capture/test_capture_page.py tests/capture/test_capture_rtest_kill.py
#
# The tests' temporary folders (pytest's tmp_path, the PostgreSQL cluster, LinuxCNC's
# configurations: TMPDIR) in a folder of their own made for the run on the memory file
# system /dev/shm when it has TEST_TMP_MIN_KB free (removed at the end, whatever the
# outcome), else under the default temporary folder as before. The suite writes and removes
# some 70 000 files; on this box's disk (ext4 mounted with discard) an unlink takes about
# 0.4 ms, and pytest removed the folders of the runs before the last three at the end of
# each session (20-35 s). benchmarks/README.md, "Session 23: make test within its budget".
TEST_TMP_MIN_KB := 4194304
test: $(STAMP) bytecode browser-deps linuxcnc-deps postgres-deps opcua-deps
	@if [ -d /dev/shm ] && [ "$$(df -Pk /dev/shm 2>/dev/null | awk 'NR==2 {print $$4}')" -ge \
	  $(TEST_TMP_MIN_KB) ] 2>/dev/null; then t=$$(mktemp -d /dev/shm/volcal-test.XXXXXX) && \
	  chmod 1777 "$$t" && export TMPDIR="$$t" && trap 'rm -rf "$$t"' EXIT; fi; \
	log=$$(mktemp); \
	$(ONE_BLAS_THREAD) $(BIN)/python -m pytest -p no:cacheprovider -m "not slow" \
	  $(REALTIME_TESTS) > $$log 2>&1 & rt=$$!; \
	$(ONE_BLAS_THREAD) nice -n 10 $(BIN)/python -m pytest -n 2 --dist loadfile \
	  --no-loadscope-reorder -m "not slow" $(addprefix --ignore=,$(REALTIME_TESTS)); cpu=$$?; \
	wait $$rt; r=$$?; echo "--- the real-time files ($(words $(REALTIME_TESTS)) files, one process):"; \
	cat $$log; rm -f $$log; test $$cpu -eq 0 -a $$r -eq 0

# ruff, then the import contracts of pyproject.toml (docs/architecture.md; make test runs
# them too, tests/test_architecture.py), then mypy on src/volcal ([tool.mypy] of
# pyproject.toml; make test does not run it)
lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/lint-imports --no-cache
	$(BIN)/mypy

demo: $(STAMP) bytecode
	$(BIN)/volcal demo -o demo-output

bench: $(STAMP) bytecode postgres-deps
	$(BIN)/python benchmarks/run.py

study: $(STAMP)
	$(ONE_BLAS_THREAD) $(BIN)/python -m pytest -n 2 --dist loadfile -m slow
	$(BIN)/python benchmarks/history_study.py --pairs 40 --power-pairs 20
	$(BIN)/python benchmarks/history_study.py --detectability --steps 4,6,10,20 --runs 1,2,5
	HYPOTHESIS_PROFILE=fuzz VOLCAL_FUZZ_STORES=10000 $(BIN)/python -m pytest -q -p no:cacheprovider tests/history/test_fuzz_store.py
	$(BIN)/python benchmarks/study.py --design all --machines 10 --markdown --quiet
	$(BIN)/python benchmarks/study.py --drift --design all --machines 10 --markdown --quiet
	$(BIN)/python benchmarks/study.py --false-alarms 60 --runs 2 --design all
	$(BIN)/python benchmarks/families.py --machines 20 --markdown --quiet
	$(BIN)/python benchmarks/fiveaxis_study.py --machines 40 --markdown
	$(BIN)/python benchmarks/fiveaxis_fusion_study.py --machines 20 --laser step-diagonal,diagonal,linear,direct
	$(BIN)/python benchmarks/travel_study.py --machines 20 --design full,step --markdown

clean:
	rm -rf $(VENV) demo-output .pytest_cache .ruff_cache .import_linter_cache .mypy_cache
