"""Command-line times beside the in-process ones (issue 19: speed as a user sees it).

The session is the seeds' full test set with one bidirectional run per line (4 step
diagonals with a flat mirror, 4 body diagonals, 9 lines), chain XYFZ, 0.5 um noise, made
with ``volcal plan --runs 1 --steps N`` and ``volcal simulate``. Each command is run as a
whole process (the ``volcal`` console script beside this Python, or ``python -c`` when
there is none), ``REPEAT`` times after one warm-up run; the rows give the **median**
wall-clock time and, in the note, the median CPU time of the child (user + system,
``os.wait4``), which a busy shared machine inflates less. Targets (issue 19):
``volcal identify`` 1.1 s at 100 increments and 2 s at 1000, end to end;
``volcal predict`` 0.1 s beyond start-up; start-up is taken as ``volcal predict --help``
(interpreter, typer, numpy, the command's module), and the time beyond ``volcal
--version`` (interpreter and typer only) is recorded too. Run through ``make bench``,
which compiles volcal to bytecode first (``make bytecode``).
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPEAT = 5


def _volcal() -> list[str]:
    exe = Path(sys.executable).with_name("volcal")
    if exe.is_file():
        return [str(exe)]
    return [sys.executable, "-c", "from volcal.cli import main; main()"]


def _run_once(args: list[str]) -> tuple[float, float]:
    """Wall-clock and CPU seconds of one run of ``volcal ARGS`` (output discarded)."""
    t0 = time.perf_counter()
    p = subprocess.Popen([*_volcal(), *args], stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    err = p.stderr.read().decode() if p.stderr else ""
    if p.stderr:
        p.stderr.close()
    if p.returncode != 0:
        raise RuntimeError(f"volcal {' '.join(args)} failed: {err}")
    return wall, usage.ru_utime + usage.ru_stime


def timed(args: list[str], repeat: int = REPEAT) -> tuple[float, float]:
    """Median wall-clock and CPU seconds of ``repeat`` runs after one warm-up run."""
    _run_once(args)
    runs = [_run_once(args) for _ in range(repeat)]
    return (statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs))


def _in_process(session: Path, model: Path, repeat: int = 3) -> float:
    """Median seconds of read_session + identify + write the model, in this process."""
    from volcal.identify import IdentifyOptions, identify
    from volcal.session.format import read_session

    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        identify(read_session(session), IdentifyOptions()).to_json(model)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def run() -> list[dict]:
    """Time ``volcal --version``, ``identify`` at 100 and 1000 increments, ``predict``."""
    rows = []
    tmp = Path(tempfile.mkdtemp(prefix="volcal-bench-cli-"))
    try:
        start_w, start_c = timed(["--version"])
        rows.append({"benchmark": "volcal --version (start-up)", "size": "-",
                     "seconds": start_w, "note": f"cpu {start_c:.3f} s"})
        for steps, target in ((100, 1.1), (1000, 2.0)):
            s = tmp / f"S{steps}"
            _run_once(["plan", "-o", str(s), "--steps", str(steps), "--runs", "1"])
            _run_once(["simulate", str(s), "--seed", "1"])
            n = sum(max(0, len(f.read_text().splitlines()) - 1) for f in s.glob("*.csv"))
            wall, cpu = timed(["identify", str(s), "-o", str(tmp / f"m{steps}.json")])
            inproc = _in_process(s, tmp / f"m{steps}-in.json")
            rows.append({"benchmark": "volcal identify (command line, end to end)",
                         "size": f"{steps} incr, {n} readings", "seconds": wall,
                         "target_s": target,
                         "note": f"cpu {cpu:.2f} s; in-process read+identify+write "
                                 f"{inproc:.2f} s"})
        pts = tmp / "points.csv"
        pts.write_text("x_mm,y_mm,z_mm\n" + "".join(
            f"{x},{y},{z}\n" for x in range(0, 801, 100) for y in range(0, 601, 100)
            for z in range(0, 501, 100)))
        wall, cpu = timed(["predict", str(tmp / "m100.json"), "--points", str(pts), "-o",
                           str(tmp / "pred.csv")])
        help_w, help_c = timed(["predict", "--help"])
        rows.append({"benchmark": "volcal predict --help (the command's start-up)",
                     "size": "-", "seconds": help_w, "note": f"cpu {help_c:.3f} s"})
        # the differences of two medians of short runs: CPU is steadier than wall-clock
        # on a shared machine, and equal to it on an idle one (single-threaded)
        rows.append({"benchmark": "volcal predict beyond its start-up (predict --help), CPU",
                     "size": "378 points, model of 100 incr", "seconds": cpu - help_c,
                     "target_s": 0.1,
                     "note": f"whole process {wall:.3f} s wall, {cpu:.3f} s cpu; wall "
                             f"difference {wall - help_w:.3f} s"})
        rows.append({"benchmark": "volcal predict beyond volcal --version, CPU",
                     "size": "378 points, model of 100 incr", "seconds": cpu - start_c,
                     "note": f"wall difference {wall - start_w:.3f} s: numpy, typer's "
                             "parameter coercion (pydantic), rich"})
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return rows


if __name__ == "__main__":
    for row in run():
        print(row)
