"""Fixtures of the report tests (a uniquely named module: tests/conftest.py is imported by
name elsewhere, so this folder has no conftest.py of its own)."""

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from timing import scaled_timeout
from volcal.measure.simulate import SimulationOptions, simulate_session, truth_files
from volcal.measure.virtual import random_machine
from volcal.plan.planner import plan_session
from volcal.session.format import read_session, write_session

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync"]


_SHARED: dict = {}
"""Values of the session fixtures, shared by every test module that binds them (each module
binds its own fixture definitions, and pytest caches a session fixture per definition)."""


def _shared(key, make):
    if key not in _SHARED:
        _SHARED[key] = make()
    return _SHARED[key]


@pytest.fixture(scope="session")
def small_session(tmp_path_factory) -> Path:
    """A simulated session: the full test set on a small grid (fast to identify)."""
    return _shared("small_session", lambda: _small_session(tmp_path_factory))


def _small_session(tmp_path_factory) -> Path:
    travel = np.array([[0, 400], [0, 300], [0, 250]], float)
    s = plan_session(travel, "XYFZ", 5, ("step-diagonal", "diagonal", "linear"), 3,
                     name="TEST-VMC")
    vm = random_machine(travel, "XYFZ", seed=11, n_nodes=21)
    opts = SimulationOptions(noise_um=0.3, seed=11)
    setups = simulate_session(s, vm, opts)
    folder = tmp_path_factory.mktemp("sess") / "session"
    write_session(s, folder, truth_files(vm, setups, opts))
    return folder


@pytest.fixture(scope="session")
def identified(small_session):
    from volcal.identify import identify

    def make():
        s = read_session(small_session)
        return s, identify(s)

    return _shared("identified", make)


@pytest.fixture(scope="session")
def written_report(identified, tmp_path_factory):
    from volcal.report.pipeline import collect_inputs
    from volcal.report.sections import build_report
    from volcal.report.writer import write_report

    def make():
        s, r = identified
        rep = build_report(collect_inputs(s, r))
        return rep, write_report(rep, tmp_path_factory.mktemp("rep") / "report")

    return _shared("written_report", make)


@pytest.fixture
def chromium(tmp_path):
    """Run headless chromium with the test flags and a throw-away profile."""
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium is not installed (make browser-deps installs it)")
    profile = tmp_path / "chromium-profile"
    profile.mkdir(exist_ok=True)

    def run(args: list[str], timeout: float = 120.0):
        return subprocess.run([CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
                              capture_output=True, text=True, timeout=scaled_timeout(timeout))

    return run
