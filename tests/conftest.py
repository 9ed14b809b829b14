"""Shared helpers of the foundation tests: random machines, chains and measurements."""

from __future__ import annotations

import glob
import itertools
import os
import shutil
import socket
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from volcal.measure.virtual import random_machine
from volcal.model.errorfunctions import MachineErrors
from volcal.session.format import Measurement

# CI runs the property tests on a fixed set of examples (a failure is reproducible and does
# not come and go between runs); HYPOTHESIS_PROFILE=explore draws new examples each run.
# No wall-time check either (a busy box must not fail a test): no deadline, and not the
# health check that fails when generating the examples takes long.
_NOT_TIMED = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow]}
settings.register_profile("ci", derandomize=True, **_NOT_TIMED)
settings.register_profile("explore", **_NOT_TIMED)
# the slow fuzz run of session files (tests/session/test_fuzz_sessions.py, README): new examples
settings.register_profile("fuzz", **_NOT_TIMED)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 500.0]])

ALL_CHAINS: tuple[str, ...] = tuple(
    "".join(p) for p in itertools.permutations("FXYZ")
)
"""All 24 chain codes."""


def machine(chain: str = "XYFZ", seed: int = 0, scale: float = 1.0,
            travel=TRAVEL, n_nodes: int = 41) -> MachineErrors:
    """A random realistic machine, all errors multiplied by ``scale``."""
    return random_machine(travel, chain, seed, n_nodes=n_nodes).scaled(scale)


def only(m: MachineErrors, names: dict[str, float | np.ndarray]) -> MachineErrors:
    """Copy of ``m`` with every error zero except the named ones.

    Values are constants or arrays on the axis' nodes; squareness values are constants.
    """
    out = m.scaled(0.0)
    for name, val in names.items():
        from volcal.model.names import COMPONENT_NAMES, SQUARENESS_NAMES

        if name in SQUARENESS_NAMES:
            out.squareness[SQUARENESS_NAMES.index(name)] = val
        else:
            idx = COMPONENT_NAMES.index(name)
            out.values[idx // 6][:, idx % 6] = val
    return out


def meas(positions, target="retroreflector", beam=None, tool_offset=(0, 0, 0),
         kind="step_diagonal") -> Measurement:
    """A measurement skeleton at the given positions."""
    p = np.asarray(positions, dtype=float)
    if beam is None:
        d = p[-1] - p[0]
        beam = d / np.linalg.norm(d)
    return Measurement("m", kind, target, p, None, beam, np.asarray(tool_offset, float))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


# ---------------------------------------------------------------- history store fixtures
# PostgreSQL is a real server: a throw-away cluster made with the Debian package's initdb
# and started with pg_ctl on a free port, as the unprivileged 'postgres' user when the tests
# run as root (PostgreSQL refuses to run as root). Skipped, with the reason, only where no
# PostgreSQL server is installed (`make postgres-deps` installs it).
_counter = itertools.count()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _as_postgres(cmd: list[str]) -> list[str]:
    if os.geteuid() != 0:
        return cmd
    return ["runuser", "-u", "postgres", "--", *cmd]


@pytest.fixture(scope="session")
def postgres_server():
    """URL prefix of a running PostgreSQL server (``postgresql://postgres@127.0.0.1:P``)."""
    bins = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    if not bins:
        pytest.skip("PostgreSQL is not installed (make postgres-deps installs Debian's "
                    "postgresql)")
    bindir = Path(bins[-1]).parent
    if os.geteuid() == 0:
        try:
            import pwd

            pw = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("running as root and no 'postgres' user to run the server as")
    tmp = Path(tempfile.mkdtemp(prefix="volcal-pg-"))
    data, sock = tmp / "data", tmp / "sock"
    sock.mkdir()
    if os.geteuid() == 0:
        os.chown(tmp, pw.pw_uid, pw.pw_gid)
        os.chown(sock, pw.pw_uid, pw.pw_gid)
    port = _free_port()
    env = {**os.environ, "LC_ALL": "C.UTF-8"}
    subprocess.run(_as_postgres([str(bindir / "initdb"), "-D", str(data), "-A", "trust",
                                 "-U", "postgres", "-E", "UTF8"]), check=True, env=env,
                   capture_output=True)
    log = tmp / "server.log"
    subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-l", str(log), "-w",
                                 "-o", f"-p {port} -k {sock} -c listen_addresses=127.0.0.1 "
                                 "-c fsync=off -c max_connections=40", "start"]),
                   check=True, env=env, capture_output=True)
    try:
        yield f"postgresql://postgres@127.0.0.1:{port}"
    finally:
        subprocess.run(_as_postgres([str(bindir / "pg_ctl"), "-D", str(data), "-m", "immediate",
                                     "stop"]), env=env, capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)


