"""``volcal ... --help`` as a user reads it: the units in brackets must survive.

Typer renders help with Rich markup by default, and Rich takes ``[s]`` (strike) and any
other ``[word]`` for a style tag and drops it, so "Dwell at each reading pose [s]" was
printed as "Dwell at each reading pose ." The console script turns markup off.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

RUN = [sys.executable, "-c", "from volcal.cli import main; main()"]


def _help(*args: str) -> str:
    r = subprocess.run([*RUN, *args, "--help"], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "COLUMNS": "200"})
    assert r.returncode == 0, r.stderr
    return " ".join(r.stdout.split())  # undo line wrapping


@pytest.mark.parametrize(("args", "expected"), [
    (("program",), "Dwell at each reading pose [s]."),
    (("program",), "Feed of every move [mm/min] (max 10000)."),
    (("plan",), "Travel limits x,y,z as min:max [mm]."),
    (("simulate",), "Residual mirror misalignment [urad]."),
    (("compensate",), "Fanuc detection unit [um]."),
    (("evaluate", "volumetric"), "[mm]"),
    (("env", "refractive-index"), "Air pressure [Pa]."),
])
def test_units_in_brackets_are_printed(args, expected):
    assert expected in _help(*args)


def test_every_command_is_listed():
    text = _help()
    for cmd in ("plan", "program", "simulate", "import", "identify", "predict", "evaluate",
                "compensate", "report", "demo", "classic", "env"):
        assert f" {cmd} " in f" {text} ", cmd
