"""``volcal ARGS`` run in-process for the tests (a subprocess costs seconds on the shared
box). Not named conftest: test folders import their own conftest by name."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import traceback
import warnings

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


SUBPROCESS = os.environ.get("VOLCAL_TEST_SUBPROCESS") == "1"
"""Set VOLCAL_TEST_SUBPROCESS=1 to run every :func:`volcal_process` call in its own process,
as a user does; by default the calls run ``main()`` in-process (the same entry point, exit
codes and output streams; each subprocess costs 0.3-0.7 s of imports, seconds on a loaded
box)."""

RUN = [sys.executable, "-c", "from volcal.cli import main; main()"]


def volcal_process(*args: object, cwd: str | os.PathLike | None = None,
                   env: dict[str, str] | None = None,
                   timeout: float | None = None) -> subprocess.CompletedProcess[str]:
    """``volcal *args`` as a finished process: return code, standard output and error.

    In-process unless :data:`SUBPROCESS`: ``sys.argv``, the working folder and, when
    ``env`` is given, ``os.environ`` are set for the call and restored; Python's warnings
    start fresh for each call (as in a new process) and print through volcal's own
    handler; an exception escaping ``main()`` is written to standard error as the
    traceback a user would see (exit code 1), so a test's ``"Traceback" not in`` holds
    its meaning. ``timeout`` [s] bounds a subprocess only (default: ``scaled_timeout(300)``,
    tests/timing.py).
    """
    argv = [str(a) for a in args]
    if SUBPROCESS:
        from timing import scaled_timeout

        return subprocess.run([*RUN, *argv], capture_output=True, text=True, cwd=cwd,
                              env=env, timeout=scaled_timeout(300) if timeout is None
                              else timeout)
    from volcal.cli import main

    out, err = io.StringIO(), io.StringIO()
    code = 0
    old_argv, old_cwd, old_env = sys.argv, os.getcwd(), dict(os.environ)
    sys.argv = ["volcal", *argv]
    try:
        if cwd is not None:
            os.chdir(cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(env)
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), \
                contextlib.redirect_stderr(err):
            warnings.simplefilter("default")
            try:
                main()
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # what a user would see as a traceback
                err.write(traceback.format_exc())
                code = 1
    finally:
        sys.argv = old_argv
        os.chdir(old_cwd)
        if env is not None:
            os.environ.clear()
            os.environ.update(old_env)
    return subprocess.CompletedProcess(["volcal", *argv], code, out.getvalue(), err.getvalue())
