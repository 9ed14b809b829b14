"""User mistakes sweep (session 9): a new user's typical mistakes on every command.

An outside tester made 72 deliberate new-user mistakes and 17 were not refused well. This
sweep plays that tester again on every command (plan, program, simulate, import, identify,
predict, locate, advise, budget, evaluate, compensate, report, certificate, history,
capture, env, classic, the optics and multilateration sessions) with the mistakes
tests/cli/test_cli_bad_input.py does not try: Excel artefacts in CSV files (BOM, comma
decimals, semicolons, blank rows), duplicated or unsorted positions, TOML keys of the wrong
name or type, options out of range, a session folder of the wrong kind, a model of another
machine or travel, an output path over measured data or files volcal did not write, an
output in a folder that does not exist, mixed as-found/as-left sessions, wrong axis names,
empty sessions, Ctrl-C midway.

Each case copies the inputs built once (:func:`base`) into a fresh folder, spoils one
thing, runs ``volcal`` in-process and asserts what a user must see:

- the exit code (2 for a user mistake unless the case says otherwise);
- no ``Traceback``;
- a one-line message naming the file and, where the problem is in a row, the row and the
  column (or the TOML key, or the option);
- not a byte of the folder created, changed or removed (unless the case succeeds and says
  what it writes).

``Case.before`` records what today's volcal did before this session's fixes ("ok": refused
well already; otherwise what went wrong); benchmarks/README.md "User mistakes sweep
(session 9)" counts them.
"""

from __future__ import annotations

import re
import shutil
import sqlite3
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from cli_mutations import (
    Mutation,
    chain_of,
    edit,
    put,
    remove,
    rename_column,
    set_cell,
    touch_snapshot,
)
from volcal_cli_helpers import volcal_process

TRAVEL = "0:400,0:300,0:200"


def volcal(*args: object, cwd: Path | None = None):
    return volcal_process(*args, cwd=cwd, env=None)


# ---------------------------------------------------------------------------------------------
# the inputs, built once
# ---------------------------------------------------------------------------------------------

LASER = "Target (mm),Run,Dir,Error (um)\n" + "".join(
    f"{t},{r},{d},{e}\n" for r in (1, 2) for t, d, e in
    [(0, "fwd", 0.0), (100, "fwd", 1.2), (200, "fwd", 2.5),
     (200, "bwd", 3.1), (100, "bwd", 1.9), (0, "bwd", 0.4)])
LASER_MAP = "target=Target (mm),run=Run,direction=Dir,deviation=Error (um)"
POINTS = "x_mm,y_mm,z_mm\n0,0,0\n100,50,20\n400,300,200\n"


def _ok(r) -> None:
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``P`` planned, ``S`` measured, ``MODEL.json``, ``ERRORS.csv``, ``COMP``, ``PS``
    (probe on sphere), ``OPT`` (direct optics), ``ROT`` (rotary C), ``ML``
    (multilateration), ``H.sqlite`` (a history with ``S``), ``points.csv``, ``laser.csv``."""
    d = tmp_path_factory.mktemp("sweep")
    _ok(volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", "-o", d / "P"))
    shutil.copytree(d / "P", d / "S")
    _ok(volcal("simulate", d / "S", "--seed", "1"))
    shutil.copy(d / "S" / "truth" / "machine.csv", d / "ERRORS.csv")
    shutil.copy(d / "S" / "truth" / "machine.toml", d / "ERRORS.toml")
    _ok(volcal("identify", d / "S", "-o", d / "MODEL.json"))
    _ok(volcal("compensate", d / "ERRORS.csv", "--format", "csv", "--sign", "error",
               "-o", d / "COMP"))
    _ok(volcal("plan", "--travel", "0:800,0:600,0:500", "--tests", "probe_sphere",
               "-o", d / "PS"))
    _ok(volcal("simulate", d / "PS", "--seed", "7"))
    _ok(volcal("plan", "--travel", TRAVEL, "--tests", "direct", "--steps", "3", "--runs", "2",
               "-o", d / "OPT"))
    _ok(volcal("simulate", d / "OPT", "--seed", "3"))
    _ok(volcal("plan", "--travel", TRAVEL, "--tests", "rotary:c", "--runs", "2",
               "-o", d / "ROT"))
    _ok(volcal("simulate", d / "ROT", "--seed", "3"))
    _ok(volcal("plan", "--travel", TRAVEL, "--tests", "multilateration", "--grid", "3,3,3",
               "-o", d / "ML"))
    _ok(volcal("simulate", d / "ML", "--seed", "3"))
    _ok(volcal("history", "add", d / "S", "--model", d / "MODEL.json", "--db", d / "H.sqlite",
               "--create"))
    (d / "laser.csv").write_text(LASER)
    (d / "points.csv").write_text(POINTS)
    (d / "notes.txt").write_text("my own notes\n")
    (d / "EMPTY").mkdir()
    (d / "empty.csv").write_text("")
    (d / "garbage.bin").write_bytes(bytes(range(256)) * 8)
    return d


# ---------------------------------------------------------------------------------------------
# mutations
# ---------------------------------------------------------------------------------------------

def sub(rel: str, old: str, new: str, count: int = 1) -> Mutation:
    """Replace ``old`` by ``new`` in ``rel`` (the text must hold ``old``)."""
    def fn(t: str) -> str:
        assert old in t, (rel, old)
        return t.replace(old, new, count)
    return edit(rel, fn)


def resub(rel: str, pattern: str, new: str) -> Mutation:
    """Replace the first match of the regular expression ``pattern`` in ``rel``.

    For numbers whose last digit depends on the machine's floating point (a unit vector
    normalised by ``numpy.linalg.norm``: 0.7427813527082076 on one CPU, ...074 on another).
    """
    def fn(t: str) -> str:
        out, n = re.subn(pattern, new, t, count=1)
        assert n == 1, (rel, pattern)
        return out
    return edit(rel, fn)


def lines_of(rel: str, fn: Callable[[list[str]], list[str]]) -> Mutation:
    """Rewrite the lines of ``rel``."""
    return edit(rel, lambda t: "\n".join(fn(t.splitlines())) + "\n")


def swap_lines(rel: str, a: int, b: int) -> Mutation:
    """Swap lines ``a`` and ``b`` (1-based)."""
    def fn(ls: list[str]) -> list[str]:
        ls[a - 1], ls[b - 1] = ls[b - 1], ls[a - 1]
        return ls
    return lines_of(rel, fn)


def european(rel: str) -> Mutation:
    """A CSV as a German Excel saves it: semicolons, decimal commas."""
    return edit(rel, lambda t: t.replace(",", ";").replace(".", ","))


# ---------------------------------------------------------------------------------------------
# the cases
# ---------------------------------------------------------------------------------------------


@dataclass
class Case:
    """One mistake: the command line, how the inputs are spoiled, what the user must see.

    ``code`` is the exit code (2: refused as a user mistake); ``expect`` the fragments the
    message names; ``writes`` the paths a successful case may create (nothing else may
    change); ``before`` what volcal did before session 9's fixes."""

    id: str
    args: list[str]
    expect: tuple[str, ...] = ()
    mutate: Mutation | None = None
    code: int = 2
    writes: tuple[str, ...] = ()
    before: str = "ok"


