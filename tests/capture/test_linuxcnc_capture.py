"""volcal capture on LinuxCNC itself: volcal's part program run by LinuxCNC in simulation.

LinuxCNC 2.9 runs headless as an unprivileged user (the fixture of the rotary issue,
tests/linuxcnc_sim.py) and executes volcal's own program for a linear test three times;
``volcal capture --control linuxcnc`` reads LinuxCNC's status channel through the bridge
run by /usr/bin/python3, and the simulated laser reads an injected error map (volcal's
random virtual machine, seed 3) at LinuxCNC's actual position. Capture A starts once
LinuxCNC's run holds the box's LinuxCNC lock, before LinuxCNC is up (the bridge waits for
it); a failure says why (LinuxCNC's state and log, the journals, what the bridge reads).
Checks:

* capture A (program run 1, uninterrupted): exactly one row per dwell, in order, every
  accepted window inside a dwell of LinuxCNC (no sample of the window in motion, the
  program running, the axes at the target, LinuxCNC on that reading's own program lines)
  and after the program's start; the readings equal the injected map within the noise;
* capture B (program runs 2 and 3): SIGKILL after two points, resumed at once: every
  reading once, the same rows as A, readings equal to A's and to the map within noise
  (run 3 only when the resumed capture did not take its readings from run 2).

The trimmed check (6 dwells) runs in make test; the ISO 230-2 cycle (5 runs, 60 dwells)
runs in make study.

A rotary test (session 21, trimmed: 3 targets of the C axis, one bidirectional run, 6
dwells): LinuxCNC runs volcal's rotary program once (the turn to the overrun before the
first target, the operator stop there, incremental turns); the bridge reports C by its
letter; the capture takes one reading per dwell, every window inside LinuxCNC's dwell at
the reading's angle and lines, equal to the virtual axis ``volcal simulate --seed 3``
draws within the noise.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from linuxcnc_sim import linuxcnc_missing, run_linuxcnc, xyzc_joints
from timing import scaled_timeout

SEED = 3
NOISE_UM = 0.05
IDLE_S = 1.0
"""Before run 1 the machine stands idle at home this long [s] with capture A connected:
longer than the stable windows of the tests (0.35-0.6 s), where a reading taken would be
one before the program's start."""
LOCKED = "locked"
"""The file LinuxCNC's run writes in its configuration's folder once it holds the box's
LinuxCNC lock (``run_linuxcnc(locked_file=...)``)."""
PAUSE_S = 1.0
"""Each run's operator stop (the ``M0`` at the program's start) lasts this long [s] before
the cycle start: longer than a stable window, where no reading may be taken (paused)."""


