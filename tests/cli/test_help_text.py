"""``volcal ... --help`` as a user reads it: the units in brackets must survive.

Typer renders help with Rich markup by default, and Rich takes ``[s]`` (strike) and any
other ``[word]`` for a style tag and drops it, so "Dwell at each reading pose [s]" was
printed as "Dwell at each reading pose ." The console script turns markup off.

The commands run in-process (:func:`volcal_cli_helpers.volcal_process`, the same ``main()``
and output streams; VOLCAL_TEST_SUBPROCESS=1 runs them as processes): the text is what is
tested, not the process (tests/cli/test_startup.py starts the processes).
"""

from __future__ import annotations

import os

import pytest

from timing import scaled_timeout
from volcal_cli_helpers import volcal_process


def _help(*args: str) -> str:
    r = volcal_process(*args, "--help", timeout=scaled_timeout(120),
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


def test_error_message_keeps_its_brackets(tmp_path):
    """A located error names '<session.toml> [<measurement id>]'; Rich markup used to eat
    the bracket, leaving 'session.toml , column ...'."""
    s = tmp_path / "S"
    r = volcal_process("plan", "-o", s, "--tests", "linear", "--steps", "2", "--runs", "1",
                       timeout=scaled_timeout(120))
    assert r.returncode == 0, r.stderr
    toml = (s / "session.toml").read_text()
    i = toml.index('id = "linear-x1"')
    j = toml.index("[[measurements]]", i)
    toml = (toml[:j] + 'readings = "raw"\n[measurements.environment]\n'
            "air_temperature_c = 20.0\nair_pressure_hpa = 1013.25\nhumidity_pct = 50\n\n"
            + toml[j:])
    (s / "session.toml").write_text(toml)
    for f in s.glob("linear-*.csv"):  # fill the deviations so the session reads as measured
        lines = f.read_text().splitlines()
        cols = lines[0].split(",")
        k = cols.index("deviation_um")
        out = [lines[0]]
        for ln in lines[1:]:
            v = ln.split(",")
            v[k] = "0"
            out.append(",".join(v))
        f.write_text("\n".join(out) + "\n")
    r = volcal_process("evaluate", "session", s, timeout=scaled_timeout(120),
                       env={**os.environ, "COLUMNS": "400"})
    assert r.returncode == 2
    first = r.stderr.strip().splitlines()[0]
    assert ("session.toml [linear-x1], column 'measurements[0].environment.air_pressure_hpa'"
            in first), first