M = "{d}/MODEL.json"
CASES: list[Case] = [
    # ---- session CSV files as spreadsheets leave them ----
    Case("evaluate:csv-bom", ["evaluate", "session", "{d}/S"], (),
         edit("S/linear-x1.csv", lambda t: "\ufeff" + t), code=0),
    Case("identify:csv-crlf", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         edit("S/linear-x1.csv", lambda t: t.replace("\n", "\r\n")), code=0),
    Case("evaluate:csv-european", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         european("S/linear-x1.csv"), code=0,
         before="refused: missing required column 'target_mm' (a session CSV saved with "
         "semicolons and decimal commas, which the session reader reads)"),
    Case("evaluate:csv-european-target-layout", ["evaluate", "iso230-2", "{d}/pos.csv"], (),
         put("pos.csv", "target_mm;run;direction;deviation_um\n" + "".join(
             f"{t};{r};{d};{v}\n" for r in (1, 2) for t, d, v in
             [("0", "+", "0,0"), ("100", "+", "1,2"), ("200", "+", "2,5"), ("200", "-", "3,1"),
              ("100", "-", "1,9"), ("0", "-", "0,4")])), code=0,
         before="refused: missing required column 'target_mm'"),
    Case("evaluate:csv-bom-file", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         edit("S/linear-x1.csv", lambda t: "\ufeff" + t), code=0),
    Case("identify:csv-european", ["evaluate", "session", "{d}/S"], (),
         european("S/linear-x1.csv"), code=0),
    Case("evaluate:csv-comma-decimal", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 3", "deviation_um"),
         set_cell("S/linear-x1.csv", 3, "deviation_um", '"4,08"')),
    Case("evaluate:csv-blank-rows", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         lines_of("S/linear-x1.csv", lambda ls: ls[:4] + ["", ""] + ls[4:]), code=0),
    Case("evaluate:csv-row-of-commas", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         lines_of("S/linear-x1.csv", lambda ls: ls[:4] + [",,,,,,"] + ls[4:]), code=0),
    Case("evaluate:csv-deviation-mm", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 1", "deviation_mm"),
         rename_column("S/linear-x1.csv", "deviation_um", "deviation_mm")),
    Case("evaluate:csv-run-zero", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("only 3 run(s) up",), set_cell("S/linear-x1.csv", 2, "run", "0"), code=0),
    Case("evaluate:csv-time-text", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 3", "time_s"), set_cell("S/linear-x1.csv", 3, "time_s", "noon")),
    Case("identify:csv-duplicated-position", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv", "row 4", "column 'x_mm'", "pose x = 143.903 mm read twice in run 1 "
          "direction + (also on row 3): a duplicated line?"),
         set_cell("S/linear-x1.csv", 4, "x_mm", "143.903"),
         before="accepted: the model fitted both readings of one pose"),
    Case("evaluate:csv-unsorted-rows", ["evaluate", "session", "{d}/S"],
         (), swap_lines("S/linear-x1.csv", 3, 4), code=0),
    Case("evaluate:csv-diagonal-unsorted", ["evaluate", "session", "{d}/S"],
         (), swap_lines("S/diag-ppp.csv", 3, 4), code=0),
    Case("identify:csv-header-only", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv",), lines_of("S/linear-x1.csv", lambda ls: ls[:1])),
    Case("identify:csv-empty-file", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv",), put("S/linear-x1.csv", "")),
    Case("identify:csv-is-folder", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv",), chain_of(remove("S/linear-x1.csv"), put("S/linear-x1.csv/a", "x"))),
    Case("evaluate:csv-extra-column", ["evaluate", "session", "{d}/S"], (),
         edit("S/linear-x1.csv", lambda t: "\n".join(
             ln + (",comment" if i == 0 else ",ok") for i, ln in enumerate(t.splitlines()))
             + "\n"), code=0),
    Case("identify:csv-duplicate-column", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv", "row 1", "deviation_um"),
         edit("S/linear-x1.csv", lambda t: "\n".join(
             ln + (",deviation_um" if i == 0 else ",0") for i, ln in enumerate(t.splitlines()))
             + "\n")),
    Case("identify:csv-latin1", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("linear-x1.csv",), lambda d: (d / "S/linear-x1.csv").write_bytes(
             (d / "S/linear-x1.csv").read_text().replace("deviation_um", "deviation_\u00b5m")
             .encode("latin-1"))),
    # ---- session TOML: wrong keys, wrong types ----
    Case("identify:toml-travel-string", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "travel_mm.x"), sub("S/session.toml", "x = [0.0, 400.0]",
                                              'x = "0:400"')),
    Case("identify:toml-travel-inverted", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "travel_mm.x"), sub("S/session.toml", "x = [0.0, 400.0]",
                                              "x = [400.0, 0.0]")),
    Case("identify:toml-chain-int", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "chain"), sub("S/session.toml", 'chain = "XYFZ"', "chain = 5")),
    Case("identify:toml-format-version", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "format"), sub("S/session.toml", '"volcal-session/1"',
                                         '"volcal-session/9"')),
    Case("identify:toml-machine-key-typo", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "travel_mm"), sub("S/session.toml", "[machine.travel_mm]",
                                            "[machine.travel]")),
    Case("identify:toml-tool-offset-two", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "tool_offset_mm"),
         sub("S/session.toml", "tool_offset_mm = [0.0, 0.0, 0.0]", "tool_offset_mm = [0.0, 0.0]")),
    Case("identify:toml-duplicate-id", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "step-npp"), sub("S/session.toml", 'id = "step-ppp"',
                                           'id = "step-npp"')),
    Case("identify:toml-file-escapes", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "measurements[0].file", "'../points.csv' is outside the session "
          "folder"), sub("S/session.toml", 'file = "step-ppp.csv"', 'file = "../points.csv"'),
         before="read ../points.csv outside the session folder (refused for its columns)"),
    Case("identify:toml-same-file-twice", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "measurements[1].file", "'step-ppp.csv' is also the file of "
          "measurement 'step-ppp'"),
         sub("S/session.toml", 'file = "step-npp.csv"', 'file = "step-ppp.csv"'),
         before="accepted: two measurements read one file"),
    Case("evaluate:toml-beam-not-unit", ["evaluate", "session", "{d}/S"],
         (), resub("S/session.toml", r"beam_direction = \[0\.742781352708207\d, "
                   r"0\.557086014531155\d, 0\.371390676354103\d\]",
                   "beam_direction = [1.0, 1.0, 1.0]"),
         code=0),
    Case("identify:toml-diagonal-unknown", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "diagonal"), sub("S/session.toml", 'diagonal = "ppp"',
                                           'diagonal = "pxp"')),
    Case("identify:toml-axis-order-bad", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "axis_order"), sub("S/session.toml", 'axis_order = "xyz"',
                                             'axis_order = "xyy"')),
    Case("identify:toml-no-measurements", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml",), edit("S/session.toml", lambda t: t.split("[[measurements]]")[0])),
    Case("identify:toml-referred-text", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "referred_to_20c"),
         sub("S/session.toml", "referred_to_20c = true", 'referred_to_20c = "yes"')),
    Case("locate:toml-sphere-text", ["locate", "{d}/PS"], ("session.toml", "sphere_mm"),
         sub("PS/session.toml", "sphere_mm = [550.0, 300.0, 375.353]",
             'sphere_mm = ["a", 300.0, 375.353]')),
    Case("locate:toml-pivot-two", ["locate", "{d}/PS"], ("session.toml", "pivot_mm"),
         sub("PS/session.toml", "c = [400.0, 300.0, 335.353]", "c = [400.0, 300.0]")),
    Case("evaluate:toml-rotary-range-inverted", ["evaluate", "session", "{d}/ROT"],
         ("session.toml", "range_deg"), sub("ROT/session.toml", "range_deg = [0.0, 360.0]\nmodulo",
                                            "range_deg = [360.0, 0.0]\nmodulo")),
    Case("evaluate:toml-rotary-axis-linear", ["evaluate", "session", "{d}/ROT"],
         ("session.toml", "axis"), sub("ROT/session.toml", 'axis = "c"', 'axis = "x"')),
    Case("identify:toml-station-two", ["identify", "{d}/ML", "-o", "{d}/M2.json"],
         ("session.toml", "station_mm"), sub("ML/session.toml", "station_mm = [90.0, 80.0, -160.0]",
                                             "station_mm = [90.0, 80.0]")),
    Case("evaluate:toml-optics-error-direction", ["evaluate", "optics", "{d}/OPT"],
         ("session.toml", "error_direction"),
         sub("OPT/session.toml", 'error_direction = "y"', 'error_direction = "x"')),
    # ---- other kinds' CSV files ----
    Case("evaluate:rotary-text", ["evaluate", "session", "{d}/ROT"],
         ("rotary-c.csv", "row 3", "deviation_urad"),
         set_cell("ROT/rotary-c.csv", 3, "deviation_urad", "n/a")),
    Case("evaluate:rotary-arcsec-header", ["evaluate", "session", "{d}/ROT"],
         (), rename_column("ROT/rotary-c.csv", "deviation_urad", "deviation_arcsec"), code=0),
    Case("evaluate:rotary-target-outside", ["evaluate", "session", "{d}/ROT"],
         ("rotary-c.csv", "row 3", "target_deg"), set_cell("ROT/rotary-c.csv", 3, "target_deg",
                                                           "720")),
    Case("locate:probe-text", ["locate", "{d}/PS"], ("probe_sphere.csv", "row 3", "x_mm"),
         set_cell("PS/probe_sphere.csv", 3, "x_mm", "5O0.1")),
    Case("locate:probe-missing-angle", ["locate", "{d}/PS"],
         ("probe_sphere.csv", "row 1", "a_deg"), rename_column("PS/probe_sphere.csv", "a_deg",
                                                              "b_deg")),
    Case("evaluate:optics-text", ["evaluate", "optics", "{d}/OPT"],
         ("ang-xb.csv", "row 3", "angle_urad"), set_cell("OPT/ang-xb.csv", 3, "angle_urad", "?")),
    Case("evaluate:optics-arcsec-header", ["evaluate", "optics", "{d}/OPT"],
         ("lev-xa.csv", "row 1", "angle_urad"),
         rename_column("OPT/lev-xa.csv", "angle_urad", "angle_arcsec")),
    Case("identify:ml-nan", ["identify", "{d}/ML", "-o", "{d}/M2.json"],
         ("trk-s1-t1.csv", "row 3", "length_mm"),
         set_cell("ML/trk-s1-t1.csv", 3, "length_mm", "NaN")),
    Case("identify:ml-length-um", ["identify", "{d}/ML", "-o", "{d}/M2.json"],
         ("trk-s1-t1.csv", "row 1", "length_mm"),
         rename_column("ML/trk-s1-t1.csv", "length_mm", "length_um")),
    # ---- a session folder of the wrong kind ----
    Case("locate:linear-session", ["locate", "{d}/S"],
         ("S/session.toml", "the session has no probe_sphere test and no r_test test"),
         before="message named no file"),
    Case("evaluate-optics:no-optics", ["evaluate", "optics", "{d}/S"], ("S",)),
    Case("classic-optics:no-optics", ["classic", "optics", "{d}/S"], ("S",)),
    Case("evaluate-iso230-6:optics-session", ["evaluate", "iso230-6", "{d}/OPT"], ("OPT",)),
    Case("classic-abbe-session:rotary", ["classic", "abbe-session", "{d}/ROT"], ("ROT",)),
    Case("program:rotary-session", ["program", "{d}/ROT", "--dialect", "heidenhain",
                                    "-o", "{d}/PROG"], (), code=0, writes=("PROG",)),
    Case("identify:probe-session", ["identify", "{d}/PS", "-o", "{d}/M2.json"],
         ("PS/session.toml", "no measurements selected for identification"),
         before="message named no file"),
    Case("identify:history-db-as-session", ["identify", "{d}/H.sqlite", "-o", "{d}/M2.json"],
         ("H.sqlite",)),
    Case("identify:compensation-folder", ["identify", "{d}/COMP", "-o", "{d}/M2.json"],
         ("COMP", "session.toml")),
    Case("evaluate:session-toml-given", ["evaluate", "session", "{d}/S/session.toml"],
         (), code=0),
    Case("report:empty-session", ["report", "{d}/E", "-o", "{d}/R"], ("E",),
         chain_of(put("E/session.toml", 'format = "volcal-session/1"\n[machine]\nname = "V"\n'
                      'chain = "XYFZ"\n[machine.travel_mm]\nx = [0.0, 400.0]\n'
                      'y = [0.0, 300.0]\nz = [0.0, 200.0]\n'))),
    Case("evaluate:empty-session", ["evaluate", "session", "{d}/E"], ("E",),
         put("E/session.toml", 'format = "volcal-session/1"\n[machine]\nname = "V"\n'
             'chain = "XYFZ"\n[machine.travel_mm]\nx = [0.0, 400.0]\n'
             'y = [0.0, 300.0]\nz = [0.0, 200.0]\n')),
    # ---- options out of range ----
    Case("plan:steps-one", ["plan", "--steps", "1", "-o", "{d}/N"], (), code=0, writes=("N",)),
    Case("plan:travel-zero-length", ["plan", "--travel", "0:0,0:300,0:200", "-o", "{d}/N"],
         ("--travel",)),
    Case("plan:overrun-negative", ["plan", "--overrun-mm", "-5", "-o", "{d}/N"],
         ("--overrun-mm -5.0: expected a finite number >= 0 [mm]",),
         before="message named no option"),
    Case("plan:overrun-too-big", ["plan", "--travel", TRAVEL, "--overrun-mm", "300",
                                  "-o", "{d}/N"],
         ("--overrun-mm 300: the linear margin leaves no travel on X",),
         before="message named no option"),
    Case("plan:abbe-offset-nan", ["plan", "--abbe-offset-mm", "nan", "-o", "{d}/N"],
         ("--abbe-offset-mm nan: expected a finite number > 0 [mm]",),
         before="message named no option"),
    Case("plan:step-target-unknown", ["plan", "--step-target", "prism", "-o", "{d}/N"],
         ("prism",)),
    Case("plan:rotary-axes-inverted", ["plan", "--tests", "rotary:c", "--rotary-axes",
                                       "c:360:0:modulo", "-o", "{d}/N"],
         ("--rotary-axes: rotary axis 'c:360:0:modulo': expected min < max [deg]",),
         before="message named no option"),
    Case("plan:rotary-axes-unknown-name", ["plan", "--tests", "rotary:q", "-o", "{d}/N"],
         ("rotary:q",)),
    Case("plan:rotary-axes-linear-name", ["plan", "--tests", "rotary:c", "--rotary-axes",
                                          "x:0:360", "-o", "{d}/N"],
         ("--rotary-axes: rotary axis 'x:0:360'",), before="message named no option"),
    Case("plan:rotary-axes-bad-kind", ["plan", "--tests", "rotary:c", "--rotary-axes",
                                       "c:0:360:endless", "-o", "{d}/N"], ("endless",)),
    Case("plan:targets-text", ["plan", "--tests", "rotary:c", "--targets", "0,ninety,180",
                               "-o", "{d}/N"], ("--targets",)),
    Case("plan:targets-outside", ["plan", "--tests", "rotary:a", "--rotary-axes",
                                  "a:-120:30:limited", "--targets", "0,90", "-o", "{d}/N"],
         ("--targets",)),
    Case("plan:grid-zero", ["plan", "--tests", "multilateration", "--grid", "0,3,3",
                            "-o", "{d}/N"], ("--grid",)),
    Case("plan:grid-two", ["plan", "--tests", "multilateration", "--grid", "3,3",
                           "-o", "{d}/N"], ("--grid",)),
    Case("plan:stations-two", ["plan", "--tests", "multilateration", "--stations", "2",
                               "-o", "{d}/N"], ("--stations",)),
    Case("plan:stations-text", ["plan", "--tests", "multilateration", "--stations", "four",
                                "-o", "{d}/N"], ("--stations",)),
    Case("plan:tool-offsets-two", ["plan", "--tests", "multilateration", "--tool-offsets",
                                   "0,0;1,1", "-o", "{d}/N"], ("--tool-offsets",)),
    Case("plan:name-empty", ["plan", "--name", "", "-o", "{d}/N"],
         ("--name '': expected the machine's name",),
         before="accepted: a session of a machine without a name"),
    Case("plan:tests-lowercase-axis-ok", ["plan", "--tests", "linear:X", "-o", "{d}/N"], (),
         code=0, writes=("N",)),
    Case("plan:tests-hyphen-or-underscore-ok", ["plan", "--tests",
         "probe-sphere:ca,R-Test:ca,step_diagonal", "-o", "{d}/N"], (), code=0, writes=("N",),
         before="refused: unknown test(s) probe-sphere (the other tests are spelt with '-')"),
    Case("simulate:budget-missing", ["simulate", "{d}/P", "--budget", "{d}/NOPE.toml"],
         ("NOPE.toml",)),
    Case("simulate:budget-garbage", ["simulate", "{d}/P", "--budget", "{d}/garbage.bin"],
         ("garbage.bin",)),
    Case("identify:max-nodes-zero", ["identify", "{d}/S", "--max-nodes", "0", "-o",
                                     "{d}/M2.json"], ("--max-nodes",)),
    Case("identify:roll-uppercase", ["identify", "{d}/S", "--roll", "ZERO", "-o", "{d}/M2.json"],
         ("ZERO",)),
    Case("identify:known-other-travel", ["identify", "{d}/S", "--known", "{d}/PSE.csv",
                                         "-o", "{d}/M2.json"], (),
         lambda d: shutil.copy(d / "PS" / "truth" / "machine.csv", d / "PSE.csv"), code=0,
         writes=("M2.json", "M2.npz")),
    Case("advise:top-zero", ["advise", "{d}/PS", "--top", "0"], ("--top",)),
    Case("advise:candidates-missing", ["advise", "{d}/PS", "--candidates", "{d}/NOPE.csv"],
         ("NOPE.csv",)),
    Case("advise:candidates-bad", ["advise", "{d}/PS", "--candidates", "{d}/points.csv"],
         ("points.csv", "row 1")),
    Case("advise:missing-session", ["advise", "{d}/NOPE"], ("NOPE",)),
    Case("advise:roll-unknown", ["advise", "{d}/P", "--roll", "maybe"], ("maybe",)),
    Case("locate:prior-nan", ["locate", "{d}/PS", "--prior-u", "nan"], ("--prior-u",)),
    Case("locate:tool-carrier-negative", ["locate", "{d}/PS", "--siemens-tcarr", "{d}/T.mpf",
                                          "--tool-carrier", "-1"],
         ("--tool-carrier -1: expected a record number",), before="message named no option"),
    Case("locate:z-rot-nan", ["locate", "{d}/PS", "--linuxcnc-hal", "{d}/trt.hal",
                              "--z-rot-point-mm", "nan"],
         ("--z-rot-point-mm nan: expected a finite number [mm]",),
         before="wrote nan pins into trt.hal"),
    Case("locate:model-garbage", ["locate", "{d}/PS", "--model", "{d}/garbage.bin"],
         ("garbage.bin",)),
    Case("locate:model-session-folder", ["locate", "{d}/PS", "--model", "{d}/PS"],
         ("a session folder, not a model: identify it first",),
         before="refused: error table not found"),
    Case("locate:measurements-unknown", ["locate", "{d}/PS", "--measurements", "nope"],
         ("nope",)),
    Case("budget:missing", ["budget", "{d}/NOPE.toml"], ("NOPE.toml",)),
    Case("budget:folder", ["budget", "{d}/EMPTY"], ("EMPTY",)),
    Case("budget:garbage", ["budget", "{d}/garbage.bin"], ("garbage.bin",)),
    Case("budget:length-negative", ["budget", "{d}/B.toml", "--length-mm", "-5"],
         ("--length-mm -5: expected a finite length >= 0",),
         lambda d: _ok(volcal("budget", "--template", "-o", d / "B.toml")),
         before="accepted: a budget shown at -5 mm"),
    Case("budget:unknown-key", ["budget", "{d}/B.toml"], ("B.toml",),
         chain_of(lambda d: _ok(volcal("budget", "--template", "-o", d / "B.toml")),
                  edit("B.toml", lambda t: t + "\nwavelenght_ppm = 0.1\n"))),
    Case("compensate:units-unknown", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                      "--sign", "error", "--session", "{d}/ROT", "--units",
                                      "grad", "-o", "{d}/C2"], ("grad",)),
    Case("compensate:magnification-zero", ["compensate", "{d}/ERRORS.csv", "--format", "fanuc",
                                           "--magnification", "0", "-o", "{d}/C2"],
         ("--magnification",)),
    Case("compensate:max-increment-negative", ["compensate", "{d}/ERRORS.csv", "--format",
                                               "fanuc", "--max-increment", "-1", "-o",
                                               "{d}/C2"], ("--max-increment",)),
    Case("compensate:tool-offset-text", ["compensate", "{d}/ERRORS.csv", "--format", "isg",
                                         "--tool-offset", "a,b,c", "-o", "{d}/C2"],
         ("--tool-offset",)),
    Case("compensate:session-other-travel", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                             "--sign", "error", "--session", "{d}/PS",
                                             "-o", "{d}/C2"],
         ("ERRORS.csv", "not of this session's machine", "--force")),
    Case("compensate:model-other-machine", ["compensate", "{d}/M.csv", "--format", "csv",
                                            "--sign", "error", "--session", "{d}/S",
                                            "-o", "{d}/C2"],
         ("M.csv", "not of this session's machine"),
         chain_of(lambda d: shutil.copy(d / "PS" / "truth" / "machine.csv", d / "M.csv"),
                  lambda d: shutil.copy(d / "PS" / "truth" / "machine.toml", d / "M.toml"))),
    Case("report:tolerance-negative", ["report", "{d}/S", "--model", M, "--tolerance-um",
                                       "X=-10", "-o", "{d}/R"], ("--tolerance-um",)),
    Case("report:tolerance-axis-unknown", ["report", "{d}/S", "--model", M, "--tolerance-um",
                                           "W=10", "-o", "{d}/R"], ("--tolerance-um", "W")),
    Case("report:tolerance-no-equals", ["report", "{d}/S", "--model", M, "--tolerance-um",
                                        "X10", "-o", "{d}/R"], ("--tolerance-um",)),
    Case("report:angle-units-unknown", ["report", "{d}/ROT", "--angle-units", "grad",
                                        "-o", "{d}/R"], ("grad",)),
    Case("report:rotary-tolerance-negative", ["report", "{d}/ROT", "--rotary-tolerance-urad",
                                              "C=-5", "-o", "{d}/R"],
         ("--rotary-tolerance-urad",)),
    Case("report:location-tolerance-negative", ["report", "{d}/PS", "--location-tolerance-um",
                                                "-1", "-o", "{d}/R"],
         ("--location-tolerance-um",)),
    Case("report:budget-missing", ["report", "{d}/S", "--model", M, "--budget", "{d}/NOPE.toml",
                                   "-o", "{d}/R"], ("NOPE.toml",)),
    Case("report:model-other-session", ["report", "{d}/OPT", "--model", M, "-o", "{d}/R"],
         ("MODEL.json",)),
    Case("report:model-is-session", ["report", "{d}/S", "--model", "{d}/S", "-o", "{d}/R"],
         ("S",)),
    Case("report:model-is-error-table", ["report", "{d}/S", "--model", "{d}/points.csv",
                                         "-o", "{d}/R"], ("points.csv",)),
    # ---- mixing as-found / as-left ----
    Case("report:as-left-planned", ["report", "{d}/S", "--model", M, "--tolerance-um", "X=10",
                                    "--as-left", "{d}/P", "--tables", "{d}/COMP", "--force",
                                    "-o", "{d}/R"], ("P",)),
    Case("report:as-left-other-machine", ["report", "{d}/S", "--model", M, "--tolerance-um",
                                          "X=10", "--as-left", "{d}/PS", "-o", "{d}/R"],
         ("PS",)),
    Case("report:as-left-same-session", ["report", "{d}/S", "--model", M, "--as-left", "{d}/S",
                                         "-o", "{d}/R"],
         ("--as-left: the as-left session is the as-found session itself",),
         before="accepted: a certificate pairing the session with itself"),
    Case("report:tables-without-as-left", ["report", "{d}/S", "--model", M, "--tables",
                                           "{d}/COMP", "-o", "{d}/R"], ("--tables",)),
    Case("history:as-left-of-unknown", ["history", "add", "{d}/S", "--model", M, "--db",
                                        "{d}/H.sqlite", "--as-left-of", "C999999"],
         ("C999999",)),
    Case("history:as-left-of-itself", ["history", "add", "{d}/S", "--model", M, "--db",
                                       "{d}/H.sqlite", "--as-left-of", "C000002"],
         ("C000002",)),
    # ---- history ----
    Case("history:db-missing", ["history", "list", "--db", "{d}/NOPE.sqlite"], ("NOPE.sqlite",)),
    Case("history:db-garbage", ["history", "list", "--db", "{d}/garbage.bin"], ("garbage.bin",)),
    Case("history:db-folder", ["history", "list", "--db", "{d}/EMPTY"], ("EMPTY",)),
    Case("history:db-other-sqlite", ["history", "list", "--db", "{d}/other.sqlite"],
         ("other.sqlite",), lambda d: sqlite3.connect(d / "other.sqlite").execute(
             "create table t (a)").connection.commit()),
    Case("history:db-scheme-unknown", ["history", "list", "--db", "mysql://x/y"], ("mysql",)),
    Case("history:add-planned", ["history", "add", "{d}/P", "--db", "{d}/H.sqlite"], ("P",)),
    Case("history:add-model-other", ["history", "add", "{d}/OPT", "--model", M, "--db",
                                     "{d}/H.sqlite"],
         ("OPT/session.toml", "the model does not belong to this session")),
    Case("history:add-no-create", ["history", "add", "{d}/S", "--model", M, "--db",
                                   "{d}/NEW.sqlite"], ("NEW.sqlite", "--create")),
    Case("history:show-unknown", ["history", "show", "C999999", "--db", "{d}/H.sqlite"],
         ("C999999",)),
    Case("history:show-units-unknown", ["history", "show", "C000002", "--db", "{d}/H.sqlite",
                                        "--units", "grad"], ("grad",)),
    Case("history:trend-parameter-unknown", ["history", "trend", "VMC-1", "--parameter", "W.A",
                                             "--db", "{d}/H.sqlite"], ("W.A",)),
    Case("history:trend-plot-extension", ["history", "trend", "VMC-1", "--parameter", "X.A",
                                          "--db", "{d}/H.sqlite", "--plot", "{d}/t.txt"],
         ("t.txt",)),
    Case("history:compare-one", ["history", "compare", "C000002", "--db", "{d}/H.sqlite"],
         ("Missing argument 'second'",)),
    Case("history:compare-level", ["history", "compare", "C000002", "C000002", "--db",
                                   "{d}/H.sqlite", "--level", "2"], ("--level",)),
    Case("history:export-qif-over-measured", ["history", "export-qif", "C000002", "--db",
                                              "{d}/H.sqlite", "-o", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv",), before="overwrote it"),
    Case("history:fleet-over-foreign", ["history", "fleet", "--db", "{d}/H.sqlite", "-o",
                                        "{d}/notes.txt"], ("notes.txt",), before="overwrote it"),
    Case("history:add-etalon-garbage", ["history", "add-etalon", "{d}/garbage.bin", "--session",
                                        "{d}/S", "--db", "{d}/H.sqlite"], ("garbage.bin",)),
    Case("history:verify-garbage", ["history", "verify", "--db", "{d}/garbage.bin"],
         ("garbage.bin",)),
    # ---- outputs over measured data or files volcal did not write ----
    Case("identify:output-over-measured-csv", ["identify", "{d}/S", "-o", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv",), before="overwrote it"),
    Case("identify:output-over-session-toml", ["identify", "{d}/S", "-o",
                                               "{d}/S/session.toml"], ("session.toml",),
         before="overwrote it"),
    Case("identify:output-over-foreign", ["identify", "{d}/S", "-o", "{d}/notes.txt"],
         ("notes.txt",), before="overwrote it"),
    Case("predict:output-over-measured-csv", ["predict", M, "--points", "{d}/points.csv", "-o",
                                              "{d}/S/diag-ppp.csv"], ("diag-ppp.csv",),
         before="overwrote it"),
    Case("predict:output-over-points", ["predict", M, "--points", "{d}/points.csv", "-o",
                                        "{d}/points.csv"], ("points.csv",), before="overwrote it"),
    Case("compensate:output-session", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                       "--sign", "error", "-o", "{d}/S"], ("S",)),
    Case("program:output-session", ["program", "{d}/P", "--dialect", "fanuc", "-o", "{d}/S"],
         ("S",)),
    Case("classic-step-diagonal:output-over-measured", ["classic", "step-diagonal", "{d}/S",
                                                        "-o", "{d}/S/diag-ppp.csv"],
         ("diag-ppp.csv",), before="overwrote it"),
    Case("budget:template-over-session-toml", ["budget", "--template", "-o",
                                               "{d}/S/session.toml"], ("session.toml",)),
    Case("budget:template-over-foreign", ["budget", "--template", "-o", "{d}/notes.txt"],
         ("notes.txt",)),
    Case("locate:hal-over-measured", ["locate", "{d}/PS", "--linuxcnc-hal",
                                      "{d}/PS/probe_sphere.csv"], ("probe_sphere.csv",),
         before="overwrote it"),
    Case("locate:json-over-foreign", ["locate", "{d}/PS", "--json", "-o", "{d}/notes.txt"],
         ("notes.txt",), before="overwrote it"),
    Case("locate:tcarr-over-session-toml", ["locate", "{d}/PS", "--siemens-tcarr",
                                            "{d}/PS/session.toml"], ("session.toml",),
         before="overwrote it"),
    Case("history:trend-plot-over-measured", ["history", "trend", "VMC-1", "--parameter", "X.A",
                                              "--db", "{d}/H.sqlite", "--plot",
                                              "{d}/S/linear-x1.csv"], ("linear-x1.csv",)),
    Case("import:new-session-over-foreign", ["import", "{d}/laser.csv", "--map", LASER_MAP,
                                             "--axis", "X", "--id", "lx9", "--session",
                                             "{d}/COMP", "--travel", TRAVEL], ("COMP",)),
    Case("predict:output-over-empty-file", ["predict", M, "--points", "{d}/points.csv", "-o",
                                            "{d}/empty.csv"], (), code=0, writes=("empty.csv",)),
    Case("identify:output-over-empty-file", ["identify", "{d}/S", "-o", "{d}/placeholder.json"],
         (), mutate=lambda d: (d / "placeholder.json").write_text(""), code=0,
         writes=("placeholder.json", "placeholder.npz")),
    # ---- outputs in a folder that does not exist ----
    Case("identify:output-parent-missing", ["identify", "{d}/S", "-o", "{d}/NOPE/M.json"],
         (), code=0, writes=("NOPE",)),
    Case("predict:output-parent-missing", ["predict", M, "--points", "{d}/points.csv", "-o",
                                           "{d}/NOPE/p.csv"], (), code=0, writes=("NOPE",)),
    Case("budget:template-parent-missing", ["budget", "--template", "-o", "{d}/NOPE/b.toml"],
         (), code=0, writes=("NOPE",)),
    Case("locate:hal-parent-missing", ["locate", "{d}/PS", "--linuxcnc-hal",
                                       "{d}/NOPE/trt.hal"], (), code=0, writes=("NOPE",)),
    Case("history:qif-parent-missing", ["history", "export-qif", "C000002", "--db",
                                        "{d}/H.sqlite", "-o", "{d}/NOPE/q.qif"], (),
         code=0, writes=("NOPE",)),
    Case("history:fleet-parent-missing", ["history", "fleet", "--db", "{d}/H.sqlite", "-o",
                                          "{d}/NOPE/f.html"], (), code=0, writes=("NOPE",)),
    # ---- capture ----
    Case("capture:control-unknown", ["capture", "{d}/P", "--control", "magic", "--laser", "sim"],
         ("magic",)),
    Case("capture:laser-unknown", ["capture", "{d}/P", "--control", "sim", "--laser", "magic"],
         ("unknown laser source 'magic'",), before="left capture/ files in the session"),
    Case("capture:laser-file-folder-missing", ["capture", "{d}/P", "--control", "sim", "--laser",
                                               "file:{d}/NOPE/x.txt"],
         ("file:", "NOPE' does not exist"),
         before="ran: every point missed, capture/ files left"),
    Case("capture:laser-file-is-folder", ["capture", "{d}/P", "--control", "sim", "--laser",
                                          "file:{d}/EMPTY"], ("EMPTY is a folder",),
         before="ran: every point missed, capture/ files left"),
    Case("capture:window-negative", ["capture", "{d}/P", "--control", "sim", "--laser", "sim",
                                     "--window-mm", "-1"], ("--window-mm",)),
    Case("capture:poll-zero", ["capture", "{d}/P", "--control", "sim", "--laser", "sim",
                               "--poll-s", "0"], ("--poll-s",)),
    Case("capture:measurement-unknown", ["capture", "{d}/P", "--control", "sim", "--laser",
                                         "sim", "--measurement", "nope"], ("nope",)),
    Case("capture:measured-session", ["capture", "{d}/S", "--control", "sim", "--laser", "sim"],
         ("S/step-ppp.csv", "row 2", "column 'deviation_um'", "a measured reading is never "
          "overwritten"), before="refused, but left capture/ files in the session"),
    Case("capture:port-out-of-range", ["capture", "{d}/P", "--control", "sim", "--laser", "sim",
                                       "--serve", "--port", "99999"], ("127.0.0.1:99999",)),
    Case("capture:programs-missing", ["capture", "{d}/P", "--control", "sim", "--laser", "sim",
                                      "--programs", "{d}/NOPE"], ("NOPE",)),
    Case("capture:output-foreign", ["capture", "{d}/P", "--control", "sim", "--laser", "sim",
                                    "-o", "{d}/COMP"], ("COMP",)),
    # ---- import ----
    Case("import:bom", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X", "--id",
                        "lx9", "--session", "{d}/S"], (), edit("laser.csv", lambda t: "\ufeff" + t),
         code=0, writes=("S/lx9.csv", "S/session.toml")),
    Case("import:european", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                             "--id", "lx9", "--session", "{d}/S"], (), european("laser.csv"),
         code=0, writes=("S/lx9.csv", "S/session.toml")),
    Case("import:axis-lowercase", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "x",
                                   "--id", "lx9", "--session", "{d}/S"], (), code=0,
         writes=("S/lx9.csv", "S/session.toml")),
    Case("import:dwell-negative", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                                   "--id", "lx9", "--session", "{d}/S", "--dwell-s", "-1"],
         ("--dwell-s -1.0: expected a finite number > 0 [s]",),
         before="accepted (the dwell is read for a .rtx only)"),
    Case("import:sign-unknown", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                                 "--id", "lx9", "--session", "{d}/S", "--sign", "plus"],
         ("--sign 'plus'",), before="accepted (the sign is read for optics only)"),
    Case("import:rtx-garbage", ["import", "{d}/x.rtx", "--axis", "X", "--id", "lx9",
                                "--session", "{d}/S"], ("x.rtx",),
         lambda d: shutil.copy(d / "garbage.bin", d / "x.rtx")),
    Case("import:into-ml-measurement-of-other-kind", ["import", "{d}/laser.csv", "--map",
                                                      LASER_MAP, "--session", "{d}/ML",
                                                      "--measurement", "trk-s1-t1"],
         ("trk-s1-t1",)),
    Case("import:unsorted-targets", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis",
                                     "X", "--id", "lx9", "--session", "{d}/S"], (),
         swap_lines("laser.csv", 2, 3), code=0, writes=("S/lx9.csv", "S/session.toml")),
    Case("import:duplicated-row", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                                   "--id", "lx9", "--session", "{d}/S"],
         ("laser.csv", "row 4", "appears twice"),
         lines_of("laser.csv", lambda ls: ls[:3] + ls[2:])),
    Case("import:session-of-other-travel", ["import", "{d}/laser.csv", "--map", LASER_MAP,
                                            "--axis", "X", "--id", "lx9", "--session", "{d}/S",
                                            "--line-mm", "0,500,0"], ("--line-mm",)),
    # ---- env ----
    Case("env-drift:missing", ["env", "drift", "{d}/NOPE.csv"], ("NOPE.csv",)),
    Case("env-drift:limit-negative", ["env", "drift", "{d}/S/linear-x1.csv", "--limit-um", "-1"],
         ("--limit-um",)),
    Case("env-drift:folder", ["env", "drift", "{d}/S"], ("S",)),
    Case("env-drift:text", ["env", "drift", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 3", "deviation_um"),
         set_cell("S/linear-x1.csv", 3, "deviation_um", "abc")),
    # ---- evaluate ----
    Case("evaluate-optics:tolerance-bad", ["evaluate", "optics", "{d}/OPT", "--tolerance-um",
                                           "X.straightness_um=-4"], ("--tolerance-um",)),
    Case("evaluate-optics:tolerance-unknown", ["evaluate", "optics", "{d}/OPT",
                                               "--tolerance-um", "X.flatness_um=4"],
         ("flatness",)),
    Case("evaluate-volumetric:tool-offset-nan", ["evaluate", "volumetric", "{d}/ERRORS.csv",
                                                 "--tool-offset", "0,nan,0"], ("--tool-offset",)),
    Case("evaluate-iso230-2:rotary-file", ["evaluate", "iso230-2", "{d}/ROT/rotary-c.csv"],
         (), code=0),
    Case("evaluate-iso230-2:optics-file", ["evaluate", "iso230-2", "{d}/OPT/ang-xb.csv"],
         ("ang-xb.csv",)),
    Case("evaluate-session:model-other-travel", ["evaluate", "session", "{d}/S",
                                                 "--tolerance-um", "X=10", "--model",
                                                 "{d}/PS/truth/machine.csv"],
         ("machine.csv", "the error table is not of this session's machine", "--force"),
         before="accepted: evaluated another machine's table"),
    Case("predict:session-other", ["predict", M, "--points", "{d}/points.csv", "--session",
                                   "{d}/OPT", "-o", "{d}/p.csv"], ("MODEL.json",)),
    Case("predict:points-bom", ["predict", M, "--points", "{d}/points.csv", "-o", "{d}/p.csv"],
         (), edit("points.csv", lambda t: "\ufeff" + t), code=0, writes=("p.csv",)),
    # ---- second batch: spelling, encodings, typed keys ----
    Case("plan:chain-lowercase", ["plan", "--chain", "xyfz", "-o", "{d}/N"], (), code=0,
         writes=("N",)),
    Case("plan:travel-spaces", ["plan", "--travel", "0:400, 0:300, 0:200", "-o", "{d}/N"], (),
         code=0, writes=("N",)),
    Case("plan:tests-unknown-axis", ["plan", "--tests", "linear:w", "-o", "{d}/N"],
         ("linear:w",)),
    Case("plan:tests-face-plane-bad", ["plan", "--tests", "face-diagonal:xx", "-o", "{d}/N"],
         ("face-diagonal:xx",)),
    Case("plan:output-over-foreign-file", ["plan", "-o", "{d}/notes.txt"], ("notes.txt",)),
    Case("program:dialect-uppercase", ["program", "{d}/P", "--dialect", "FANUC", "-o",
                                       "{d}/PROG"], (), code=0, writes=("PROG",)),
    Case("program:safe-z-nan", ["program", "{d}/P", "--dialect", "fanuc", "--safe-z-mm", "nan",
                                "-o", "{d}/PROG"], ("--safe-z-mm",)),
    Case("program:feed-huge", ["program", "{d}/P", "--dialect", "fanuc", "--feed", "1e6",
                               "-o", "{d}/PROG"], ("feed",)),
    Case("simulate:seed-text", ["simulate", "{d}/P", "--seed", "one"], ("--seed",)),
    Case("simulate:planned-folder-empty", ["simulate", "{d}/EMPTY"], ("EMPTY", "session.toml")),
    # written until session 19 (the points 0 and 5000 mm, the second holding the value at
    # 400 mm): refused now, naming the option and the axis' travel
    Case("compensate:spacing-over-travel", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                            "--sign", "error", "--spacing", "5000", "-o",
                                            "{d}/C2"], ("--spacing 5000", "travel of X")),
    Case("compensate:session-planned", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                        "--sign", "error", "--session", "{d}/P", "-o",
                                        "{d}/C2"], ("P", "deviation_um")),
    Case("compensate:model-garbage", ["compensate", "{d}/garbage.bin", "--format", "csv",
                                      "--sign", "error", "-o", "{d}/C2"], ("garbage.bin",)),
    Case("report:history-garbage", ["report", "{d}/S", "--model", M, "--history",
                                    "{d}/garbage.bin", "-o", "{d}/R"], ("garbage.bin",)),
    Case("report:model-of-planned", ["report", "{d}/P", "--model", M, "-o", "{d}/R"],
         ("P", "deviation_um")),
    Case("history:add-supersedes-unknown", ["history", "add", "{d}/S", "--model", M, "--db",
                                            "{d}/H.sqlite", "--supersedes", "C999999"],
         ("C999999",)),
    Case("history:add-private-key-missing", ["history", "add", "{d}/S", "--model", M, "--db",
                                             "{d}/H.sqlite", "--private-key", "{d}/NOPE.pem"],
         ("NOPE.pem",)),
    Case("history:add-empty-folder", ["history", "add", "{d}/EMPTY", "--db", "{d}/H.sqlite"],
         ("EMPTY", "session.toml")),
    Case("history:interval-zero", ["history", "interval", "VMC-1", "0", "--db",
                                   "{d}/H.sqlite"], ("days",)),
    Case("history:interval-unknown-machine", ["history", "interval", "VMC-9", "365", "--db",
                                              "{d}/H.sqlite"], ("VMC-9",)),
    Case("history:trend-unknown-machine", ["history", "trend", "VMC-9", "--parameter", "X.A",
                                           "--db", "{d}/H.sqlite"], ("VMC-9",)),
    Case("history:due-db-missing", ["history", "due", "--db", "{d}/NOPE.sqlite"],
         ("NOPE.sqlite",)),
    Case("history:list-certificate-unknown", ["history", "list", "--certificate", "NOPE-1",
                                              "--db", "{d}/H.sqlite"],
         ("no calibration of certificate 'NOPE-1'",), code=1),
    Case("advise:top-negative", ["advise", "{d}/PS", "--top", "-1"], ("--top",)),
    Case("advise:folder-is-file", ["advise", "{d}/points.csv"], ("points.csv",)),
    Case("env:pressure-absurd", ["env", "refractive-index", "--temperature-c", "20",
                                 "--pressure-pa", "1e9", "--humidity-pct", "50"],
         ("pressure",)),
    Case("evaluate-volumetric:n-float", ["evaluate", "volumetric", "{d}/ERRORS.csv", "--n",
                                         "2.5"], ("--n",)),
    Case("import:excel-file", ["import", "{d}/x.xlsx", "--map", LASER_MAP, "--axis", "X",
                               "--id", "lx9", "--session", "{d}/S"], ("x.xlsx",),
         put("x.xlsx", b"PK\x03\x04" + bytes(range(256)) * 4)),
    Case("import:tab-separated", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                                  "--id", "lx9", "--session", "{d}/S"], (),
         edit("laser.csv", lambda t: t.replace(",", "\t")), code=0,
         writes=("S/lx9.csv", "S/session.toml")),
    Case("import:rotary-measurement-from-linear-csv", ["import", "{d}/laser.csv", "--map",
                                                       LASER_MAP, "--session", "{d}/ROT",
                                                       "--measurement", "rotary-c"],
         ("ROT/session.toml", "measurement 'rotary-c' has readings; give --replace")),
    Case("evaluate:csv-utf16", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv",), lambda d: (d / "S/linear-x1.csv").write_bytes(
             (d / "S/linear-x1.csv").read_text().encode("utf-16"))),
    Case("evaluate:csv-two-exports-concatenated", ["evaluate", "iso230-2",
                                                   "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row"),
         lines_of("S/linear-x1.csv", lambda ls: ls + ls)),
    Case("evaluate:csv-excel-na", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 4", "deviation_um"),
         set_cell("S/linear-x1.csv", 4, "deviation_um", "#N/A")),
    Case("evaluate:csv-quoted-number", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"], (),
         set_cell("S/linear-x1.csv", 4, "deviation_um", '"4.718744"'), code=0),
    Case("evaluate:csv-thousands-separator", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv"],
         ("linear-x1.csv", "row 3", "x_mm"), set_cell("S/linear-x1.csv", 3, "x_mm",
                                                      '"1,143.903"')),
    Case("identify:toml-travel-z-missing", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "travel_mm"), sub("S/session.toml", "z = [0.0, 200.0]\n", "")),
    Case("identify:toml-machine-chain-typo", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "chain"), sub("S/session.toml", 'chain = "XYFZ"', 'chian = "XYFZ"')),
    Case("identify:toml-tool-offset-typo", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "measurements[0].tool_offset_mm", "unknown key 'tool_ofset_mm': did "
          "you mean 'tool_offset_mm'?"),
         sub("S/session.toml", "tool_offset_mm = [0.0, 0.0, 0.0]",
             "tool_ofset_mm = [0.0, 0.0, 100.0]"),
         before="accepted: the key kept as a note, the tool offset taken as 0"),
    Case("identify:toml-kind-typo-key", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "measurements[0].kind", "unknown key 'knd': did you mean 'kind'?"),
         sub("S/session.toml", 'kind = "step_diagonal"',
                                      'knd = "step_diagonal"'),
         before="refused as 'unknown kind None' naming measurements[0].kind"),
    Case("budget:value-text", ["budget", "{d}/B.toml"], ("B.toml", "u_wavelength_ppm"),
         chain_of(lambda d: _ok(volcal("budget", "--template", "-o", d / "B.toml")),
                  sub("B.toml", "u_wavelength_ppm = 0.029", 'u_wavelength_ppm = "0.029"'))),
    Case("budget:value-negative", ["budget", "{d}/B.toml"], ("B.toml", "u_wavelength_ppm"),
         chain_of(lambda d: _ok(volcal("budget", "--template", "-o", d / "B.toml")),
                  sub("B.toml", "u_wavelength_ppm = 0.029", "u_wavelength_ppm = -0.029"))),
    Case("classic-abbe:bom-files", ["classic", "abbe", "{d}/S/linear-x1.csv",
                                    "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv", "--axis", "X",
                                    "--chain", "XYFZ"], (),
         chain_of(*(edit(f"S/linear-x{i}.csv", lambda t: "\ufeff" + t) for i in (1, 2, 3))),
         code=0),
    Case("classic-abbe:output-over-input", ["classic", "abbe", "{d}/S/linear-x1.csv",
                                            "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                                            "--axis", "X", "--chain", "XYFZ", "-o",
                                            "{d}/S/linear-x3.csv"], ("linear-x3.csv",),
         before="overwrote it"),
    # ---- wrong axis names, spelling ----
    Case("report:tolerance-axis-lowercase", ["evaluate", "session", "{d}/S", "--tolerance-um",
                                             "x=10"], (), code=0),
    Case("classic-abbe:axis-lowercase", ["classic", "abbe", "{d}/S/linear-x1.csv",
                                         "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv", "--axis",
                                         "x", "--chain", "XYFZ"], (), code=0),
    Case("compensate:format-uppercase", ["compensate", "{d}/ERRORS.csv", "--format", "CSV",
                                         "--sign", "error", "-o", "{d}/C2"], (), code=0,
         writes=("C2",)),
    Case("evaluate-optics:tolerance-axis-unknown", ["evaluate", "optics", "{d}/OPT",
                                                    "--tolerance-um", "W.straightness_um=4"],
         ("W.straightness_um",)),
    Case("import:axis-rotary-unknown", ["import", "{d}/laser.csv", "--map", LASER_MAP,
                                        "--axis", "D", "--id", "lx9", "--session", "{d}/S"],
         ("--axis",)),
    Case("identify:toml-measurements-empty-list", ["identify", "{d}/S", "-o", "{d}/M2.json"],
         ("session.toml", "measurements"),
         edit("S/session.toml", lambda t: t.split("[[measurements]]")[0].replace(
             "[machine]", "measurements = []\n\n[machine]", 1))),
    Case("compensate:model-of-other-session", ["compensate", M, "--format", "csv", "--sign",
                                               "error", "--session", "{d}/OPT", "-o", "{d}/C2"],
         ("the model does not belong to this session", "--force")),
    # ---- an output that exists and is volcal's own: replaced, as documented ----
    Case("compensate:output-own-folder", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                          "--sign", "error", "-o", "{d}/COMP"], (), code=0,
         writes=("COMP",)),
    Case("identify:output-own-model", ["identify", "{d}/S", "-o", M], (), code=0,
         writes=("MODEL.json", "MODEL.npz")),
    Case("predict:output-own-csv", ["predict", M, "--points", "{d}/points.csv", "-o",
                                    "{d}/p.csv"], (),
         lambda d: _ok(volcal("predict", d / "MODEL.json", "--points", d / "points.csv", "-o",
                              d / "p.csv")), code=0, writes=("p.csv",)),
    # ---- the same command again over its own earlier output: replaced ----
    *[Case(f"rerun:{name}", args, (), lambda d, a=args: _ok(volcal(
        *[x.format(d=d) for x in a], cwd=d)), code=0, writes=writes)
      for name, args, writes in [
        ("history-export-qif", ["history", "export-qif", "C000002", "--db", "{d}/H.sqlite",
                                "-o", "{d}/q.qif"], ("q.qif",)),
        ("history-export-etalon", ["history", "export-etalon", "C000002", "--db",
                                   "{d}/H.sqlite", "-o", "{d}/e.txt"], ("e.txt",)),
        ("history-fleet", ["history", "fleet", "--db", "{d}/H.sqlite", "-o", "{d}/f.html"],
         ("f.html",)),
        ("locate-exports", ["locate", "{d}/PS", "--json", "-o", "{d}/loc.json",
                            "--linuxcnc-hal", "{d}/trt.hal", "--siemens-tcarr", "{d}/t.mpf",
                            "--isg-kinematics", "{d}/isg.csv"],
         ("loc.json", "trt.hal", "t.mpf", "isg.csv")),
        ("classic-step-diagonal", ["classic", "step-diagonal", "{d}/S", "-o", "{d}/T.csv"],
         ("T.csv", "T.toml")),
        ("classic-abbe", ["classic", "abbe", "{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                          "{d}/S/linear-x3.csv", "--axis", "X", "--chain", "XYFZ", "-o",
                          "{d}/abbe.csv"], ("abbe.csv",)),
      ]],
    Case("predict:points-duplicate", ["predict", M, "--points", "{d}/points.csv", "-o",
                                      "{d}/p.csv"], (),
         lines_of("points.csv", lambda ls: ls + ls[1:2]),
         code=0, writes=("p.csv",)),
]


