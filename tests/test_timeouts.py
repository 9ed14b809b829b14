"""The tests' timeouts scale with the measured slowdown of the box (tests/timing.py)."""

from __future__ import annotations

import timing
from timing import scaled_timeout


def _measured(monkeypatch, wall: float, cpu: float) -> list[int]:
    calls: list[int] = []

    def fake():
        calls.append(1)
        return wall, cpu

    monkeypatch.setattr(timing, "measure_slowdown", fake)
    monkeypatch.setattr(timing, "_last", {})
    return calls


def test_a_busy_box_gets_longer_timeouts(monkeypatch):
    # load 16 on 2 cores: the workload gets an eighth of a core, wall = 8 x CPU
    _measured(monkeypatch, wall=8 * timing.REFERENCE_CPU_S, cpu=timing.REFERENCE_CPU_S)
    assert scaled_timeout(600) == 4800.0


def test_a_slower_processor_gets_longer_timeouts(monkeypatch):
    # idle, but the workload takes 3 times the reference CPU time
    cpu = 3 * timing.REFERENCE_CPU_S
    _measured(monkeypatch, wall=cpu, cpu=cpu)
    assert scaled_timeout(100) == 300.0
    # both: 2 x contention on a 3 x slower processor
    _measured(monkeypatch, wall=2 * cpu, cpu=cpu)
    assert scaled_timeout(100) == 600.0


def test_never_below_nominal(monkeypatch):
    # a faster box than the reference keeps the nominal timeout
    _measured(monkeypatch, wall=0.5 * timing.REFERENCE_CPU_S, cpu=0.5 * timing.REFERENCE_CPU_S)
    assert scaled_timeout(60) == 60.0


def test_measured_again_when_old(monkeypatch):
    calls = _measured(monkeypatch, wall=1.0, cpu=1.0)
    t = [1000.0]
    monkeypatch.setattr(timing, "_clock", lambda: t[0])
    scaled_timeout(10)
    t[0] += timing.MAX_AGE_S / 2
    scaled_timeout(10)
    assert len(calls) == 1
    t[0] += timing.MAX_AGE_S
    scaled_timeout(10)
    assert len(calls) == 2


def test_the_real_measurement():
    """The workload runs: its CPU time is positive and the slowdown at least 1."""
    wall, cpu = timing.measure_slowdown()
    assert cpu > 0 and wall > 0
    assert timing.slowdown() >= 1.0