def new_database(server: str) -> str:
    """A fresh, empty database on the server; its URL."""
    import psycopg

    name = f"volcal_test_{os.getpid()}_{next(_counter)}"
    with psycopg.connect(f"{server}/postgres", autocommit=True) as conn:
        conn.execute(f"CREATE DATABASE {name}")
    return f"{server}/{name}"


@pytest.fixture(params=["sqlite", "postgresql"])
def store_url(request, tmp_path):
    """URL of an empty store, once per backend."""
    if request.param == "sqlite":
        return str(tmp_path / "history.sqlite")
    return new_database(request.getfixturevalue("postgres_server"))


# LinuxCNC itself, headless in simulation (tests/linuxcnc_sim.py): the fixture linuxcnc_sim;
# the model's U drawn once per model (tests/model_u_once.py): the fixture model_u_once;
# reports with less drawing (tests/report_stubs.py): the fixtures blank_figures, stub_pdfs
from linuxcnc_sim import linuxcnc_sim  # noqa: E402, F401
from model_u_once import model_u_once  # noqa: E402, F401
from report_stubs import blank_figures, stub_pdfs  # noqa: E402, F401

# ---------------------------------------------------------------- order of the test files
LINUXCNC_FILES: tuple[str, ...] = (
    "compensate/test_trt_closed_loop.py", "capture/test_linuxcnc_capture.py",
    "compensate/test_linuxcnc_control.py", "compensate/test_trt_halcmd.py",
)
"""The test files that run LinuxCNC (one at a time per box: ``linuxcnc_sim``'s lock).
``make test`` runs them in a process of its own beside the workers (the Makefile's
REALTIME_TESTS); a plain ``pytest -n 2 --dist loadfile`` gives them to one worker as one
unit of work (:func:`pytest_xdist_make_scheduler`), first, so the other worker never waits
on the lock while they run."""

REPORT_FIXTURE_FILES: tuple[str, ...] = (
    "report/test_report_render.py", "report/test_report_cli.py", "report/test_evaluate_once.py",
    "report/test_report_customer_pdf.py", "report/test_report_pdf.py",
    "report/test_report_browser.py", "report/test_report_sections.py",
)
"""The test files of tests/report/report_fixtures.py's session fixtures (the simulated
session identified once; the report rendered once, ``written_report``, about 10 s). ``make
test`` gives them to one worker as one unit of work (:func:`pytest_xdist_make_scheduler`),
so the session is identified and the report rendered once per run, not once per worker."""

HISTORY_FIXTURE_FILES: tuple[str, ...] = (
    "history/test_uncertainty_stored.py", "history/test_signing.py",
    "history/test_damaged_store.py", "history/test_qif.py", "history/test_load.py",
    "history/test_report_previous.py", "history/test_fuzz_store.py",
)
"""The test files of tests/history/history_fixtures.py's ``history_two`` (two calibrations
simulated and identified, one of them added to a store: seconds of CPU), one unit of work
for ``make test`` (:func:`pytest_xdist_make_scheduler`): built once per run, not once per
worker."""