def _ids(cases: list[Case]) -> list[str]:
    seen: set[str] = set()
    for c in cases:
        assert c.id not in seen, c.id
        seen.add(c.id)
    return [c.id for c in cases]


@pytest.mark.parametrize("case", CASES, ids=_ids(CASES))
def test_user_mistake(case: Case, base: Path, tmp_path: Path) -> None:
    d = tmp_path / "w"
    shutil.copytree(base, d)
    if case.mutate is not None:
        case.mutate(d)
    before = touch_snapshot(d)
    r = volcal(*[a.format(d=d) for a in case.args], cwd=d)
    out = r.stdout + r.stderr
    assert "Traceback" not in out, out
    assert r.returncode == case.code, \
        f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"
    msg = " ".join(r.stderr.split())
    for e in case.expect:
        assert e.format(d=d) in msg, f"{e!r} not in the message:\n{r.stderr}"
    after = touch_snapshot(d)
    changed = {k for k in set(before) | set(after) if before.get(k) != after.get(k)}
    stray = {k for k in changed if not any(k == w or k.startswith(w + "/") for w in case.writes)}
    assert not stray, f"changed: {sorted(stray)}\n{r.stderr}"


# ---------------------------------------------------------------------------------------------
# Ctrl-C midway: the n-th atomic replacement is interrupted
# ---------------------------------------------------------------------------------------------


