"""Timeouts that scale with how fast this box runs the tests now, never fixed seconds.

A test's timeout only guards against a hang: it must not fail a test because the box is
busy (``make test`` on a 2-core box at load 16 runs every process about 8 times slower
than on an idle one; a fixed 600 s timeout once failed 13 tests there). Every timeout of
the tests is :func:`scaled_timeout` of its nominal value: the nominal seconds (enough on
an idle reference box, with a margin) times the slowdown measured on a fixed
single-threaded workload (pure Python and numpy):

* contention: the workload's wall time over its CPU time (1 on an idle core, about
  load / cores on a busy box);
* speed: its CPU time over :data:`REFERENCE_CPU_S`, the CPU time on the reference box (a
  slower processor), never below 1.

The slowdown is measured again when the last measurement is older than
:data:`MAX_AGE_S` (load changes during a run). No test asserts on wall time.
"""

from __future__ import annotations

import time

import numpy as np

REFERENCE_CPU_S = 0.06
"""CPU time of :func:`_workload` on the reference box (2-core x86-64, 2026) [s]."""

MAX_AGE_S = 30.0
"""A slowdown measured longer ago than this is measured again [s]."""

_last: dict[str, float] = {}
_clock = time.monotonic


def _workload() -> float:
    s = 0
    for i in range(400_000):
        s += i * i
    x = np.linspace(0.0, 1.0, 20_000)
    for _ in range(150):
        x = np.sort(np.sin(x) + 0.5 * x)
    return s + float(x[0])


def measure_slowdown() -> tuple[float, float]:
    """Run the workload once: (wall time [s], CPU time of this process [s])."""
    w0, c0 = time.perf_counter(), time.process_time()
    _workload()
    return time.perf_counter() - w0, time.process_time() - c0


def slowdown() -> float:
    """How many times slower than the idle reference box this box runs now (>= 1)."""
    now = _clock()
    if _last and now - _last["at"] < MAX_AGE_S:
        return _last["factor"]
    wall, cpu = measure_slowdown()
    cpu = max(cpu, 1e-3)
    factor = max(1.0, wall / cpu) * max(1.0, cpu / REFERENCE_CPU_S)
    _last.update(at=now, factor=factor)
    return factor


def scaled_timeout(nominal_s: float) -> float:
    """A timeout [s]: ``nominal_s`` (enough on the idle reference box) times the slowdown.

    Parameters
    ----------
    nominal_s : float
        Timeout on an idle reference box [s].

    Returns
    -------
    float
        At least ``nominal_s``.
    """
    return nominal_s * slowdown()
