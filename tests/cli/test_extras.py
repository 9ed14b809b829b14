"""``pip install volcal`` without extras: the core works, the history names its extra.

Each command runs in a fresh interpreter where the libraries of the ``history`` and
``dataframe`` extras cannot be imported (``None`` in ``sys.modules``: ``import sqlalchemy``
raises ImportError, as when they are not installed).
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from volcal.extras import EXTRAS

BLOCKED = ("sqlalchemy", "alembic", "psycopg", "pandas", "pyarrow")

_WRAPPER = (
    "import sys\n"
    f"for _m in {BLOCKED!r}:\n"
    "    sys.modules[_m] = None\n"
    "import volcal\n"
    "from volcal.cli import main\n"
    "sys.argv = ['volcal', *sys.argv[1:]]\n"
    "try:\n"
    "    main()\n"
    "finally:\n"
    "    loaded = [m for m in sys.modules if m.split('.')[0] in "
    f"{BLOCKED!r} and sys.modules[m] is not None]\n"
    "    assert not loaded, loaded\n"
)


def bare_volcal(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``volcal *args`` without the extras' libraries."""
    return subprocess.run([sys.executable, "-c", _WRAPPER, *args], capture_output=True,
                          text=True, cwd=cwd)


def test_the_extras_cover_the_blocked_libraries():
    assert set(BLOCKED) == set(EXTRAS["history"]) | set(EXTRAS["dataframe"])


def test_import_volcal_without_the_extras():
    code = (f"import sys\nfor m in {BLOCKED!r}:\n    sys.modules[m] = None\n"
            "import volcal\nfrom volcal import Calibration, identify, load_model\n"
            "import volcal.report.sections, volcal.standards.session, volcal.io.frames\n"
            "print(Calibration.__name__)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "Calibration", r.stderr


@pytest.fixture(scope="module")
def bare_session(tmp_path_factory):
    """A small session planned, simulated and identified without the extras."""
    root = tmp_path_factory.mktemp("bare")
    runs = {"plan": bare_volcal("plan", "-o", "S", "--steps", "5", cwd=root),
            "simulate": bare_volcal("simulate", "S", "--seed", "1", cwd=root),
            "identify": bare_volcal("identify", "S", "-o", "m.json", cwd=root)}
    return root, runs


def test_help_without_the_extras():
    r = bare_volcal("--help")
    assert r.returncode == 0, r.stderr
    assert "history" in r.stdout and "identify" in r.stdout


def test_plan_and_identify_without_the_extras(bare_session):
    root, runs = bare_session
    for name, r in runs.items():
        assert r.returncode == 0, f"{name}: {r.stderr}"
    assert "planned 17 measurements, 628 readings" in runs["plan"].stdout
    assert (root / "m.json").is_file() and (root / "m.npz").is_file()
    r = bare_volcal("evaluate", "session", "S", "--json", cwd=root)
    assert r.returncode == 0, r.stderr


def test_history_names_its_extra(tmp_path):
    r = bare_volcal("history", "list", "--db", str(tmp_path / "h.sqlite"))
    assert r.returncode == 2
    assert "volcal history needs the 'history' extra: pip install 'volcal[history]'" \
        in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "h.sqlite").exists()
    # the group's help needs no library
    r = bare_volcal("history", "--help")
    assert r.returncode == 0 and "Calibration history" in r.stdout


def test_report_history_names_its_extra(bare_session, tmp_path):
    root, _ = bare_session
    r = bare_volcal("report", "S", "--model", "m.json", "-o", str(tmp_path / "r"),
                    "--history", str(tmp_path / "h.sqlite"), cwd=root)
    assert r.returncode == 2, r.stderr
    assert "volcal report --history needs the 'history' extra" in r.stderr
    assert "Traceback" not in r.stderr and not (tmp_path / "r").exists()


def test_python_history_names_its_extra():
    code = (f"import sys\nfor m in {BLOCKED!r}:\n    sys.modules[m] = None\n"
            "from volcal.extras import MissingExtraError\n"
            "try:\n    from volcal import History\n"
            "except MissingExtraError as exc:\n    print(exc)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == ("volcal.history needs the 'history' extra: pip install "
                                "'volcal[history]' (not installed: sqlalchemy, alembic, pandas)")