def _volcal(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-c", "from volcal.cli import main; main()",
                             *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _journal(folder: Path, mid: str) -> list[dict]:
    p = folder / "capture" / f"{mid}.jsonl"
    out = []
    if p.is_file():
        for line in p.read_bytes().splitlines():
            try:
                out.append(json.loads(line))
            except json.JSONDecodeError:
                pass
    return out


def _truth(session: Path, mid: str) -> np.ndarray:
    from volcal.measure.virtual import random_machine
    from volcal.session.format import read_session
    from volcal.session.kinds import kind_of

    s = read_session(session, require_deviation=False)
    m = s.get(mid)
    return np.asarray(kind_of(m.kind).exact(random_machine(s.travel, s.chain, SEED), m))


def _check_windows(journal: list[dict], targets: np.ndarray, window_mm: float,
                   lines: list[tuple[int, int]]) -> None:
    """Each accepted window lies inside one dwell of LinuxCNC, after the program started,
    and LinuxCNC executes that reading's own lines of the program (the right run)."""
    ctrl = [x for x in journal if x["type"] == "control"]
    runs = [k for k, x in enumerate(journal) if x["type"] == "start"]
    first_running = min(x["t"] for x in ctrl if x.get("running"))
    for x in journal:
        if x["type"] != "accepted":
            continue
        lo, hi = x["window"]
        assert lo > first_running
        # the control samples of the window's own run (each run has its own clock)
        run_start = max(k for k in runs if k < journal.index(x))
        inside = [c for c in journal[run_start:journal.index(x)]
                  if c["type"] == "control" and lo <= c["t"] <= hi]
        assert len(inside) >= 5
        for c in inside:
            assert c["running"] and not c["moving"], (x["reading"], c)
            assert c["line"] in lines[x["reading"]], (x["reading"], c["line"])
            p = np.array([c["pos"][a] for a in "XYZ"])
            assert np.max(np.abs(p - targets[x["reading"]])) <= window_mm


def _wait(p: subprocess.Popen[str], what: str, timeout: float,
          outputs: dict[str, tuple[str, str]]) -> str:
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
        outputs[what] = (out, err)
        raise AssertionError(f"{what} did not end") from None
    outputs[what] = (out, err)
    assert p.returncode == 0, f"{what} ended with exit code {p.returncode}"
    return out


class _CNC:
    """LinuxCNC's run in its thread, as the test follows it: its configuration folder
    (found by the test's marker file), when it took the box's LinuxCNC lock, its result."""

    def __init__(self) -> None:
        self.config: Path | None = None
        self.result: dict = {}
        self.thread: threading.Thread | None = None
        self.t0 = time.monotonic()
        self.locked_after_s: float | None = None

    def check(self) -> None:
        """Fail at once (with LinuxCNC's reason) when its run has ended: whatever the test
        waits for (a capture connecting, a program) will not come."""
        assert self.thread is not None
        if not self.thread.is_alive():
            raise AssertionError("LinuxCNC's run ended before the test was done: "
                                 + self.state())

    def state(self) -> str:
        """Where LinuxCNC's run is (for a failure message)."""
        waited = (f"it waited {self.locked_after_s:.1f} s for the box's LinuxCNC lock"
                  if self.locked_after_s is not None else
                  f"it has waited {time.monotonic() - self.t0:.1f} s for the box's LinuxCNC "
                  "lock (other runs on the box hold it) or its configuration")
        if "error" in self.result:
            return f"{waited}; it failed: {self.result['error']}"
        if "res" in self.result:
            r = self.result["res"]
            return (f"{waited}; it ended after {r.get('run_s', 0):.1f} s, ok={r['ok']}, "
                    f"failed: {r['failed']}, errors: {r['errors'][:5]}")
        alive = self.thread is not None and self.thread.is_alive()
        return f"{waited}; {'still running' if alive else 'ended without a result'}"


def _tail(text: str, n: int) -> str:
    return "\n".join(text.splitlines()[-n:])


def _diagnostics(tmp_path: Path, mid: str, cnc: _CNC,
                 outputs: dict[str, tuple[str, str]]) -> str:
    """What the captures and LinuxCNC did, for a failure message: LinuxCNC's state and
    log (kept in ``tmp_path/linuxcnc``), each capture's journal summary and output."""
    parts = [f"LinuxCNC: {cnc.state()}"]
    log = ""
    if "res" in cnc.result:
        log = cnc.result["res"].get("log", "")
    elif (tmp_path / "linuxcnc" / "linuxcnc.log").is_file():
        log = (tmp_path / "linuxcnc" / "linuxcnc.log").read_text(errors="replace")
    parts.append(f"LinuxCNC's log (kept in {tmp_path / 'linuxcnc'}), its end:\n"
                 + (_tail(log, 40) or "(empty)"))
    for name in ("A", "B"):
        journal = _journal(tmp_path / name, mid)
        if not journal and name not in outputs:
            continue
        counts: dict[str, int] = {}
        for x in journal:
            counts[x["type"]] = counts.get(x["type"], 0) + 1
        said = [{k: x.get(k) for k in ("type", "t", "utc", "done", "reason", "text")
                 if k in x} for x in journal if x["type"] in ("start", "end", "note")]
        ctrl = [x for x in journal if x["type"] == "control"]
        parts.append(f"capture {name}: journal {counts}; {json.dumps(said[-10:])}"
                     + (f"; last control sample {json.dumps(ctrl[-1])}" if ctrl else ""))
    for name, (out, err) in outputs.items():
        parts.append(f"{name}: stdout:\n{_tail(out, 15)}\nstderr:\n{_tail(err, 25)}")
    return "\n\n".join(parts)


def _bridge_sees(config: Path) -> str:
    """What volcal's LinuxCNC bridge reads now for this configuration (about 2 s of its
    output, for a failure message: its ``waiting`` reasons or a status line)."""
    from volcal.capture.linuxcnc_source import BRIDGE, system_python

    p = subprocess.Popen([system_python(), str(BRIDGE), "--ini", str(config / "sim.ini"),
                          "--wait", "5", "--lost", "5", "--period", "0.2"],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    time.sleep(2.0)
    p.send_signal(signal.SIGINT)  # the bridge ends between two polls (never inside one)
    try:
        out = p.communicate(timeout=scaled_timeout(10))[0]
    except subprocess.TimeoutExpired:
        p.kill()
        out = p.communicate()[0]
    seen = list(dict.fromkeys(line[:300] for line in out.splitlines()))
    return "the bridge reads now: " + ("\n".join(seen[:2] + seen[-1:]) or "nothing")


def _run(tmp_path: Path, *, steps: int, runs: int, travel: float, dwell_s: float,
         stable_s: float, max_gap_s: float, feed: float) -> None:
    from volcal.steps.plan import plan
    from volcal.steps.program import program

    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    s = tmp_path / "S"
    plan(((0.0, travel), (0.0, 50.0), (0.0, 40.0)), steps=steps, tests="linear", runs=runs,
         output=s)
    progs = tmp_path / "P"
    program(s, dialect="linuxcnc", output=progs, dwell_s=dwell_s, feed=feed)
    ngc = (progs / "linear_x1.ngc").read_text()
    mid = "linear-x1"
    marker = f"volcal-capture-{uuid.uuid4().hex}"  # finds this test's LinuxCNC folder
    cnc = _CNC()
    n_prog = 3

    def run() -> None:
        try:
            cnc.result["res"] = run_linuxcnc(
                xyzc_joints(), [{"home": True},
                                *[step for k in range(n_prog) for step in (
                                    # each run starts once the test says the capture that
                                    # follows it is connected (a loaded box starts a
                                    # capture late: it would join the program mid-run)
                                    # (run 3 only when the resumed capture B needs it)
                                    {"wait_file": f"go-p{k}", "or_end": "stop",
                                     "timeout_s": scaled_timeout(600)},
                                    *([{"sleep_s": IDLE_S}] if k == 0 else []),
                                    {"program": "linear_x1.ngc", "label": f"p{k}",
                                     "resume_after_s": PAUSE_S, "done_file": f"ended-p{k}",
                                     "timeout_s": scaled_timeout(600)})]],
                files={"linear_x1.ngc": ngc, marker: ""}, timeout_s=900,
                locked_file=LOCKED, keep=tmp_path / "linuxcnc")
        except Exception as e:  # reported by the test below
            cnc.result["error"] = e

    cnc.thread = threading.Thread(target=run, daemon=True)
    cnc.thread.start()
    procs: dict[str, subprocess.Popen[str]] = {}
    outputs: dict[str, tuple[str, str]] = {}
    failed: BaseException | None = None
    try:
        _captures(tmp_path, s, progs, mid, marker, procs, stable_s, max_gap_s, cnc, outputs)
    except BaseException as e:
        failed = e
    finally:
        for name, p in procs.items():  # never leave a capture or LinuxCNC behind
            if p.poll() is None:
                p.kill()
            if name not in outputs:
                try:
                    outputs[name] = p.communicate(timeout=scaled_timeout(30))
                except (ValueError, OSError, subprocess.TimeoutExpired):
                    pass
        probe = ""
        if failed is not None and cnc.config is not None:
            if cnc.thread.is_alive() and cnc.locked_after_s is not None:
                probe = _bridge_sees(cnc.config)
            _release(cnc.config, "stop")  # LinuxCNC's plan ends at its next wait
        cnc.thread.join(scaled_timeout(1200))
    if isinstance(failed, AssertionError):
        raise AssertionError(f"{failed}\n\n{_diagnostics(tmp_path, mid, cnc, outputs)}"
                             f"\n\n{probe}") from None
    if failed is not None:
        raise failed
    assert not cnc.thread.is_alive(), "LinuxCNC's run did not end"
    assert "error" not in cnc.result, _diagnostics(tmp_path, mid, cnc, outputs)
    assert cnc.result["res"]["ok"], _diagnostics(tmp_path, mid, cnc, outputs)
    _check(tmp_path, s, mid, stable_s)


def _connected(folder: Path, mid: str, starts: int) -> bool:
    """The capture's ``starts``-th ``start`` in its journal is followed by a ``control``
    sample of LinuxCNC (the ``start`` alone is journaled before the bridge reaches
    LinuxCNC)."""
    journal = _journal(folder, mid)
    begun = [k for k, x in enumerate(journal) if x["type"] == "start"]
    return len(begun) >= starts and any(
        x["type"] == "control" for x in journal[begun[starts - 1]:])


def _release(config: Path, name: str) -> None:
    """Write the file ``name`` the driver waits for in the configuration's folder."""
    (config / name).write_text("")
    os.chmod(config / name, 0o644)


def _ended(p: subprocess.Popen[str], what: str,
           outputs: dict[str, tuple[str, str]]) -> AssertionError:
    """The failure of capture ``p`` that ended before its time, with its output."""
    out, err = p.communicate()
    outputs[what] = (out, err)
    return AssertionError(f"{what} ended (exit code {p.returncode}) before its time")


def _go(config: Path, name: str, p: subprocess.Popen[str], folder: Path, mid: str,
        starts: int, cnc: _CNC, what: str, outputs: dict[str, tuple[str, str]]) -> None:
    """Let LinuxCNC start its next program once capture ``p`` is connected
    (:func:`_connected`): the file ``name`` releases the driver's ``wait_file`` step."""
    deadline = time.monotonic() + scaled_timeout(300)
    while not _connected(folder, mid, starts):
        if p.poll() is not None:
            raise _ended(p, what, outputs)
        cnc.check()
        assert time.monotonic() < deadline, f"{name}: {what} did not reach LinuxCNC (no " \
            "control sample after its start)"
        time.sleep(0.02)
    _release(config, name)


def _go_if_needed(config: Path, p: subprocess.Popen[str], folder: Path, mid: str,
                  cnc: _CNC) -> None:
    """Run 3 for the resumed capture ``p`` only if it needs it: resumed at once, it may
    take its remaining readings from run 2 and end there (then the driver's plan ends,
    ``stop``); once run 2 has ended without that, run 3 starts when ``p`` is connected
    (``go-p2``), as before."""
    deadline = time.monotonic() + scaled_timeout(300)
    while True:
        if p.poll() is not None:  # ended within run 2 (its exit code is checked after)
            _release(config, "stop")
            return
        if (config / "ended-p1").exists() and _connected(folder, mid, 2):
            _release(config, "go-p2")
            return
        cnc.check()
        assert time.monotonic() < deadline, "go-p2: the capture did not connect"
        time.sleep(0.02)


def _locked_config(cnc: _CNC, marker: str) -> Path:
    """LinuxCNC's configuration folder (found by ``marker``), once its run holds the box's
    LinuxCNC lock."""
    deadline = time.monotonic() + scaled_timeout(120)
    found: list[Path] = []
    while not found:
        found = list(Path(tempfile.gettempdir()).glob(f"volcal-cnc-*/{marker}"))
        cnc.check()
        assert time.monotonic() < deadline, "the LinuxCNC configuration was not written"
        time.sleep(0.05)
    config = cnc.config = found[0].parent
    # capture A starts once LinuxCNC's run holds the box's lock (LinuxCNC starts then, and
    # comes up seconds later): started before, its timeout ran while other runs on the box
    # held the lock (it ended with no control sample after scaled_timeout(120) s: seen twice
    # in about ten runs on the shared box). The test waits for the lock as long as other runs
    # hold it, as every LinuxCNC test does (the deadline only catches a lock never freed).
    deadline = time.monotonic() + scaled_timeout(1800)
    while not (config / LOCKED).exists():
        cnc.check()
        assert time.monotonic() < deadline, "the box's LinuxCNC lock was never free"
        time.sleep(0.05)
    cnc.locked_after_s = time.monotonic() - cnc.t0
    return config


def _captures(tmp_path: Path, s: Path, progs: Path, mid: str, marker: str,
              procs: dict[str, subprocess.Popen[str]], stable_s: float, max_gap_s: float,
              cnc: _CNC, outputs: dict[str, tuple[str, str]]) -> None:
    config = _locked_config(cnc, marker)
    ini = config / "sim.ini"
    common = [str(s), "--control", f"linuxcnc:{ini}",
              "--laser", f"sim:seed={SEED},noise={NOISE_UM}",
              "--measurement", mid, "--programs", str(progs), "--stable-s", str(stable_s),
              "--max-gap-s", str(max_gap_s), "--poll-s", "0.02",
              "--timeout-s", str(scaled_timeout(120))]
    a_dir, b_dir = tmp_path / "A", tmp_path / "B"
    a = procs["capture A"] = _volcal("capture", *common, "-o", str(a_dir))  # LinuxCNC not up
    _go(config, "go-p0", a, a_dir, mid, 1, cnc, "capture A", outputs)
    out_a = _wait(a, "capture A", scaled_timeout(900), outputs)
    assert "captured ->" in out_a
    # capture B during program run 2: killed after two points, resumed at once
    b = procs["capture B"] = _volcal("capture", *common, "-o", str(b_dir))
    _go(config, "go-p1", b, b_dir, mid, 1, cnc, "capture B", outputs)
    deadline = time.monotonic() + scaled_timeout(600)
    while len([x for x in _journal(b_dir, mid) if x["type"] == "accepted"]) < 2:
        if b.poll() is not None:
            raise _ended(b, "capture B", outputs)
        cnc.check()
        assert time.monotonic() < deadline, "capture B took no point"
        time.sleep(0.02)
    os.kill(b.pid, signal.SIGKILL)
    b.wait()
    killed_with = [x["reading"] for x in _journal(b_dir, mid) if x["type"] == "accepted"]
    assert len(killed_with) >= 2
    b2 = procs["capture B (resumed)"] = _volcal("capture", *common, "-o", str(b_dir))
    _go_if_needed(config, b2, b_dir, mid, cnc)
    _wait(b2, "capture B (resumed)", scaled_timeout(900), outputs)


def _check(tmp_path: Path, s: Path, mid: str, stable_s: float) -> None:
    from volcal.capture.plan import dwell_lines
    from volcal.session.format import read_session

    a_dir, b_dir = tmp_path / "A", tmp_path / "B"
    truth = _truth(s, mid)
    planned = read_session(s, require_deviation=False).get(mid)
    ja, jb = _journal(a_dir, mid), _journal(b_dir, mid)
    # exactly one row per dwell, in order; none before the start or in motion
    assert [x["reading"] for x in ja if x["type"] == "accepted"] == list(range(planned.n))
    assert not [x for x in ja if x["type"] == "missed"]
    lines = dwell_lines(tmp_path / "P", mid)
    assert len(lines) == planned.n
    _check_windows(ja, planned.positions, 0.010, lines)
    _check_windows(jb, planned.positions, 0.010, lines)
    ma, mb = read_session(a_dir).get(mid), read_session(b_dir).get(mid)
    # a deviation is the difference of two means of >= stable_s / 0.02 samples
    tol = 5 * NOISE_UM * np.sqrt(2 / (stable_s / 0.02))
    assert np.max(np.abs(ma.deviation - truth)) < tol, ma.deviation - truth
    # SIGKILL + resume: every reading once, the same rows, the same readings within noise
    acc_b = [x["reading"] for x in jb if x["type"] == "accepted"]
    assert sorted(acc_b) == list(range(planned.n))
    assert np.array_equal(ma.positions, mb.positions)
    assert np.array_equal(ma.columns["direction"], mb.columns["direction"])
    assert np.max(np.abs(mb.deviation - truth)) < tol, mb.deviation - truth
    assert np.max(np.abs(mb.deviation - ma.deviation)) < tol * np.sqrt(2)


def test_capture_on_linuxcnc_trimmed(tmp_path):
    """A linear test of 2 steps, 1 run (6 dwells of 1 s) run two or three times: 20-30 s."""
    _run(tmp_path, steps=2, runs=1, travel=60.0, dwell_s=1.0, stable_s=0.35, max_gap_s=0.25,
         feed=6000.0)


@pytest.mark.slow
def test_capture_on_linuxcnc_iso230_2(tmp_path):
    """The ISO 230-2 cycle, 5 bidirectional runs over 6 targets (60 dwells of 1.5 s), two
    or three times: 4-8 minutes."""
    _run(tmp_path, steps=5, runs=5, travel=300.0, dwell_s=1.5, stable_s=0.6, max_gap_s=0.3,
         feed=6000.0)


def _capture_one_run(tmp_path: Path, s: Path, progs: Path, mid: str, ngc_name: str,
                     joints: list, stable_s: float, *, files: dict | None = None,
                     poll_s: float = 0.0, **kins) -> _CNC:
    """LinuxCNC runs the program ``progs/ngc_name`` once (the driver's operator stop
    resumed after :data:`PAUSE_S`), ``volcal capture --control linuxcnc`` of ``mid``
    connected first, into ``tmp_path/A``; the finished run (its driver's samples of the
    program every ``poll_s`` when > 0). A failure says what LinuxCNC and the capture did."""
    marker = f"volcal-capture-{uuid.uuid4().hex}"
    files = {ngc_name: (progs / ngc_name).read_text(), marker: "", **(files or {})}
    cnc = _CNC()

    def run() -> None:
        try:
            cnc.result["res"] = run_linuxcnc(
                joints, [{"home": True},
                         {"wait_file": "go-p0", "or_end": "stop",
                          "timeout_s": scaled_timeout(600)},
                         {"program": ngc_name, "label": "p0", "resume_after_s": PAUSE_S,
                          "done_file": "ended-p0", "timeout_s": scaled_timeout(600),
                          "poll_s": poll_s}],
                files=files, timeout_s=600, locked_file=LOCKED, keep=tmp_path / "linuxcnc",
                **kins)
        except Exception as e:  # reported below
            cnc.result["error"] = e

    cnc.thread = threading.Thread(target=run, daemon=True)
    cnc.thread.start()
    outputs: dict[str, tuple[str, str]] = {}
    a: subprocess.Popen[str] | None = None
    try:
        config = _locked_config(cnc, marker)
        a = _volcal("capture", str(s), "--control", f"linuxcnc:{config / 'sim.ini'}",
                    "--laser", f"sim:seed={SEED},noise={NOISE_UM}", "--measurement", mid,
                    "--programs", str(progs), "--stable-s", str(stable_s), "--max-gap-s",
                    "0.25", "--poll-s", "0.02", "--timeout-s", str(scaled_timeout(120)),
                    "-o", str(tmp_path / "A"))
        _go(config, "go-p0", a, tmp_path / "A", mid, 1, cnc, "capture A", outputs)
        assert "captured ->" in _wait(a, "capture A", scaled_timeout(600), outputs)
    except AssertionError as e:
        if cnc.config is not None:
            _release(cnc.config, "stop")
        raise AssertionError(f"{e}\n\n{_diagnostics(tmp_path, mid, cnc, outputs)}") from None
    finally:
        if a is not None and a.poll() is None:
            a.kill()
            a.communicate()
        cnc.thread.join(scaled_timeout(600))
    assert "error" not in cnc.result, _diagnostics(tmp_path, mid, cnc, outputs)
    assert cnc.result["res"]["ok"], _diagnostics(tmp_path, mid, cnc, outputs)
    return cnc


def _rotary_truth(s: Path, tmp_path: Path, mid: str) -> np.ndarray:
    """The exact readings of the C axis ``volcal simulate --seed 3`` draws (its truth)."""
    import shutil
    import tomllib

    from volcal.measure.rotary import RotaryAxisErrors, RotarySetup, rotary_exact
    from volcal.session.format import read_session
    from volcal.steps.simulate import save, simulate

    sim = tmp_path / "truth"
    shutil.copytree(s, sim)
    save(simulate(sim, seed=SEED), sim)
    doc = tomllib.loads((sim / "truth" / "setup.toml").read_text())["setup"][mid]
    ax = dict(doc["rotary_axis"])
    setup = RotarySetup(RotaryAxisErrors(**{**ax, "range_deg": tuple(ax["range_deg"]),
                                            "smooth_urad": tuple(ax["smooth_urad"])}),
                        doc["eccentricity_mm"], doc["eccentricity_phase_rad"])
    m = read_session(s, require_deviation=False).get(mid)
    return rotary_exact(setup, m.columns["target_deg"], m.columns["direction"])


def _check_rotary(tmp_path: Path, s: Path, mid: str, stable_s: float) -> None:
    """One row per dwell, each window inside LinuxCNC's dwell at the reading's angle and
    program lines, the readings equal to the truth within the noise."""
    from volcal.capture.plan import dwell_lines
    from volcal.session.format import read_session

    planned = read_session(s, require_deviation=False).get(mid)
    ja = _journal(tmp_path / "A", mid)
    assert [x["reading"] for x in ja if x["type"] == "accepted"] == list(range(planned.n))
    lines = dwell_lines(tmp_path / "P", mid)
    assert len(lines) == planned.n
    first_running = min(x["t"] for x in ja if x["type"] == "control" and x.get("running"))
    for x in (x for x in ja if x["type"] == "accepted"):
        lo, hi = x["window"]
        assert lo > first_running
        inside = [c for c in ja[:ja.index(x)] if c["type"] == "control" and lo <= c["t"] <= hi]
        assert len(inside) >= 5
        target = planned.columns["target_deg"][x["reading"]]
        for c in inside:
            assert c["running"] and not c["moving"] and c["line"] in lines[x["reading"]], c
            assert abs((c["pos"]["C"] - target + 180.0) % 360.0 - 180.0) <= 0.005, c
    m = read_session(tmp_path / "A").get(mid)
    tol = 5 * NOISE_UM * np.sqrt(2 / (stable_s / 0.02))
    truth = _rotary_truth(s, tmp_path, mid)
    assert np.max(np.abs(m.deviation - truth)) < tol, m.deviation - truth


def test_rotary_capture_on_linuxcnc_trimmed(tmp_path):
    """A C-axis test (3 targets, 1 bidirectional run: 6 dwells of 1 s) run once by
    LinuxCNC: the bridge reports C by its letter, the capture takes one reading per dwell
    at the commanded angle from its side, equal to the virtual axis: 15-25 s."""
    from volcal.steps.plan import plan
    from volcal.steps.program import program

    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    s, progs, mid, stable_s = tmp_path / "S", tmp_path / "P", "rotary-c", 0.35
    plan(((0.0, 60.0), (0.0, 50.0), (0.0, 40.0)), steps=2, tests="rotary:c", runs=1,
         output=s)
    program(s, dialect="linuxcnc", output=progs, dwell_s=1.0, feed=10000.0)
    _capture_one_run(tmp_path, s, progs, mid, "rotary_c.ngc", xyzc_joints(), stable_s)
    _check_rotary(tmp_path, s, mid, stable_s)


RT_POSES = [(0, 0), (30, 0), (0, -15), (0, -30)]
"""(c, a) [deg] of the default ``r_test:ca`` plan kept in the trimmed R-test on LinuxCNC:
C turns and A tilts, the linear axes following (some 20 s of motion at the following
moves' capped feed)."""
RT_TRAVEL = ((0.0, 800.0), (0.0, 600.0), (0.0, 500.0))
RT_SAFE_Z_MM = 480.0
"""Above the sphere's top plus the approach's clearance on the default R-test layout."""


def _rtest_planned(tmp_path: Path, poses: list[tuple[int, int]], tcp: bool) -> Path:
    """The default R-test of a CA trunnion, cut to ``poses``; with ``tcp`` the session
    states LinuxCNC's trt kinematics (``control_kinematics = "tcp"``, its angles counted
    the other way: ``control_angle_sign = -1``)."""
    from .rtest_plan import plan_rtest

    s = plan_rtest(tmp_path / "S", RT_TRAVEL, poses)
    if tcp:
        toml = s / "session.toml"
        text = toml.read_text()
        assert text.count('sphere = "R1"\n') == 1
        toml.write_text(text.replace('sphere = "R1"\n', 'sphere = "R1"\ncontrol_kinematics = '
                                     '"tcp"\ncontrol_angle_sign = -1\n'))
    return s


def _trt_pins(s: Path) -> str:
    """HAL ``setp`` lines of xyzac-trt-kins for the plan's pivots: the C line's point
    (``x/y/z-rot-point``) and the A line's offset from it (``y-offset``, ``z-offset``), as
    ``volcal locate --linuxcnc-hal`` writes them (tests/compensate/test_trt_closed_loop.py
    closes that loop)."""
    from volcal.session.format import read_session

    piv = read_session(s, require_deviation=False).get("r_test").meta["pivot_mm"]
    c, a = np.asarray(piv["c"], float), np.asarray(piv["a"], float)
    pins = {"x-rot-point": c[0], "y-rot-point": c[1], "z-rot-point": c[2],
            "y-offset": a[1] - c[1], "z-offset": a[2] - c[2]}
    return "".join(f"setp xyzac-trt-kins.{k} {v:.6f}\n" for k, v in pins.items())


def _rtest_truth(s: Path, tmp_path: Path) -> np.ndarray:
    """The exact readings of the nest at the planned poses for the machine, location errors
    and sphere ``volcal simulate --seed 3`` draws (its ``truth/``) [um], shape (n, 3)."""
    import shutil
    import tomllib

    from volcal.kinds import kind_of
    from volcal.kinds.r_test import RTestSetup
    from volcal.session.errortable import read_error_table
    from volcal.session.format import read_session
    from volcal.steps.simulate import save, simulate

    sim = tmp_path / "truth"
    shutil.copytree(s, sim)
    save(simulate(sim, seed=SEED), sim)
    doc = tomllib.loads((sim / "truth" / "setup.toml").read_text())["setup"]["r_test"]
    setup = RTestSetup(doc["chain"], doc["location"], np.array(doc["sphere_mm"]))
    planned = read_session(s, require_deviation=False)
    vm = read_error_table(sim / "truth" / "machine.csv", chain=planned.chain)
    return np.asarray(kind_of("r_test").exact(vm, planned.get("r_test"), setup))


def _check_rtest(tmp_path: Path, s: Path, stable_s: float, tcp: bool) -> None:
    """One row per pose, each window inside LinuxCNC's dwell at the pose (X, Y, Z within
    10 um: the pose's machine positions, or with ``tcp`` the sphere's table coordinates;
    A and C within 0.005 deg of the control's angles) on that pose's program lines, the
    three sensors' readings equal to the truth within the noise."""
    from volcal.capture.plan import dwell_lines
    from volcal.session.format import read_session

    mid = "r_test"
    planned = read_session(s, require_deviation=False).get(mid)
    sign = -1.0 if tcp else 1.0
    ja = _journal(tmp_path / "A", mid)
    assert [x["reading"] for x in ja if x["type"] == "accepted"] == list(range(planned.n))
    assert not [x for x in ja if x["type"] == "missed"]
    lines = dwell_lines(tmp_path / "P", mid)
    assert len(lines) == planned.n
    first_running = min(x["t"] for x in ja if x["type"] == "control" and x.get("running"))
    for x in (x for x in ja if x["type"] == "accepted"):
        i = x["reading"]
        lo, hi = x["window"]
        assert lo > first_running
        inside = [c for c in ja[:ja.index(x)] if c["type"] == "control" and lo <= c["t"] <= hi]
        assert len(inside) >= 5
        want = np.asarray(planned.meta["sphere_mm"], float) if tcp else planned.positions[i]
        for c in inside:
            assert c["running"] and not c["moving"] and c["line"] in lines[i], c
            p = np.array([c["pos"][a] for a in "XYZ"])
            assert np.max(np.abs(p - want)) <= 0.010, (i, c)
            for a, col in (("C", "c_deg"), ("A", "a_deg")):
                d = (c["pos"][a] - sign * planned.columns[col][i] + 180.0) % 360.0 - 180.0
                assert abs(d) <= 0.005, (i, a, c)
    m = read_session(tmp_path / "A").get(mid)
    got = np.column_stack([m.columns[k] for k in ("dx_um", "dy_um", "dz_um")])
    truth = _rtest_truth(s, tmp_path)
    assert np.max(np.abs(truth)) > 50.0  # hidden location errors of some 100 um
    # each reading the difference of two window means (the first pose's zero) of >=
    # stable_s / 0.02 samples of the laser's noise
    tol = 5 * NOISE_UM * np.sqrt(2 / (stable_s / 0.02))
    assert np.max(np.abs(got - truth)) < tol, got - truth


def _rtest_on_linuxcnc(tmp_path: Path, poses: list[tuple[int, int]], tcp: bool) -> None:
    from volcal.steps.program import program

    why = linuxcnc_missing()
    if why:
        pytest.skip(why)
    from linuxcnc_sim import xyzac_joints

    mid, stable_s = "r_test", 0.35
    s, progs = _rtest_planned(tmp_path, poses, tcp), tmp_path / "P"
    program(s, dialect="linuxcnc", output=progs, dwell_s=1.0, safe_z_mm=RT_SAFE_Z_MM)
    kins: dict = {}
    if tcp:
        kins = {"files": {"pins.hal": _trt_pins(s)}, "kinematics": "xyzac-trt-kins",
                "halfiles": ("pins.hal",), "poll_s": 0.02}
    cnc = _capture_one_run(tmp_path, s, progs, mid, "r_test.ngc", xyzac_joints(), stable_s,
                           **kins)
    _check_rtest(tmp_path, s, stable_s, tcp)
    if tcp:
        _check_trt_joints(cnc.result["res"]["series"]["p0"], s, tmp_path / "P")


def _check_trt_joints(series: list[dict], s: Path, progs: Path) -> None:
    """LinuxCNC's trt kinematics put its joints where volcal computed the machine
    positions of each pose (X, Y, Z within 10 um; A, C the control's angles within 0.005
    deg), during each pose's ``G4`` (the driver's samples of the program): what the
    simulated nest assumes when it reads the machine at the pose's positions."""
    from volcal.capture.plan import dwell_lines
    from volcal.session.format import read_session

    m = read_session(s, require_deviation=False).get("r_test")
    lines = dwell_lines(progs, "r_test")
    for i, pair in enumerate(lines):
        # (LinuxCNC's current line in a G4 is the move's before it, or the G4's)
        at = [x for x in series if x["delay_left"] > 0 and x["line"] in pair]
        assert len(at) >= 10, (i, pair, len(at))
        want = [*m.positions[i], -m.columns["a_deg"][i], -m.columns["c_deg"][i]]
        for x in at:
            got = np.asarray(x["joint_actual_position"][:5], float)
            assert np.max(np.abs(got[:3] - want[:3])) <= 0.010, (i, got, want)
            assert np.max(np.abs(got[3:] - want[3:])) <= 0.005, (i, got, want)


def test_rtest_capture_on_linuxcnc_trimmed(tmp_path):
    """volcal's R-test program (the default ``r_test:ca`` plan cut to 4 poses) run once by
    LinuxCNC on X, Y, Z, A, C joints (trivial kinematics: the program's X, Y, Z are the
    machine positions volcal computed): the rotary axes turn with the linear axes
    following, a dwell at each pose; ``volcal capture --control linuxcnc`` takes one row
    per pose from the bridge's X, Y, Z, A and C, the simulated nest reading the machine
    ``volcal simulate --seed 3`` draws at LinuxCNC's actual pose: 35-45 s."""
    _rtest_on_linuxcnc(tmp_path, RT_POSES, tcp=False)


def test_rtest_capture_on_linuxcnc_tcp_trimmed(tmp_path):
    """The same on LinuxCNC's own ``xyzac-trt-kins`` with the plan's pivots as its pins
    (``control_kinematics = "tcp"``, ``control_angle_sign = -1``): the program holds X, Y, Z
    at the sphere's table coordinates and turns the rotary axes alone, LinuxCNC's
    kinematics move the joints, during each dwell to the machine positions volcal computed;
    the bridge reports the table coordinates and the control's angles, the capture matches
    each pose in them, the nest reads the machine at the pose: 3 poses, 30-40 s."""
    _rtest_on_linuxcnc(tmp_path, RT_POSES[:3], tcp=True)
