"""Fuzz test of session files (hypothesis): mutated ``session.toml`` and CSVs.

Every mutated session either loads and then satisfies every rule of ``docs/formats.md``
(checked here independently of the reader: no bad file accepted), or is refused with a
:class:`~volcal.errors.VolcalInputError` naming a file (no traceback); a writing command
(``volcal simulate``) on a mutated session fails without changing a byte of the folder
(no partial output).

The default profile runs a fixed small subset (a few seconds, ``make test``); the slow
run draws new files: ``HYPOTHESIS_PROFILE=fuzz .venv/bin/pytest
tests/session/test_fuzz_sessions.py`` (10^4 mutated sessions read, 2,500 simulated;
README).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import machine
from volcal.errors import VolcalInputError
from volcal.measure.simulate import SimulationOptions, simulate_session
from volcal.plan.planner import plan_session
from volcal.session.checks import travel_margin
from volcal.session.format import (
    DEVIATION_ABS_MAX_UM,
    KINDS,
    TARGETS,
    read_session,
    write_session,
)

TRAVEL = np.array([[0.0, 400.0], [0.0, 300.0], [0.0, 200.0]])

FUZZ = os.environ.get("HYPOTHESIS_PROFILE") == "fuzz"
N_READ = 10_000 if FUZZ else 40
"""Examples of the reader test: 10^4 in the slow run, a fixed 40 in ``make test``."""
N_SIMULATE = 2_500 if FUZZ else 8
"""Examples of the writer test (``volcal simulate``)."""

TOKENS = ["nan", "inf", "-inf", "", "abc", "1e308", "-1e308", "1e999", "99999", "-99999",
          "20000", "missed", "MISSED", "ok", "0x10", "\x00", '"', "1,2", "[", "]", "=", "true",
          "{}", "é", "\ufeff", "1.5.2", "0", "-0", "1e-300", "+", "-", "flat-mirror",
          "retroreflector", "flat_mirror", "linear", "diagonal", "step_diagonal", "circle",
          "XYFZ", "XYZ", "status", "run"]


def _session(folder: Path, measured: bool) -> Path:
    s = plan_session(TRAVEL, "XYFZ", steps=2, runs=2,
                     tests=("step-diagonal", "diagonal", "linear"))
    if measured:
        simulate_session(s, machine("XYFZ", travel=TRAVEL, n_nodes=5), SimulationOptions(seed=1))
    return write_session(s, folder)


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("fuzz")
    return {"S": _session(d / "S", True), "P": _session(d / "P", False)}


def _mutate(data: st.DataObject, folder: Path) -> None:
    files = sorted(p for p in folder.iterdir() if p.is_file())
    target = data.draw(st.sampled_from(files), label="file")
    raw = target.read_bytes()
    text = raw.decode()
    how = data.draw(st.sampled_from(["token", "token", "cell", "truncate", "insert", "drop_line",
                                     "dup_line", "swap_lines", "drop_column", "delete"]),
                    label="how")
    pieces = [p for p in text.replace("\n", ",").replace(" = ", ",").split(",") if p.strip()]
    lines = [ln.split(",") for ln in text.splitlines()]
    if how == "token" and pieces:
        old = data.draw(st.sampled_from(pieces))
        text = text.replace(old, data.draw(st.sampled_from(TOKENS)), 1)
    elif how == "cell" and target.suffix == ".csv" and len(lines) > 1:
        i = data.draw(st.integers(1, len(lines) - 1))
        j = data.draw(st.integers(0, len(lines[i]) - 1))
        lines[i][j] = data.draw(st.one_of(st.sampled_from(TOKENS),
                                          st.floats(allow_nan=True).map(repr)))
        text = "\n".join(",".join(r) for r in lines) + "\n"
    elif how == "truncate":
        text = text[: data.draw(st.integers(0, len(text)))]
    elif how == "insert":
        i = data.draw(st.integers(0, len(text)))
        text = text[:i] + data.draw(st.text(max_size=12)) + text[i:]
    elif how in ("drop_line", "dup_line", "swap_lines") and text.splitlines():
        lines = text.splitlines()
        i = data.draw(st.integers(0, len(lines) - 1))
        if how == "drop_line":
            del lines[i]
        elif how == "dup_line":
            lines.insert(i, lines[i])
        else:
            k = data.draw(st.integers(0, len(lines) - 1))
            lines[i], lines[k] = lines[k], lines[i]
        text = "\n".join(lines) + "\n"
    elif how == "drop_column":
        j = data.draw(st.integers(0, 7))
        text = "\n".join(",".join(c for i, c in enumerate(ln.split(",")) if i != j)
                         for ln in text.splitlines()) + "\n"
    if how == "delete":
        target.unlink()
    else:
        target.write_bytes(text.encode("utf-8", "surrogatepass"))


def _check_accepted(folder: Path) -> None:
    """Every rule of docs/formats.md holds for what the reader accepted."""
    s = read_session(folder)
    margin = travel_margin(s.travel)
    assert s.measurements
    for m in s.measurements:
        assert m.kind in KINDS and m.target in TARGETS
        assert m.n >= 2 and m.positions.shape == (m.n, 3)
        assert np.all(np.isfinite(m.positions))
        assert np.all(m.positions >= s.travel[:, 0] - margin - 1e-9)
        assert np.all(m.positions <= s.travel[:, 1] + margin + 1e-9)
        assert m.deviation is not None and m.deviation.shape == (m.n,)
        assert np.all(np.isfinite(m.deviation))
        assert np.all(np.abs(m.deviation) <= DEVIATION_ABS_MAX_UM)
        assert abs(np.linalg.norm(m.beam_direction) - 1) < 1e-9
        if m.kind == "step_diagonal":  # single-axis moves only
            assert np.all(np.sum(np.abs(np.diff(m.positions, axis=0)) > 0.01, axis=1) <= 1) \
                or m.rows is not None and np.any(np.diff(m.rows) > 1)


@settings(deadline=None, max_examples=N_READ,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_read_session(sessions, data):
    tmp = Path(tempfile.mkdtemp())
    try:
        folder = tmp / "S"
        shutil.copytree(sessions["S"], folder)
        for _ in range(data.draw(st.integers(1, 3), label="mutations")):
            _mutate(data, folder)
        try:
            _check_accepted(folder)
        except VolcalInputError as exc:
            assert exc.file, f"error without a file name: {exc}"
            assert "Traceback" not in str(exc)
    finally:
        shutil.rmtree(tmp)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


@settings(deadline=None, max_examples=N_SIMULATE,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_simulate_writes_all_or_nothing(sessions, data):
    """``volcal simulate`` on a mutated planned session: exit 0, or exit 2 with the folder
    unchanged; never a traceback."""
    import contextlib
    import io

    from volcal.cli import main

    tmp = Path(tempfile.mkdtemp())
    try:
        folder = tmp / "P"
        shutil.copytree(sessions["P"], folder)
        _mutate(data, folder)
        before = _snapshot(folder)
        out, err = io.StringIO(), io.StringIO()
        import sys

        argv, sys.argv = sys.argv, ["volcal", "simulate", str(folder), "--seed", "1"]
        code = 0
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                main()
        except SystemExit as exc:
            code = exc.code
        finally:
            sys.argv = argv
        assert "Traceback" not in out.getvalue() + err.getvalue()
        assert code in (0, None, 2), err.getvalue()
        if code == 2:
            assert _snapshot(folder) == before
            assert err.getvalue().startswith("error:")
        else:
            _check_accepted(folder)
    finally:
        shutil.rmtree(tmp)