LONGEST_FIRST: tuple[str, ...] = (
    *LINUXCNC_FILES, *REPORT_FIXTURE_FILES,
    "cli/test_cli_bad_input.py", "history/test_history.py", "history/test_uncertainty_stored.py",
    "test_python_parity_budget.py", "standards/test_model_uncertainty.py",
    "identify/test_systematic_optics.py", "test_python_docs.py",
    "identify/test_optics_roundtrip.py", "identify/test_multilateration_roundtrip.py",
    "identify/test_outliers.py", "history/test_records.py", "cli/test_missed_capture_flow.py",
    "report/test_certificate_optics.py", "history/test_signing.py",
    "report/test_certificate.py", "report/test_certificate_number.py",
    "identify/test_families.py", "kinds/test_kind_plugin.py", "test_python_flow.py",
    "history/test_damaged_store.py", "history/test_change_test.py",
    "standards/test_incomplete.py", "identify/test_identify_roundtrip.py",
    "identify/test_solver_contract.py", "identify/test_identify_features.py",
    "identify/test_estimator_parts.py", "cli/test_uncertainty_chain.py",
)
"""The test files that took longest in ``make test`` (benchmarks/README.md, "make test
time"), longest first. ``make test`` gives each of its two workers one file at a time in
collection order (``--dist loadfile --no-loadscope-reorder``; xdist's default order, by
number of tests per file, put the files of one or two long tests such as
``test_python_docs.py`` last, one worker running them alone minutes after the other ran out
of files). Starting with the longest files (the longest-processing-time-first rule)
leaves only short files for the end. A file missing here (renamed, removed) is simply collected
in its usual place; the order of the tests inside a file is unchanged."""


def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with the LinuxCNC files as one unit of work (see LINUXCNC_FILES),
    the files of the shared report fixtures as another (see REPORT_FIXTURE_FILES), and the
    files of the shared history calibrations as a third (see HISTORY_FIXTURE_FILES)."""
    if config.getoption("dist", None) != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    class OneLinuxCNC(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            if any(path.endswith(f) for f in LINUXCNC_FILES):
                return "linuxcnc"
            if any(path.endswith(f) for f in REPORT_FIXTURE_FILES):
                return "report_fixtures"
            if any(path.endswith(f) for f in HISTORY_FIXTURE_FILES):
                return "history_fixtures"
            return super()._split_scope(nodeid)

    return OneLinuxCNC(config, log)


POSTGRESQL_IN_MAKE_TEST: tuple[str, ...] = (
    "history/test_history.py", "history/test_damaged_store.py",
)
"""The test files whose store tests run on both backends in ``make test``. Elsewhere a test
given the store's backend as a parameter (``store_url``, or a module fixture's ``sqlite`` /
``postgresql``) runs on SQLite in ``make test`` and on PostgreSQL too in ``make study``
(marked ``slow`` here): the store reaches both through SQLAlchemy, and what differs between
them (the engine, the server's URL, locking, concurrent writers, the integrity checks of a
damaged store) is what these two files test on both (benchmarks/README.md, "Session 23:
make test within its budget")."""


def _second_backend(item) -> bool:
    """Whether ``item`` is a store test on PostgreSQL outside :data:`POSTGRESQL_IN_MAKE_TEST`."""
    params = getattr(getattr(item, "callspec", None), "params", {})
    if not any(isinstance(v, str) and v == "postgresql" for v in params.values()):
        return False
    path = str(item.path).replace(os.sep, "/")
    return not any(path.endswith(f) for f in POSTGRESQL_IN_MAKE_TEST)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session, config, items):
    """Collect the files of :data:`LONGEST_FIRST` first, in that order; mark the second
    backend's store tests ``slow`` (:data:`POSTGRESQL_IN_MAKE_TEST`)."""
    for it in items:
        if _second_backend(it):
            it.add_marker(pytest.mark.slow)
    root = Path(__file__).parent
    rank = {str(root / f): k for k, f in enumerate(LONGEST_FIRST)}
    late = len(LONGEST_FIRST)
    items[:] = [it for _, it in sorted(enumerate(items), key=lambda p: (
        rank.get(str(p[1].path), late), p[0]))]


@pytest.fixture(autouse=True)
def _history_heads_in_tmp(tmp_path, monkeypatch):
    """The history's kept heads (``volcal.history.heads``) in the test's folder, never in
    the user's ``~/.cache`` (subprocesses inherit the variable)."""
    monkeypatch.setenv("VOLCAL_HISTORY_HEADS", str(tmp_path / "history-heads.json"))