@dataclass
class Interrupt:
    """Ctrl-C (``KeyboardInterrupt``) at the ``nth`` ``os.replace`` of a command: exit code
    130, ``aborted``, and the folder as it was (no temporary left, nothing half written)."""

    id: str
    args: list[str]
    nth: int = 1
    before: str = "ok"


INTERRUPTS: list[Interrupt] = [
    Interrupt("plan", ["plan", "--travel", TRAVEL, "--steps", "3", "-o", "{d}/N"]),
    Interrupt("simulate", ["simulate", "{d}/P", "--seed", "2"]),
    Interrupt("identify-json", ["identify", "{d}/S", "-o", "{d}/M2.json"]),
    Interrupt("identify-npz", ["identify", "{d}/S", "-o", "{d}/M2.json"], nth=2,
              before="left M2.npz without its JSON"),
    Interrupt("compensate", ["compensate", "{d}/ERRORS.csv", "--format", "csv", "--sign",
                             "error", "-o", "{d}/C2"]),
    Interrupt("import-csv", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                             "--id", "lx9", "--session", "{d}/S"]),
    Interrupt("import-toml", ["import", "{d}/laser.csv", "--map", LASER_MAP, "--axis", "X",
                              "--id", "lx9", "--session", "{d}/S"], nth=2,
              before="left lx9.csv in the session, not in its session.toml"),
    Interrupt("predict", ["predict", M, "--points", "{d}/points.csv", "-o", "{d}/p.csv"]),
    Interrupt("locate-hal", ["locate", "{d}/PS", "--linuxcnc-hal", "{d}/trt.hal"]),
]


@pytest.mark.parametrize("case", INTERRUPTS, ids=[c.id for c in INTERRUPTS])
def test_ctrl_c_midway(case: Interrupt, base: Path, tmp_path: Path,
                       monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    d = tmp_path / "w"
    shutil.copytree(base, d)
    before = touch_snapshot(d)
    real, calls = os.replace, [0]

    def replace(src: object, dst: object) -> None:
        calls[0] += 1
        if calls[0] == case.nth:
            raise KeyboardInterrupt
        real(src, dst)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "replace", replace)
    r = volcal(*[a.format(d=d) for a in case.args], cwd=d)
    monkeypatch.undo()
    assert calls[0] >= case.nth, "the command did not reach the interrupted write"
    assert "Traceback" not in r.stdout + r.stderr, r.stderr
    assert r.returncode == 130, r.stdout + r.stderr
    after = touch_snapshot(d)
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert not changed, f"left behind: {changed}"
