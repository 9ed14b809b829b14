"""``volcal ARGS`` run in-process for the tests (a subprocess costs seconds on the shared
box). Not named conftest: test folders import their own conftest by name."""

from __future__ import annotations

import sys

import pytest


def run_volcal(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
               *args: str) -> tuple[int, str, str]:
    """Run ``volcal *args``; returns (exit code, standard output, standard error)."""
    from volcal.cli import main

    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return int(code), out.out, out.err
