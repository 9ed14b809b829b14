"""Random journeys through the command line: no traceback, only a result or a refusal.

A demanding user's sessions are not the defaults: travels that start below zero, short
and long axes side by side, any kinematic chain, 2 to 17 increments, mixes of tests
(linear, body, face and step diagonals, direct optics, multilateration, rotary, probe and
R-test), one to five runs. Each journey plans such a session, simulates it and takes it
through every step (evaluate, identify, advise, locate, compensate for every controller,
program for every dialect, report, history), the way session 26's fuzzing did by hand.

Each command must end with exit code 0 or 2 (a user's mistake or a design the step
cannot serve, refused with its message), never a traceback: the sweep of known mistakes
(tests/cli/test_user_mistakes_sweep.py) checks the wording; this one checks that no
combination of legitimate options reaches an unhandled error. Slow (``make study``): each
journey takes 10-60 s.

Capture journeys (:func:`test_a_random_capture_journey_records_every_dwell`): a short
test captured with a simulated control of random acceleration, position noise, overshoot
and flags, and random trigger options: every dwell gives its row.

Found by these journeys (session 26), fixed: ``--tests linear,linear:x`` refused naming
only the duplicate id; two full-circle rotary axes' Fanuc tables refused, naming an option
the command did not have (``--rotary-spacing``, now there); a session of a CA and a CB
trunnion refused by ``locate`` without naming the tests of each; a control's position
noise across the target window ended a dwell and refused the next sample as a mismatch.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from volcal_cli_helpers import volcal_process

pytestmark = pytest.mark.slow

CHAINS = ["XYFZ", "FXYZ", "YFXZ", "XFYZ", "FYXZ", "YXFZ", "XYZF", "FZXY", "ZFXY"]
TESTS = ["step-diagonal", "diagonal", "linear", "face-diagonal", "face-step-diagonal",
         "linear:x", "linear:z", "face-diagonal:xy", "face-step-diagonal:yz", "direct",
         "multilateration", "rotary:c", "rotary:a", "probe_sphere:ca", "r_test:cb"]
FORMATS = ["fanuc", "siemens", "heidenhain", "linuxcnc", "csv", "isg", "grid"]
DIALECTS = ["fanuc", "linuxcnc", "siemens", "heidenhain"]


def _journey(seed: int) -> list[tuple[str, ...]]:
    """The commands of journey ``seed`` (the later ones name the files the earlier write)."""
    rng = random.Random(seed)
    travel = []
    for _ in range(3):
        length = rng.choice([60, 200, 500, 800, 1500, 3000])
        low = rng.choice([0, -length, -length / 2, 100])
        travel.append(f"{low:g}:{low + length:g}")
    plan = ["plan", "-o", "S", "--travel", ",".join(travel), "--chain", rng.choice(CHAINS),
            "--steps", str(rng.choice([2, 3, 5, 10, 17])), "--runs", str(rng.choice([1, 2, 5])),
            "--tests", ",".join(rng.sample(TESTS, rng.randint(1, 4)))]
    if rng.random() < 0.3:
        plan += ["--no-iso-spacing"]
    if rng.random() < 0.3:
        plan += ["--step-target", rng.choice(["retroreflector", "retroreflector_mirror"])]
    if rng.random() < 0.3:
        plan += ["--step-orders", rng.choice(["xyz,yxz", "zyx"])]
    out = [tuple(plan), ("simulate", "S", "--seed", str(seed)), ("evaluate", "session", "S"),
           ("identify", "S", "-o", "M.json"), ("evaluate", "volumetric", "M.json"), ("advise", "S"),
           ("locate", "S", "--json", "-o", "loc.json")]
    out += [("compensate", "M.json", "--format", f, "-o", f"C-{f}", "--session", "S")
            for f in FORMATS]
    out += [("program", "S", "-o", f"P-{d}", "--dialect", d, "--safe-z-mm",
             str(rng.choice([0, 480, 3200]))) for d in DIALECTS]
    out += [("report", "S", "--model", "M.json", "-o", "R"),
            ("history", "add", "S", "--model", "M.json", "--db", "h.sqlite", "--create"),
            ("history", "list", "--db", "h.sqlite")]
    return out


@pytest.mark.parametrize("seed", range(8))
def test_a_random_journey_ends_each_step_with_a_result_or_a_refusal(tmp_path: Path,
                                                                    seed: int):
    refused = 0
    for args in _journey(20261128 + seed):
        p = volcal_process(*args, cwd=tmp_path)
        assert "Traceback" not in p.stderr + p.stdout, (args, p.stderr[-3000:])
        assert p.returncode in (0, 2), (args, p.returncode, p.stderr[-2000:])
        if p.returncode:
            assert p.stderr.strip(), args  # a refusal says why
            refused += 1
            if args[0] in ("plan", "simulate"):
                break  # nothing to go on with (the refusal checked)
    assert refused < 20


def _capture_journey(seed: int) -> list[tuple[str, ...]]:
    """Plan a short test, capture it with a simulated control and laser of random
    behaviour (acceleration, position noise, overshoot, with or without its flags) and
    random trigger options, capture it again, evaluate and identify or locate it."""
    rng = random.Random(seed)
    tests = rng.choice(["linear:x", "linear:y", "rotary:c", "rotary:a", "diagonal",
                        "step-diagonal", "linear:z,rotary:c"])
    travel = ",".join(rng.choice(["0:200", "-100:100", "-300:0"]) for _ in range(3))
    control = "sim:" + ",".join(f"{k}={v}" for k, v in (
        ("flags", rng.choice([0, 1])), ("noise", rng.choice([0, 0.0001, 0.002])),
        ("overshoot", rng.choice([0, 0.003])), ("accel", rng.choice([50, 500, 5000]))))
    opts = ("--dwell-s", str(rng.choice([1.5, 2, 4])), "--stable-s", "0.5", "--max-gap-s",
            "0.3", "--poll-s", "0.05", "--timeout-s", "120", "--window-mm",
            str(rng.choice([0.005, 0.01, 0.05])))
    capture = ("capture", "S", "--control", control, "--laser",
               rng.choice(["sim:seed=3", "sim:seed=1,noise=0.2"]), *opts)
    return [("plan", "-o", "S", "--travel", travel, "--tests", tests, "--steps", "3", "--runs",
             "2"), capture, capture, ("evaluate", "session", "S"),
            ("identify", "S", "-o", "M.json")]


@pytest.mark.parametrize("seed", range(4))
def test_a_random_capture_journey_records_every_dwell(tmp_path: Path, seed: int):
    """Every capture of a random simulated control is complete: one accepted row per dwell
    (the control's noise up to 2 um across windows down to 5 um: session 26's fix), and
    the second capture finds nothing left to do."""
    for args in _capture_journey(20261128 + seed):
        p = volcal_process(*args, cwd=tmp_path)
        assert "Traceback" not in p.stderr + p.stdout, (args, p.stderr[-3000:])
        assert p.returncode in (0, 2), (args, p.returncode, p.stderr[-2000:])
        if args[0] == "capture":
            assert p.returncode == 0, (args, p.stderr[-2000:])
            assert "missed" not in p.stdout.replace("0 missed", ""), p.stdout
