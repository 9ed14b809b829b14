"""Every CLI command against the mistakes users make: no traceback, ever.

Each case copies one planned session, one measured session and the files derived from
it (model, error table, compensation tables, a laser export, a points file) into a fresh
folder, spoils one thing, runs ``volcal`` in a subprocess as a user does, and asserts:

- exit code 2 (a :class:`~volcal.errors.VolcalInputError`, or a usage error of typer);
- no ``Traceback`` anywhere in the output;
- a message naming the file (and the row and column when the problem is in a row, the
  option when the problem is an option);
- not a byte of the folder created, changed or removed (outputs are written atomically,
  and only after every input has been checked).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
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
from timing import scaled_timeout

RUN = [sys.executable, "-c", "from volcal.cli import main; main()"]
TRAVEL = "0:400,0:300,0:200"
SUBPROCESS = os.environ.get("VOLCAL_TEST_SUBPROCESS") == "1"
"""Set VOLCAL_TEST_SUBPROCESS=1 to run every case in its own process, as a user does; by
default the cases run ``main()`` in-process (same entry point, same exit codes, same
output streams) so that the ~300 cases take seconds instead of minutes."""


def _in_process(args: list[str], cwd: Path | None) -> subprocess.CompletedProcess[str]:
    import contextlib
    import io
    import traceback

    from volcal.cli import main

    out, err = io.StringIO(), io.StringIO()
    code = 0
    old_argv, old_cwd = sys.argv, os.getcwd()
    sys.argv = ["volcal", *args]
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
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
    return subprocess.CompletedProcess(["volcal", *args], code, out.getvalue(), err.getvalue())


def volcal(*args: object, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the command line as a user does (in-process unless VOLCAL_TEST_SUBPROCESS=1)."""
    if not SUBPROCESS:
        os.environ.setdefault("COLUMNS", "200")
        return _in_process([str(a) for a in args], cwd)
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "TERM": "dumb"}
    return subprocess.run([*RUN, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=scaled_timeout(300), env=env)


# ---------------------------------------------------------------------------------------------
# the inputs every case starts from
# ---------------------------------------------------------------------------------------------

LASER_EXPORT = "Target (mm),Run,Dir,Error (um)\n" + "".join(
    f"{t},{r},{d},{e}\n" for r in (1, 2) for t, d, e in
    [(0, "fwd", 0.0), (100, "fwd", 1.2), (200, "fwd", 2.5),
     (200, "bwd", 3.1), (100, "bwd", 1.9), (0, "bwd", 0.4)])
LASER_MAP = "target=Target (mm),run=Run,direction=Dir,deviation=Error (um)"
WIDE_EXPORT = ("Target (mm),Run 1 (um),Run 2 (um)\n0,0.0,0.1\n100,1.2,1.3\n200,2.5,2.4\n"
               "200,3.1,3.0\n100,1.9,1.8\n0,0.4,0.5\n")
WIDE_MAP = "target=Target (mm),deviation=Run*"
TRUNCATED_TOML = 'format = "volcal-errors/1"\nname = "virt'
POINTS = "x_mm,y_mm,z_mm\n0,0,0\n100,50,20\n400,300,200\n"


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Build once: ``P`` planned, ``S`` measured, ``L`` and ``D`` (its linear tests, its
    diagonals: :func:`_extra_sessions`), ``MODEL.json``, ``ERRORS.csv``, ``COMP``."""
    d = tmp_path_factory.mktemp("base")
    r = volcal("plan", "--travel", TRAVEL, "--steps", "3", "--runs", "2", "-o", d / "P")
    assert r.returncode == 0, r.stderr
    shutil.copytree(d / "P", d / "S")
    r = volcal("simulate", d / "S", "--seed", "1")
    assert r.returncode == 0, r.stderr
    shutil.copy(d / "S" / "truth" / "machine.csv", d / "ERRORS.csv")
    shutil.copy(d / "S" / "truth" / "machine.toml", d / "ERRORS.toml")
    r = volcal("identify", d / "S", "-o", d / "MODEL.json")
    assert r.returncode == 0, r.stderr
    r = volcal("compensate", d / "ERRORS.csv", "--format", "csv", "--sign", "error",
               "-o", d / "COMP")
    assert r.returncode == 0, r.stderr
    (d / "laser.csv").write_text(LASER_EXPORT)
    (d / "wide.csv").write_text(WIDE_EXPORT)
    _planned_exports(d)
    (d / "points.csv").write_text(POINTS)
    (d / "EMPTY").mkdir()
    (d / "empty.csv").write_text("")
    (d / "garbage.bin").write_bytes(bytes(range(256)) * 8)
    _extra_sessions(d)
    return d


def _planned_exports(d: Path) -> None:
    """``diag.csv``, ``steps.csv``: the simulated diag-ppp and step-ppp of ``S`` as a laser
    exports them (distance along the diagonal; one row per step)."""
    import numpy as np

    from volcal.importer.planned import planned_targets
    from volcal.session.format import read_session

    s = read_session(d / "S")
    m = s.get("diag-ppp")
    (d / "diag.csv").write_text("Pos (mm),Dev (um)\n" + "".join(
        f"{t:.4f},{v:.6f}\n" for t, v in zip(planned_targets(m), m.deviation, strict=True)))
    m = s.get("step-ppp")
    t, v = planned_targets(m), m.deviation
    rows = [f"0,{v[0]:.6f},,"] + [f"{t[3 * k + 3]:.4f}," + ",".join(
        f"{x:.6f}" for x in v[3 * k + 1: 3 * k + 4]) for k in range((m.n - 1) // 3)]
    (d / "steps.csv").write_text("Pos (mm),dX (um),dY (um),dZ (um)\n" + "\n".join(rows) + "\n")
    assert np.isfinite(v).all()


# ---------------------------------------------------------------------------------------------
# mutations: how a case spoils its copy of the inputs
# ---------------------------------------------------------------------------------------------

def drop_column(rel: str, col: str) -> Mutation:
    """Remove a column from a CSV."""
    def fn(text: str) -> str:
        rows = [ln.split(",") for ln in text.splitlines()]
        j = rows[0].index(col)
        return "\n".join(",".join(r[:j] + r[j + 1:]) for r in rows) + "\n"
    return edit(rel, fn)


def keep_lines(rel: str, n: int) -> Mutation:
    """Keep the first ``n`` lines of a file."""
    return edit(rel, lambda t: "\n".join(t.splitlines()[:n]) + "\n")


def duplicate_line(rel: str, line: int) -> Mutation:
    """Repeat line ``line`` (1-based) right after itself."""
    def fn(text: str) -> str:
        lines = text.splitlines()
        lines.insert(line, lines[line - 1])
        return "\n".join(lines) + "\n"
    return edit(rel, fn)


def semicolons(rel: str) -> Mutation:
    """Re-delimit a CSV with semicolons."""
    return edit(rel, lambda t: t.replace(",", ";"))


def truncate(rel: str, fraction: float = 0.5) -> Mutation:
    """Cut a file in the middle (a copy that stopped half way)."""
    def f(d: Path) -> None:
        p = d / rel
        b = p.read_bytes()
        p.write_bytes(b[: int(len(b) * fraction)])
    return f


def add_column(rel: str, name: str, value: str) -> Mutation:
    """Append a column ``name`` holding ``value`` in every row."""
    def fn(text: str) -> str:
        lines = text.splitlines()
        return "\n".join([f"{lines[0]},{name}", *(f"{ln},{value}" for ln in lines[1:])]) + "\n"
    return edit(rel, fn)


def missed_where(rel: str, col: str, value: str) -> Mutation:
    """Mark ``missed`` every deviation of the rows whose ``col`` equals ``value``."""
    def fn(text: str) -> str:
        rows = [ln.split(",") for ln in text.splitlines()]
        j, k = rows[0].index("deviation_um"), rows[0].index(col)
        for r in rows[1:]:
            if r[k] == value:
                r[j] = "missed"
        return "\n".join(",".join(r) for r in rows) + "\n"
    return edit(rel, fn)


def clear_deviations(rel: str) -> Mutation:
    """Empty the deviation column (a planned, unmeasured measurement)."""
    def fn(text: str) -> str:
        rows = [ln.split(",") for ln in text.splitlines()]
        j = rows[0].index("deviation_um")
        for r in rows[1:]:
            r[j] = ""
        return "\n".join(",".join(r) for r in rows) + "\n"
    return edit(rel, fn)


# ---------------------------------------------------------------------------------------------
# the cases
# ---------------------------------------------------------------------------------------------


@dataclass
class Case:
    """One bad input: the command line, how the inputs are spoiled, what the message names."""

    id: str
    args: list[str]
    expect: tuple[str, ...] = ()
    mutate: Mutation | None = None
    marks: list[pytest.MarkDecorator] = field(default_factory=list)


SHORT = ("missing-session", "file-not-folder", "truncated-toml", "text-in-number",
         "planned-not-measured", "1e308", "99999-mm", "unknown-target")
"""Session mistakes tried on every command; the full list runs on simulate and identify
(one reader, ``read_session``, serves all commands)."""


def sessions_cases(cmd: list[str], out: list[str] | None = None,
                   needs_measured: bool = True, full: bool = False) -> list[Case]:
    """The session mistakes every command that reads ``SESSION`` must catch."""
    name = "-".join(cmd)
    o = out or []
    cases = [
        Case(f"{name}:missing-session", [*cmd, "{d}/NOPE", *o], ("NOPE",)),
        Case(f"{name}:file-not-folder", [*cmd, "{d}/points.csv", *o], ("points.csv",)),
        Case(f"{name}:empty-folder", [*cmd, "{d}/EMPTY", *o], ("EMPTY", "session.toml")),
        Case(f"{name}:truncated-toml", [*cmd, "{d}/S", *o], ("session.toml",),
             truncate("S/session.toml", 0.37)),
        Case(f"{name}:binary-toml", [*cmd, "{d}/S", *o], ("session.toml",),
             put("S/session.toml", bytes(range(256)))),
        Case(f"{name}:bad-chain", [*cmd, "{d}/S", *o], ("session.toml", "machine.chain"),
             edit("S/session.toml", lambda t: t.replace('chain = "XYFZ"', 'chain = "XYZ"'))),
        Case(f"{name}:missing-csv", [*cmd, "{d}/S", *o], ("session.toml", "diag-ppp.csv"),
             remove("S/diag-ppp.csv")),
        Case(f"{name}:text-in-number", [*cmd, "{d}/S", *o],
             ("diag-npp.csv", "row 3", "column 'y_mm'"), set_cell("S/diag-npp.csv", 3, "y_mm",
                                                                 "ten")),
        Case(f"{name}:nan", [*cmd, "{d}/S", *o], ("diag-npp.csv", "row 4", "column 'deviation_um'"),
             set_cell("S/diag-npp.csv", 4, "deviation_um", "nan")),
        Case(f"{name}:inf", [*cmd, "{d}/S", *o], ("step-ppp.csv", "row 2", "column 'x_mm'"),
             set_cell("S/step-ppp.csv", 2, "x_mm", "-inf")),
        Case(f"{name}:missing-column", [*cmd, "{d}/S", *o],
             ("linear-y2.csv", "row 1", "z_mm"), drop_column("S/linear-y2.csv", "z_mm")),
        Case(f"{name}:wrong-unit", [*cmd, "{d}/S", *o], ("linear-z1.csv", "row 1", "x_in"),
             rename_column("S/linear-z1.csv", "x_mm", "x_in")),
        Case(f"{name}:one-row", [*cmd, "{d}/S", *o], ("diag-ppn.csv",),
             keep_lines("S/diag-ppn.csv", 2)),
        Case(f"{name}:typo-column", [*cmd, "{d}/S", *o],
             ("diag-pnp.csv", "row 1", "column 'deviation_um'",
              "missing required column 'deviation_um' (closest: 'deviaton_um')"),
             rename_column("S/diag-pnp.csv", "deviation_um", "deviaton_um")),
        Case(f"{name}:binary-csv", [*cmd, "{d}/S", *o], ("linear-x3.csv",),
             put("S/linear-x3.csv", bytes(range(256)) * 4)),
        Case(f"{name}:ragged-row", [*cmd, "{d}/S", *o], ("diag-ppp.csv", "row 3"),
             edit("S/diag-ppp.csv", lambda t: t.replace("\n", ",1\n", 3).replace(",1\n", "\n", 2))),
        Case(f"{name}:1e308", [*cmd, "{d}/S", *o],
             ("diag-npp.csv", "row 3", "column 'deviation_um'", "absurd value 1e308"),
             set_cell("S/diag-npp.csv", 3, "deviation_um", "1e308")),
        Case(f"{name}:20-mm-deviation", [*cmd, "{d}/S", *o],
             ("linear-x1.csv", "row 4", "column 'deviation_um'", "|value| > 10000 um"),
             set_cell("S/linear-x1.csv", 4, "deviation_um", "-20000")),
        Case(f"{name}:99999-mm", [*cmd, "{d}/S", *o],
             ("step-ppp.csv", "row 4", "column 'x_mm'", "outside the travel 0..400 mm"),
             set_cell("S/step-ppp.csv", 4, "x_mm", "99999")),
        Case(f"{name}:unknown-target", [*cmd, "{d}/S", *o],
             ("session.toml", "measurements[0].target", "unknown target 'flat-mirror'",
              "flat_mirror, retroreflector, retroreflector_mirror"),
             edit("S/session.toml", lambda t: t.replace('target = "flat_mirror"',
                                                        'target = "flat-mirror"', 1))),
        Case(f"{name}:unknown-kind", [*cmd, "{d}/S", *o],
             ("session.toml", "measurements[0].kind", "unknown kind 'step-diagonal'"),
             edit("S/session.toml", lambda t: t.replace('kind = "step_diagonal"',
                                                        'kind = "step-diagonal"', 1))),
        Case(f"{name}:off-the-line", [*cmd, "{d}/S", *o],
             ("linear-y2.csv", "row 4", "column 'z_mm'", "not on the line"),
             set_cell("S/linear-y2.csv", 4, "z_mm", "7")),
        Case(f"{name}:off-the-diagonal", [*cmd, "{d}/S", *o],
             ("diag-pnp.csv", "row 3", "column 'x_mm'", "not on the diagonal"),
             set_cell("S/diag-pnp.csv", 3, "x_mm", "20")),
        Case(f"{name}:off-the-steps", [*cmd, "{d}/S", *o],
             ("step-npp.csv", "row 6", "column 'y_mm'", "stepping pattern"),
             set_cell("S/step-npp.csv", 6, "y_mm", "150")),
        Case(f"{name}:step-row-missing", [*cmd, "{d}/S", *o],
             ("step-ppn.csv", "1 + 3N rows"), keep_lines("S/step-ppn.csv", 10)),
        Case(f"{name}:missed-first-row", [*cmd, "{d}/S", *o],
             ("diag-ppn.csv", "row 2", "column 'deviation_um'", "cannot be a missed capture"),
             set_cell("S/diag-ppn.csv", 2, "deviation_um", "missed")),
        Case(f"{name}:bad-status", [*cmd, "{d}/S", *o],
             ("diag-ppn.csv", "row 2", "column 'status'", "expected one of 'ok', 'missed'"),
             add_column("S/diag-ppn.csv", "status", "skipped")),
    ]
    if needs_measured:
        cases += [
            Case(f"{name}:planned-not-measured", [*cmd, "{d}/P", *o],
                 ("P", "deviation_um", "no readings yet: the deviation_um column of all 17 "
                  "measurements is empty")),
            Case(f"{name}:one-empty-deviation", [*cmd, "{d}/S", *o],
                 ("step-pnp.csv", "row 3", "deviation_um", "missing deviation: write the "
                  "reading, or 'missed' for a missed capture"),
                 set_cell("S/step-pnp.csv", 3, "deviation_um", "")),
        ]
    return cases if full else [c for c in cases if c.id.split(":")[1] in SHORT]


CASES: list[Case] = [
    # ---- plan ----
    Case("plan:travel-two-axes", ["plan", "--travel", "0:800,0:600", "-o", "{d}/N"], ("--travel",)),
    Case("plan:travel-reversed", ["plan", "--travel", "0:800,600:0,0:500", "-o", "{d}/N"],
         ("--travel",)),
    Case("plan:travel-text", ["plan", "--travel", "0:800,a:b,0:500", "-o", "{d}/N"], ("--travel",)),
    Case("plan:travel-nan", ["plan", "--travel", "0:nan,0:600,0:500", "-o", "{d}/N"],
         ("--travel",)),
    Case("plan:travel-no-colon", ["plan", "--travel", "800,600,500", "-o", "{d}/N"],
         ("--travel", "e.g. 0:800,0:600,0:500")),
    Case("plan:chain-no-frame", ["plan", "--chain", "XYZ", "-o", "{d}/N"], ("XYZ",)),
    Case("plan:chain-repeated-axis", ["plan", "--chain", "XXFZ", "-o", "{d}/N"], ("XXFZ",)),
    Case("plan:chain-letters", ["plan", "--chain", "ABCD", "-o", "{d}/N"], ("ABCD",)),
    Case("plan:steps-zero", ["plan", "--steps", "0", "-o", "{d}/N"], ("--steps 0: expected",)),
    Case("plan:steps-negative", ["plan", "--steps", "-4", "-o", "{d}/N"], ("steps",)),
    Case("plan:steps-text", ["plan", "--steps", "ten", "-o", "{d}/N"], ("--steps",)),
    Case("plan:steps-huge", ["plan", "--steps", "100000000", "-o", "{d}/N"], ("steps",)),
    Case("plan:runs-zero", ["plan", "--runs", "0", "-o", "{d}/N"], ("--runs 0: expected",)),
    Case("plan:runs-negative", ["plan", "--runs", "-2", "-o", "{d}/N"], ("runs",)),
    Case("plan:tests-unknown", ["plan", "--tests", "spiral", "-o", "{d}/N"], ("spiral",)),
    Case("plan:tests-empty", ["plan", "--tests", ",", "-o", "{d}/N"], ("--tests",)),
    Case("plan:step-orders-bad", ["plan", "--step-orders", "xzz", "-o", "{d}/N"], ("xzz",)),
    Case("plan:step-orders-letters", ["plan", "--step-orders", "abc", "-o", "{d}/N"], ("abc",)),
    Case("plan:tool-offset-two", ["plan", "--tool-offset", "1,2", "-o", "{d}/N"],
         ("--tool-offset",)),
    Case("plan:tool-offset-inf", ["plan", "--tool-offset", "1,inf,2", "-o", "{d}/N"],
         ("--tool-offset",)),
    Case("plan:output-is-file", ["plan", "-o", "{d}/points.csv"], ("points.csv",)),
    Case("plan:output-under-file", ["plan", "-o", "{d}/points.csv/S"], ("points.csv",)),
    Case("plan:output-under-a-file", ["plan", "-o", "{d}/S/session.toml/S"], ("session.toml",)),
    Case("plan:output-measured-session", ["plan", "-o", "{d}/S"],
         ("{d}/S: holds a volcal session (17 measurements, 17 with readings): `volcal plan` "
          "does not replace it. Give --replace to replace it (its session.toml and measurement "
          "CSVs are moved to backup/<UTC time>/), or add tests to it with `volcal plan --add "
          "{d}/S --tests ...`; nothing was changed",)),
    Case("plan:output-planned-session", ["plan", "-o", "{d}/P"],
         ("{d}/P: holds a volcal session (17 measurements, 0 with readings): `volcal plan` "
          "does not replace it. Give --replace",)),
    Case("plan:output-other-folder", ["plan", "-o", "{d}/COMP"],
         ("COMP: exists and is not a volcal session folder; choose a new or empty folder",)),
    Case("plan:add-no-session", ["plan", "--add", "{d}/EMPTY", "--tests", "diagonal"],
         ("EMPTY: --add needs an existing session folder (with session.toml)",)),
    Case("plan:add-and-output", ["plan", "--add", "{d}/P", "-o", "{d}/N"],
         ("give -o/--output FOLDER (a new session) or --add FOLDER (tests added to an existing "
          "session), not both",)),
    Case("plan:neither-add-nor-output", ["plan"], ("give -o/--output FOLDER",)),
    Case("plan:add-replace", ["plan", "--add", "{d}/P", "--replace"],
         ("--replace belongs to -o (a new session); --add never replaces anything",)),
    Case("plan:add-unknown-axis", ["plan", "--add", "{d}/P", "--tests", "linear:w"],
         ("unknown test 'linear:w': expected one of linear:x, linear:y, linear:z",)),
    Case("plan:add-broken-session", ["plan", "--add", "{d}/S", "--tests", "diagonal"],
         ("diag-npp.csv", "row 3", "column 'y_mm'"), set_cell("S/diag-npp.csv", 3, "y_mm", "ten")),
    # ---- simulate ----
    *sessions_cases(["simulate"], needs_measured=False, full=True),
    Case("simulate:noise-negative", ["simulate", "{d}/P", "--noise-um", "-1"], ("--noise-um",)),
    Case("simulate:noise-nan", ["simulate", "{d}/P", "--noise-um", "nan"], ("--noise-um",)),
    Case("simulate:mirror-inf", ["simulate", "{d}/P", "--mirror-urad", "inf"], ("--mirror-urad",)),
    Case("simulate:drift-nan", ["simulate", "{d}/P", "--drift-um-per-h", "nan"],
         ("--drift-um-per-h",)),
    Case("simulate:reversal-negative", ["simulate", "{d}/P", "--reversal-um", "-3"],
         ("--reversal-um",)),
    Case("simulate:seed-negative", ["simulate", "{d}/P", "--seed", "-1"], ("--seed",)),
    Case("simulate:measured-readings", ["simulate", "{d}/S", "--seed", "2"],
         ("S/session.toml", "holds readings that `volcal simulate` did not write",
          "--overwrite"), set_cell("S/linear-x2.csv", 3, "deviation_um", "7.125")),
    Case("simulate:measured-no-provenance", ["simulate", "{d}/S"],
         ("S/session.toml", "holds readings that `volcal simulate` did not write"),
         edit("S/session.toml", lambda t: t.replace('readings = "simulated"',
                                                    'readings = "measured"'))),
    Case("simulate:machine-missing", ["simulate", "{d}/P", "--machine", "{d}/NOPE.csv"],
         ("NOPE.csv",)),
    Case("simulate:machine-folder", ["simulate", "{d}/P", "--machine", "{d}/EMPTY"], ("EMPTY",)),
    Case("simulate:machine-empty", ["simulate", "{d}/P", "--machine", "{d}/empty.csv"],
         ("empty.csv",)),
    Case("simulate:machine-binary", ["simulate", "{d}/P", "--machine", "{d}/garbage.bin"],
         ("garbage.bin",)),
    Case("simulate:machine-nan", ["simulate", "{d}/P", "--machine", "{d}/ERRORS.csv"],
         ("ERRORS.csv", "row 5", "EY_um"), set_cell("ERRORS.csv", 5, "EY_um", "nan")),
    Case("simulate:machine-text", ["simulate", "{d}/P", "--machine", "{d}/ERRORS.csv"],
         ("ERRORS.csv", "row 3", "EC_urad"), set_cell("ERRORS.csv", 3, "EC_urad", "1.2.3")),
    Case("simulate:machine-truncated-toml", ["simulate", "{d}/P", "--machine", "{d}/ERRORS.csv"],
         ("ERRORS.toml",), put("ERRORS.toml", TRUNCATED_TOML)),
    # ---- program ----
    *sessions_cases(["program"], ["--dialect", "fanuc", "-o", "{d}/PROG"], needs_measured=False),
    Case("program:dialect-unknown", ["program", "{d}/P", "--dialect", "mazak", "-o", "{d}/PROG"],
         ("mazak",)),
    Case("program:dwell-negative", ["program", "{d}/P", "--dialect", "fanuc", "--dwell-s", "-1",
                                    "-o", "{d}/PROG"], ("dwell",)),
    Case("program:feed-zero", ["program", "{d}/P", "--dialect", "fanuc", "--feed", "0",
                               "-o", "{d}/PROG"], ("feed",)),
    Case("program:feed-nan", ["program", "{d}/P", "--dialect", "siemens", "--feed", "nan",
                              "-o", "{d}/PROG"], ("feed",)),
    Case("program:decimals-negative", ["program", "{d}/P", "--dialect", "heidenhain",
                                       "--decimals", "-1", "-o", "{d}/PROG"], ("decimals",)),
    Case("program:overrun-negative", ["program", "{d}/P", "--dialect", "fanuc",
                                      "--overrun-mm", "-5", "-o", "{d}/PROG"], ("overrun",)),
    Case("program:first-number-negative", ["program", "{d}/P", "--dialect", "fanuc",
                                           "--first-number", "-1", "-o", "{d}/PROG"],
         ("first-number",)),
    Case("program:output-is-file", ["program", "{d}/P", "--dialect", "fanuc",
                                    "-o", "{d}/points.csv"], ("points.csv",)),
    Case("program:output-under-file", ["program", "{d}/P", "--dialect", "fanuc",
                                       "-o", "{d}/points.csv/PROG"], ("points.csv",)),
    # ---- identify ----
    *sessions_cases(["identify"], ["-o", "{d}/M2.json"], full=True),
    Case("identify:prior-unknown", ["identify", "{d}/S", "--prior", "magic", "-o", "{d}/M2.json"],
         ("magic",)),
    Case("identify:roll-unknown", ["identify", "{d}/S", "--roll", "maybe", "-o", "{d}/M2.json"],
         ("maybe",)),
    Case("identify:noise-negative", ["identify", "{d}/S", "--noise-um", "-1", "-o", "{d}/M2.json"],
         ("noise",)),
    Case("identify:noise-nan", ["identify", "{d}/S", "--noise-um", "nan", "-o", "{d}/M2.json"],
         ("noise",)),
    Case("identify:monte-carlo-negative", ["identify", "{d}/S", "--monte-carlo", "-5",
                                           "-o", "{d}/M2.json"], ("monte-carlo",)),
    Case("identify:known-missing", ["identify", "{d}/S", "--known", "{d}/NOPE.csv",
                                    "-o", "{d}/M2.json"], ("NOPE.csv",)),
    Case("identify:known-binary", ["identify", "{d}/S", "--known", "{d}/garbage.bin",
                                   "-o", "{d}/M2.json"], ("garbage.bin",)),
    Case("identify:known-u-negative", ["identify", "{d}/S", "--known", "{d}/ERRORS.csv",
                                       "--known-u", "-1", "-o", "{d}/M2.json"], ("known-u",)),
    Case("identify:known-u-without-known", ["identify", "{d}/S", "--known-u", "0.5",
                                            "-o", "{d}/M2.json"], ("--known",)),
    Case("identify:measurements-unknown", ["identify", "{d}/S", "--measurements", "diag-ppp,nope",
                                           "-o", "{d}/M2.json"], ("nope",)),
    Case("identify:measurements-empty", ["identify", "{d}/S", "--measurements", ",",
                                         "-o", "{d}/M2.json"], ("measurements",)),
    Case("identify:output-is-folder", ["identify", "{d}/S", "-o", "{d}/EMPTY"], ("EMPTY",)),
    Case("identify:output-under-file", ["identify", "{d}/S", "-o", "{d}/points.csv/M.json"],
         ("points.csv",)),
    Case("identify:existing-output-bad-input", ["identify", "{d}/P", "-o", "{d}/MODEL.json"],
         ("deviation_um",)),
    # ---- predict ----
    Case("predict:model-missing", ["predict", "{d}/NOPE.json", "--points", "{d}/points.csv",
                                   "-o", "{d}/pred.csv"], ("NOPE.json",)),
    Case("predict:model-folder", ["predict", "{d}/EMPTY", "--points", "{d}/points.csv",
                                  "-o", "{d}/pred.csv"], ("EMPTY",)),
    Case("predict:model-truncated", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                     "-o", "{d}/pred.csv"], ("MODEL.json",),
         truncate("MODEL.json", 0.5)),
    Case("predict:model-binary", ["predict", "{d}/garbage.bin", "--points", "{d}/points.csv",
                                  "-o", "{d}/pred.csv"], ("garbage.bin",)),
    Case("predict:model-other-json", ["predict", "{d}/other.json", "--points", "{d}/points.csv",
                                      "-o", "{d}/pred.csv"], ("other.json",),
         put("other.json", '{"format": "volcal-model/1", "machine": 3}')),
    Case("predict:model-json-list", ["predict", "{d}/other.json", "--points", "{d}/points.csv",
                                     "-o", "{d}/pred.csv"], ("other.json",),
         put("other.json", "[1, 2, 3]")),
    Case("predict:points-missing", ["predict", "{d}/MODEL.json", "--points", "{d}/NOPE.csv",
                                    "-o", "{d}/pred.csv"], ("NOPE.csv",)),
    Case("predict:points-empty", ["predict", "{d}/MODEL.json", "--points", "{d}/empty.csv",
                                  "-o", "{d}/pred.csv"], ("empty.csv",)),
    Case("predict:points-header-only", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                        "-o", "{d}/pred.csv"], ("points.csv", "row 2"),
         keep_lines("points.csv", 1)),
    Case("predict:points-missing-column", ["predict", "{d}/MODEL.json", "--points",
                                           "{d}/points.csv", "-o", "{d}/pred.csv"],
         ("points.csv", "row 1", "z_mm"), drop_column("points.csv", "z_mm")),
    Case("predict:points-wrong-unit", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                       "-o", "{d}/pred.csv"], ("points.csv", "row 1", "y_mm"),
         rename_column("points.csv", "y_mm", "y_in")),
    Case("predict:points-text", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                 "-o", "{d}/pred.csv"], ("points.csv", "row 3", "y_mm"),
         set_cell("points.csv", 3, "y_mm", "abc")),
    Case("predict:points-nan", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                "-o", "{d}/pred.csv"], ("points.csv", "row 4", "x_mm"),
         set_cell("points.csv", 4, "x_mm", "NaN")),
    Case("predict:points-semicolons", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                       "-o", "{d}/pred.csv"], ("points.csv", "row 1"),
         semicolons("points.csv")),
    Case("predict:points-binary", ["predict", "{d}/MODEL.json", "--points", "{d}/garbage.bin",
                                   "-o", "{d}/pred.csv"], ("garbage.bin",)),
    Case("predict:points-folder", ["predict", "{d}/MODEL.json", "--points", "{d}/EMPTY",
                                   "-o", "{d}/pred.csv"], ("EMPTY",)),
    Case("predict:points-outside-travel", ["predict", "{d}/MODEL.json", "--points",
                                           "{d}/points.csv", "-o", "{d}/pred.csv"],
         ("points.csv", "row 3", "x_mm"), set_cell("points.csv", 3, "x_mm", "5000")),
    Case("predict:tool-offset-bad", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                     "--tool-offset", "0;0;0", "-o", "{d}/pred.csv"],
         ("--tool-offset",)),
    Case("predict:output-is-folder", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                      "-o", "{d}/EMPTY"], ("EMPTY",)),
    Case("predict:output-under-file", ["predict", "{d}/MODEL.json", "--points", "{d}/points.csv",
                                       "-o", "{d}/points.csv/pred.csv"], ("points.csv",)),
    # ---- compensate ----
    *[Case(f"compensate:{k}", ["compensate", *a, "-o", "{d}/C2"], e, m) for k, a, e, m in [
        ("format-unknown", ["{d}/ERRORS.csv", "--format", "okuma", "--sign", "error"],
         ("okuma",), None),
        ("linuxcnc-type", ["{d}/ERRORS.csv", "--format", "linuxcnc", "--linuxcnc-type", "2"],
         ("--linuxcnc-type 2",), None),
        ("fanuc-series", ["{d}/ERRORS.csv", "--format", "fanuc", "--fanuc-series", "15"],
         ("--fanuc-series",), None),
        ("linuxcnc-too-many", ["{d}/ERRORS.csv", "--format", "linuxcnc", "--spacing", "0.5"],
         ("limit of 256",), None),
        ("sign-unknown", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "plus"], ("plus",), None),
        ("spacing-zero", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "error",
                          "--spacing", "0"], ("spacing",), None),
        ("spacing-negative", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                              "--spacing", "-20"], ("spacing",), None),
        ("spacing-nan", ["{d}/ERRORS.csv", "--format", "siemens", "--sign", "error",
                         "--spacing", "nan"], ("spacing",), None),
        # session 19: 900 mm on an 800 mm travel wrote LinuxCNC's X.comp with the points
        # 0 and 900 mm, the second holding the value at 800 mm
        ("spacing-over-travel", ["{d}/ERRORS.csv", "--format", "linuxcnc",
                                 "--spacing", "5000"], ("--spacing 5000: longer than the "
                                                        "travel of LinuxCNC X",), None),
        ("max-points-zero", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                             "--max-points", "0"], ("max-points",), None),
        ("reference-bad", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                           "--reference-mm", "0,0"], ("--reference-mm",), None),
        ("unit-zero", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                       "--unit-um", "0"], ("unit",), None),
        ("magnification-zero", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                                "--magnification", "0"], ("magnification",), None),
        ("max-increment-negative", ["{d}/ERRORS.csv", "--format", "fanuc", "--sign", "error",
                                    "--max-increment", "-1"], ("increment",), None),
        ("tool-offset-bad", ["{d}/ERRORS.csv", "--format", "grid", "--sign", "error",
                             "--tool-offset", "x,y,z"], ("--tool-offset",), None),
        ("model-missing", ["{d}/NOPE.json", "--format", "csv", "--sign", "error"],
         ("NOPE.json",), None),
        ("model-folder", ["{d}/EMPTY", "--format", "csv", "--sign", "error"], ("EMPTY",), None),
        ("model-txt", ["{d}/points.csv", "--format", "csv", "--sign", "error"],
         ("points.csv",), None),
        ("model-binary", ["{d}/garbage.bin", "--format", "csv", "--sign", "error"],
         ("garbage.bin",), None),
        ("model-truncated-json", ["{d}/MODEL.json", "--format", "csv", "--sign", "error"],
         ("MODEL.json",), truncate("MODEL.json", 0.3)),
        ("table-missing-column", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "error"],
         ("ERRORS.csv", "row 1", "EZ_um"), drop_column("ERRORS.csv", "EZ_um")),
        ("table-text", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "error"],
         ("ERRORS.csv", "row 4", "EX_um"), set_cell("ERRORS.csv", 4, "EX_um", "x")),
        ("table-duplicate-row", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "error"],
         ("ERRORS.csv", "row 5"), duplicate_line("ERRORS.csv", 4)),
        ("table-semicolons", ["{d}/ERRORS.csv", "--format", "csv", "--sign", "error"],
         ("ERRORS.csv", "row 1"), semicolons("ERRORS.csv")),
    ]],
    Case("compensate:output-is-file", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                       "--sign", "error", "-o", "{d}/points.csv"],
         ("points.csv",)),
    Case("compensate:output-under-file", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                          "--sign", "error", "-o", "{d}/points.csv/C"],
         ("points.csv",)),
    Case("compensate:output-is-session", ["compensate", "{d}/ERRORS.csv", "--format", "csv",
                                          "--sign", "error", "-o", "{d}/S"], ("S",)),
    # ---- import ----
    *[Case(f"import:{k}", ["import", f"{{d}}/{f}", "--map", LASER_MAP, "--axis", "X",
                           "--session", "{d}/S", "--id", "lx9", *a], e, m)
      for k, f, a, e, m in [
        ("csv-missing", "NOPE.csv", [], ("NOPE.csv",), None),
        ("csv-folder", "EMPTY", [], ("EMPTY",), None),
        ("csv-empty", "empty.csv", [], ("empty.csv",), None),
        ("csv-binary", "garbage.bin", [], ("garbage.bin",), None),
        ("csv-missing-column", "laser.csv", [], ("laser.csv", "Error (um)"),
         drop_column("laser.csv", "Error (um)")),
        ("csv-wrong-unit", "laser.csv", [], ("laser.csv", "row 1", "Target"),
         rename_column("laser.csv", "Target (mm)", "Target (ft)")),
        ("csv-text", "laser.csv", [], ("laser.csv", "row 4", "Error (um)"),
         set_cell("laser.csv", 4, "Error (um)", "n/a")),
        ("csv-nan", "laser.csv", [], ("laser.csv", "row 3", "Target (mm)"),
         set_cell("laser.csv", 3, "Target (mm)", "nan")),
        ("csv-one-row", "laser.csv", [], ("laser.csv",), keep_lines("laser.csv", 2)),
        ("csv-duplicate-row", "laser.csv", [], ("laser.csv", "row 4"),
         duplicate_line("laser.csv", 3)),
        ("csv-bad-direction", "laser.csv", [], ("laser.csv", "row 2", "Dir"),
         set_cell("laser.csv", 2, "Dir", "sideways")),
        ("map-malformed", "laser.csv", ["--map", "target"], ("--map",), None),
        ("axis-unknown", "laser.csv", ["--axis", "W"], ("--axis",), None),
        ("units-unknown", "laser.csv", ["--units", "furlong"], ("furlong",), None),
        ("deviation-units-unknown", "laser.csv", ["--deviation-units", "pm"], ("pm",), None),
        ("optics-unknown", "laser.csv", ["--optics", "prism"], ("prism",), None),
        ("line-mm-bad", "laser.csv", ["--line-mm", "1,2"], ("--line-mm",), None),
        ("id-path", "laser.csv", ["--id", "../evil"], ("--id",), None),
        ("id-exists", "laser.csv", ["--id", "linear-x1"], ("linear-x1",), None),
        ("session-is-file", "laser.csv", ["--session", "{d}/points.csv"], ("points.csv",), None),
        ("session-corrupt", "laser.csv", [], ("session.toml",), truncate("S/session.toml", 0.4)),
        ("new-session-no-travel", "laser.csv", ["--session", "{d}/NEW"], ("--travel",), None),
        ("new-session-bad-travel", "laser.csv", ["--session", "{d}/NEW", "--travel", "0:1"],
         ("--travel",), None),
        ("new-session-bad-chain", "laser.csv", ["--session", "{d}/NEW", "--travel", TRAVEL,
                                                "--chain", "XYZF0"], ("XYZF0",), None),
        ("new-session-under-file", "laser.csv", ["--session", "{d}/points.csv/NEW", "--travel",
                                                 TRAVEL], ("points.csv",), None),
    ]],
    # ---- import: wide tables, planned diagonals and step diagonals ----
    *[Case(f"import:{k}", ["import", *a], e, m) for k, a, e, m in [
        ("wide-text", ["{d}/wide.csv", "--map", WIDE_MAP, "--axis", "X", "--session", "{d}/S",
                       "--id", "lx9"],
         ("wide.csv", "row 3", "column 'Run 2 (um)'", "not a number: 'n/a'"),
         set_cell("wide.csv", 3, "Run 2 (um)", "n/a")),
        ("wide-mm-in-um", ["{d}/wide.csv", "--map", WIDE_MAP, "--axis", "X", "--session",
                           "{d}/S", "--id", "lx9"],
         ("wide.csv", "row 4", "column 'Run 2 (um)'", "deviation 12500 um of reading 9 is "
          "absurd (> 10000 um): wrong units (mm in a um column?)"),
         set_cell("wide.csv", 4, "Run 2 (um)", "12500")),
        ("wide-unknown-column", ["{d}/wide.csv", "--map", "target=Target (mm),deviation=Pass*",
                                 "--axis", "X", "--session", "{d}/S", "--id", "lx9"],
         ("wide.csv", "row 1", "column 'Pass*'", "mapped column 'Pass*' not in the header "
          "line, which holds the other mapped columns ('Target (mm)'; header: 'Target (mm),Run "
          "1 (um),Run 2 (um)')"), None),
        ("wide-run-column-without-number", ["{d}/wide.csv", "--map", WIDE_MAP, "--axis", "X",
                                            "--session", "{d}/S", "--id", "lx9"],
         ("wide.csv", "row 1", "column 'Run mean (um)'", "names no run number"),
         rename_column("wide.csv", "Run 2 (um)", "Run mean (um)")),
        ("wide-run-key", ["{d}/wide.csv", "--map", WIDE_MAP + ",run=R", "--axis", "X",
                          "--session", "{d}/S", "--id", "lx9"],
         ("--map: run= does not fit a wide table",), None),
        ("planned-wrong-row-count", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                     "--session", "{d}/P", "--measurement", "diag-ppp"],
         ("diag.csv", "3 readings in the file, but 'diag-ppp' is planned with 4"),
         keep_lines("diag.csv", 4)),
        ("planned-target-off", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                "--session", "{d}/P", "--measurement", "diag-ppp"],
         ("diag.csv", "row 3", "column 'Pos'", "target 99 mm does not match the plan of "
          "'diag-ppp': reading 2 is planned at"), set_cell("diag.csv", 3, "Pos (mm)", "99")),
        ("planned-mm-in-um", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                              "--session", "{d}/P", "--measurement", "diag-ppp"],
         ("diag.csv", "row 4", "column 'Dev'", "is absurd (> 10000 um)"),
         set_cell("diag.csv", 4, "Dev (um)", "-25000")),
        ("planned-unknown-column", ["{d}/diag.csv", "--map", "target=Pos,deviation=Error",
                                    "--session", "{d}/P", "--measurement", "diag-ppp"],
         ("diag.csv", "row 1", "column 'Error'", "mapped column 'Error' not in the header "
          "line, which holds the other mapped columns ('Pos'; header: 'Pos (mm),Dev (um)')"),
         None),
        ("header-label-typo", ["{d}/laser.csv", "--map", LASER_MAP + ",operator=Operater",
                               "--axis", "X", "--session", "{d}/S", "--id", "lx9"],
         ("laser.csv", "row 3", "column 'Operater'", "--map operator=Operater: no column "
          "'Operater' in the table's header line and no such field in the header lines above "
          "it (closest: 'Operator'); header lines: lines 1-2"),
         edit("laser.csv", lambda t: "Operator: A. Technician\nDate: 2026-11-20\n" + t)),
        ("header-pressure-unit", ["{d}/laser.csv", "--map", LASER_MAP + ",air_pressure_pa=Baro",
                                  "--axis", "X", "--session", "{d}/S", "--id", "lx9"],
         ("laser.csv", "row 1", "column 'Baro'", "--map air_pressure_pa=Baro: cannot read "
          "'14.7 psi': unknown pressure unit 'psi': expected Pa, hPa, mbar, kPa, mmHg or inHg"),
         edit("laser.csv", lambda t: "Baro: 14.7 psi\n" + t)),
        ("header-date-ambiguous", ["{d}/laser.csv", "--map", LASER_MAP + ",date=Date",
                                   "--axis", "X", "--session", "{d}/S", "--id", "lx9"],
         ("laser.csv", "row 1", "column 'Date'", "--map date=Date: cannot read '05/11/2026': "
          "'05/11/2026' is ambiguous (day/month or month/day): write it as YYYY-MM-DD"),
         edit("laser.csv", lambda t: "Date: 05/11/2026\n" + t)),
        ("planned-typo-column", ["{d}/diag.csv", "--map", "target=Pos,deviation=Deviaton",
                                 "--session", "{d}/P", "--measurement", "diag-ppp"],
         ("diag.csv", "row 3", "column 'Deviaton'", "mapped column 'Deviaton' (closest: "
          "'Deviation (um)') not in the header line, which holds the other mapped columns "
          "('Pos'; header: 'Pos (mm),Deviation (um)')"),
         chain_of(rename_column("diag.csv", "Dev (um)", "Deviation (um)"),
                  edit("diag.csv", lambda t: "Laser XL export\nDate: 2026-11-20\n" + t))),
        ("planned-unknown-measurement", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                         "--session", "{d}/P", "--measurement", "diag-xyz"],
         ("session.toml", "--measurement 'diag-xyz': no such measurement"), None),
        ("planned-has-readings", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                  "--session", "{d}/S", "--measurement", "diag-ppp"],
         ("session.toml", "measurement 'diag-ppp' has readings; give --replace"), None),
        ("planned-no-session", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                "--session", "{d}/NEW", "--measurement", "diag-ppp"],
         ("NEW", "--measurement needs an existing session"), None),
        ("planned-and-axis", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                              "--session", "{d}/P", "--measurement", "diag-ppp", "--axis", "X"],
         ("--measurement fills a planned measurement: leave out --axis and --id",), None),
        ("neither-axis-nor-measurement", ["{d}/diag.csv", "--map", "target=Pos,deviation=Dev",
                                          "--session", "{d}/P"],
         ("give --axis and --id (a new linear measurement) or --measurement ID",), None),
        ("steps-wrong-rows", ["{d}/steps.csv", "--map", "target=Pos,deviation=dX|dY|dZ",
                              "--session", "{d}/P", "--measurement", "step-ppp"],
         ("steps.csv", "2 rows in the per-step table, but 'step-ppp' is planned with 3 steps"),
         keep_lines("steps.csv", 3)),
        ("steps-text", ["{d}/steps.csv", "--map", "target=Pos,deviation=dX|dY|dZ",
                        "--session", "{d}/P", "--measurement", "step-ppp"],
         ("steps.csv", "row 3", "column 'dY'", "not a number: 'x'"),
         set_cell("steps.csv", 3, "dY (um)", "x")),
        ("steps-empty-cell", ["{d}/steps.csv", "--map", "target=Pos,deviation=dX|dY|dZ",
                              "--session", "{d}/P", "--measurement", "step-ppp"],
         ("steps.csv", "row 4", "column 'dZ'", "empty field: expected a number"),
         set_cell("steps.csv", 4, "dZ (um)", "")),
        ("steps-two-columns", ["{d}/steps.csv", "--map", "target=Pos,deviation=dX|dY",
                               "--session", "{d}/P", "--measurement", "step-ppp"],
         ("--map names 2 move column(s) but each step of 'step-ppp' moves 3 axes",), None),
    ]],
    # ---- report ----
    *sessions_cases(["report"], ["-o", "{d}/R"]),
    Case("report:model-truncated", ["report", "{d}/S", "--model", "{d}/MODEL.json", "-o", "{d}/R"],
         ("MODEL.json",), truncate("MODEL.json", 0.5)),
    Case("report:model-missing", ["report", "{d}/S", "--model", "{d}/NOPE.json", "-o", "{d}/R"],
         ("NOPE.json",)),
    Case("report:compensation-missing", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                         "--compensation", "{d}/NOPE", "-o", "{d}/R"], ("NOPE",)),
    Case("report:compensation-file", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                      "--compensation", "{d}/points.csv", "-o", "{d}/R"],
         ("points.csv",)),
    Case("report:compensation-empty", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                       "--compensation", "{d}/EMPTY", "-o", "{d}/R"], ("EMPTY",)),
    # COMP was written from ERRORS.csv, the truth of "virtual VMC-1", without --session:
    # another machine's name than the session's "VMC-1" (issue 20, item 4)
    Case("report:compensation-other-machine", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                               "--compensation", "{d}/COMP", "-o", "{d}/R"],
         ("COMP/volcal-compensation.toml", "column 'machine'",
          "written for another machine, virtual VMC-1", "name 'virtual VMC-1' is not 'VMC-1'",
          "--force")),
    Case("report:compensation-table-missing", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                               "--compensation", "{d}/COMP", "--force", "-o",
                                               "{d}/R"],
         ("COMP", "table file pitch.csv named in the manifest is missing"),
         remove("COMP/pitch.csv")),
    # the decision rule, guard band and tolerance: one check behind both faces
    # (volcal.steps._checks.acceptance), the Python keywords spelled as options
    Case("report:guarded-without-tolerance", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                              "--decision-rule", "guarded", "-o", "{d}/R"],
         ("--decision-rule 'guarded' judges a tolerance: give --tolerance-um too",)),
    Case("report:guard-band-simple", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                      "--tolerance-um", "X=10", "--guard-band-um", "1",
                                      "-o", "{d}/R"],
         ("--guard-band-um applies to --decision-rule 'guarded' (valid rules: simple, "
          "guarded)",)),
    Case("evaluate:guard-band-negative", ["evaluate", "session", "{d}/S", "--tolerance-um",
                                          "X=10", "--decision-rule", "guarded",
                                          "--guard-band-um", "-1"],
         ("--guard-band-um -1.0: expected a finite number >= 0 [um]",)),
    Case("evaluate:rule-unknown", ["evaluate", "session", "{d}/S", "--tolerance-um", "X=10",
                                   "--decision-rule", "guardd"],
         ("--decision-rule 'guardd': expected one of simple, guarded",)),
    Case("report:edition-unknown", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                    "--edition", "1999", "-o", "{d}/R"], ("1999",)),
    Case("report:output-is-file", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                   "-o", "{d}/points.csv"], ("points.csv",)),
    Case("report:output-under-file", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                      "-o", "{d}/points.csv/R"], ("points.csv",)),
    Case("report:output-is-session", ["report", "{d}/S", "--model", "{d}/MODEL.json",
                                      "-o", "{d}/P"], ("P",)),
    # ---- demo ----
    Case("demo:output-is-file", ["demo", "-o", "{d}/points.csv"], ("points.csv",)),
    Case("demo:output-under-file", ["demo", "-o", "{d}/points.csv/D"], ("points.csv",)),
    Case("demo:output-is-session", ["demo", "-o", "{d}/S"], ("S",)),
    Case("demo:seed-negative", ["demo", "--seed", "-1", "-o", "{d}/D"], ("--seed",)),
    # ---- classic ----
    *[Case(f"classic-abbe:{k}", ["classic", "abbe", *a], e, m) for k, a, e, m in [
        ("two-files", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "--axis", "X",
                       "--chain", "XYFZ"], ("3",), None),
        ("file-missing", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/NOPE.csv",
                          "--axis", "X", "--chain", "XYFZ"], ("NOPE.csv",), None),
        ("file-folder", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/EMPTY",
                         "--axis", "X", "--chain", "XYFZ"], ("EMPTY",), None),
        ("axis-unknown", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                          "--axis", "U", "--chain", "XYFZ"], ("--axis",), None),
        ("axis-wrong", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                        "--axis", "Y", "--chain", "XYFZ"], ("linear-x1.csv",), None),
        ("offsets-text", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                          "--axis", "X", "--offsets", "0,0;a,b;0,200"], ("--offsets",), None),
        ("offsets-count", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                           "--axis", "X", "--offsets", "0,0;300,0"], ("--offsets",), None),
        ("offsets-collinear", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                               "{d}/S/linear-x3.csv", "--axis", "X",
                               "--offsets", "0,0;0,0;0,0"], ("offset",), None),
        ("offsets-nan", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                         "--axis", "X", "--offsets", "0,0;nan,0;0,200"], ("--offsets",), None),
        ("no-offsets-no-chain", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                                 "{d}/S/linear-x3.csv", "--axis", "X"], ("--chain",), None),
        ("chain-bad", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                       "--axis", "X", "--chain", "XY"], ("XY",), None),
        ("csv-text", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                      "--axis", "X", "--chain", "XYFZ"],
         ("linear-x2.csv", "row 3", "deviation_um"),
         set_cell("S/linear-x2.csv", 3, "deviation_um", "1e")),
        ("csv-missing-column", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                                "{d}/S/linear-x3.csv", "--axis", "X", "--chain", "XYFZ"],
         ("linear-x3.csv", "row 1", "deviation_um"),
         drop_column("S/linear-x3.csv", "deviation_um")),
        ("csv-empty", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/empty.csv",
                       "--axis", "X", "--chain", "XYFZ"], ("empty.csv",), None),
        ("csv-other-targets", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                               "{d}/S/linear-x3.csv", "--axis", "X", "--chain", "XYFZ"],
         ("linear-x3.csv",), set_cell("S/linear-x3.csv", 3, "x_mm", "140")),
        ("output-is-folder", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv", "{d}/S/linear-x3.csv",
                              "--axis", "X", "--chain", "XYFZ", "-o", "{d}/EMPTY"],
         ("EMPTY",), None),
        ("output-under-file", ["{d}/S/linear-x1.csv", "{d}/S/linear-x2.csv",
                               "{d}/S/linear-x3.csv", "--axis", "X", "--chain", "XYFZ",
                               "-o", "{d}/points.csv/a.csv"], ("points.csv",), None),
    ]],
    *sessions_cases(["classic", "abbe-session"]),
    Case("classic-abbe-session:output-is-file", ["classic", "abbe-session", "{d}/S",
                                                 "-o", "{d}/points.csv"], ("points.csv",)),
    *sessions_cases(["classic", "step-diagonal"], ["-o", "{d}/T.csv"]),
    Case("classic-step-diagonal:no-step-diagonals", ["classic", "step-diagonal", "{d}/L"],
         ("L",)),
    Case("classic-step-diagonal:output-under-file", ["classic", "step-diagonal", "{d}/S",
                                                     "-o", "{d}/points.csv/T.csv"],
         ("points.csv",)),
    Case("classic-step-diagonal:output-stdout", ["classic", "step-diagonal", "{d}/S",
                                                 "-o", "-"], ("-o -", "writes two files")),
    *sessions_cases(["classic", "diagonals"]),
    Case("classic-diagonals:no-diagonals", ["classic", "diagonals", "{d}/L"], ("L",)),
    # ---- evaluate ----
    *[Case(f"evaluate-{cmd}:{k}", ["evaluate", cmd, f"{{d}}/{f}", *a], e, m)
      for cmd in ("iso230-2", "vdi3441")
      for k, f, a, e, m in [
        ("missing", "NOPE.csv", [], ("NOPE.csv",), None),
        ("folder", "EMPTY", [], ("EMPTY",), None),
        ("empty", "empty.csv", [], ("empty.csv",), None),
        ("binary", "garbage.bin", [], ("garbage.bin",), None),
        ("missing-column", "S/linear-y1.csv", [], ("linear-y1.csv", "row 1", "deviation_um"),
         drop_column("S/linear-y1.csv", "deviation_um")),
        ("text", "S/linear-y1.csv", [], ("linear-y1.csv", "row 5", "deviation_um"),
         set_cell("S/linear-y1.csv", 5, "deviation_um", "--")),
        ("nan", "S/linear-y1.csv", [], ("linear-y1.csv", "row 6", "y_mm"),
         set_cell("S/linear-y1.csv", 6, "y_mm", "nan")),
        ("bad-run", "S/linear-y1.csv", [], ("linear-y1.csv", "row 2", "run"),
         set_cell("S/linear-y1.csv", 2, "run", "1.5")),
        ("bad-direction", "S/linear-y1.csv", [], ("linear-y1.csv", "row 2", "direction"),
         set_cell("S/linear-y1.csv", 2, "direction", "up!")),
        ("one-row", "S/linear-y1.csv", [], ("linear-y1.csv",), keep_lines("S/linear-y1.csv", 2)),
        ("duplicate-row", "S/linear-y1.csv", [], ("linear-y1.csv", "row 4", "column 'y_mm'"),
         duplicate_line("S/linear-y1.csv", 3)),
        ("missed-every-minus", "S/linear-y1.csv", [],
         ("linear-y1.csv", "column 'direction'", "no readings in direction '-'"),
         missed_where("S/linear-y1.csv", "direction", "-")),
        ("missed-all-but-one-run", "S/linear-y1.csv", [],
         ("linear-y1.csv", "column 'run'", "only 1 run(s) in direction '+'"),
         missed_where("S/linear-y1.csv", "run", "2")),
        ("typo-column", "S/linear-y1.csv", [],
         ("linear-y1.csv", "row 1", "column 'deviation_um'",
          "missing required column 'deviation_um' (closest: 'deviaton_um')"),
         rename_column("S/linear-y1.csv", "deviation_um", "deviaton_um")),
        ("not-linear", "S/diag-ppp.csv", [], ("diag-ppp.csv",), None),
        ("no-runs", "S/linear-y1.csv", [], ("linear-y1.csv",),
         chain_of(drop_column("S/linear-y1.csv", "run"),
                  drop_column("S/linear-y1.csv", "direction"))),
        ("planned", "P/linear-y1.csv", [], ("linear-y1.csv", "deviation_um"), None),
    ]],
    Case("evaluate-iso230-2:edition-unknown", ["evaluate", "iso230-2", "{d}/S/linear-x1.csv",
                                               "--edition", "2020"], ("2020",)),
    *sessions_cases(["evaluate", "iso230-6"]),
    Case("evaluate-iso230-6:no-diagonals", ["evaluate", "iso230-6", "{d}/L"], ("L",)),
    *sessions_cases(["evaluate", "session"]),
    Case("evaluate-session:edition-unknown", ["evaluate", "session", "{d}/S", "--edition", "1"],
         ("1",)),
    Case("evaluate-session:no-linear", ["evaluate", "session", "{d}/D"], ("D",)),
    Case("evaluate-session:compensation-other-machine",
         ["evaluate", "session", "{d}/S", "--tolerance-um", "X=10", "--model", "{d}/ERRORS.csv",
          "--compensation", "{d}/COMP"],
         ("COMP/volcal-compensation.toml", "column 'machine'",
          "written for another machine, virtual VMC-1", "--force")),
    Case("evaluate-session:compensation-table-damaged",
         ["evaluate", "session", "{d}/S", "--tolerance-um", "X=10", "--model", "{d}/ERRORS.csv",
          "--compensation", "{d}/COMP", "--force"],
         ("pitch.csv", "row 3", "column 'error_um'"), set_cell("COMP/pitch.csv", 3, "error_um",
                                                              "x")),
    *[Case(f"evaluate-volumetric:{k}", ["evaluate", "volumetric", f"{{d}}/{f}", *a], e, m)
      for k, f, a, e, m in [
        ("missing", "NOPE.csv", [], ("NOPE.csv",), None),
        ("folder", "EMPTY", [], ("EMPTY",), None),
        ("empty", "empty.csv", [], ("empty.csv",), None),
        ("binary", "garbage.bin", [], ("garbage.bin",), None),
        # a model is read (its estimate's indices); a JSON that is no model is refused
        ("json-not-a-model", "notes.json", [], ("notes.json", "unknown model format"),
         put("notes.json", '{"a": 1}\n')),
        ("named-json-not-a-model", "notes", [], ("notes", "unknown model format"),
         put("notes", '{"a": 1}\n')),
        ("missing-column", "ERRORS.csv", [], ("ERRORS.csv", "row 1", "EA_urad"),
         drop_column("ERRORS.csv", "EA_urad")),
        ("text", "ERRORS.csv", [], ("ERRORS.csv", "row 2", "EB_urad"),
         set_cell("ERRORS.csv", 2, "EB_urad", "one")),
        ("inf", "ERRORS.csv", [], ("ERRORS.csv", "row 6", "EZ_um"),
         set_cell("ERRORS.csv", 6, "EZ_um", "inf")),
        ("one-row", "ERRORS.csv", [], ("ERRORS.csv",), keep_lines("ERRORS.csv", 2)),
        ("semicolons", "ERRORS.csv", [], ("ERRORS.csv", "row 1"), semicolons("ERRORS.csv")),
        ("toml-truncated", "ERRORS.csv", [], ("ERRORS.toml",), put("ERRORS.toml", TRUNCATED_TOML)),
        ("toml-other-format", "ERRORS.csv", [], ("ERRORS.toml", "format"),
         put("ERRORS.toml", 'format = "volcal-session/1"\n')),
        ("n-zero", "ERRORS.csv", ["--n", "0"], ("--n",), None),
        ("n-one", "ERRORS.csv", ["--n", "1"], ("--n",), None),
        ("n-huge", "ERRORS.csv", ["--n", "100000"], ("--n",), None),
        ("tool-offset-bad", "ERRORS.csv", ["--tool-offset", "1,2,3,4"], ("--tool-offset",), None),
    ]],
    # ---- env ----
    *[Case(f"env:{k}", ["env", "refractive-index", "--temperature-c", t, "--pressure-pa", p,
                        "--humidity-pct", h, *a], e)
      for k, t, p, h, a, e in [
        ("formula-unknown", "20", "101325", "50", ["--formula", "magic"], ("magic",)),
        ("temperature-nan", "nan", "101325", "50", [], ("temperature",)),
        ("temperature-absurd", "500", "101325", "50", [], ("temperature",)),
        ("pressure-negative", "20", "-1", "50", [], ("--pressure-pa -1 outside",)),
        ("pressure-in-hpa", "20", "1013.25", "50", [], ("--pressure-pa 1013.25 outside",
                                                        "1013.25 hPa is 101325 Pa")),
        ("humidity-over-100", "20", "101325", "150", [], ("humidity",)),
        ("humidity-text", "20", "101325", "wet", [], ("--humidity-pct",)),
        ("wavelength-zero", "20", "101325", "50", ["--wavelength-nm", "0"], ("wavelength",)),
        ("co2-negative", "20", "101325", "50", ["--co2-ppm", "-5"], ("co2",)),
    ]],
]


def _extra_sessions(d: Path) -> None:
    """``L``: only linear tests; ``D``: only diagonals (from the measured session)."""
    import tomllib

    import tomli_w

    doc = tomllib.loads((d / "S" / "session.toml").read_text())
    for name, keep in (("L", "linear"), ("D", "diagonal")):
        shutil.copytree(d / "S", d / name, ignore=shutil.ignore_patterns("truth"))
        sub = dict(doc)
        sub["measurements"] = [m for m in doc["measurements"] if m["kind"] == keep]
        (d / name / "session.toml").write_text(tomli_w.dumps(sub))


def _ids(cases: list[Case]) -> list[str]:
    seen: set[str] = set()
    for c in cases:
        assert c.id not in seen, c.id
        seen.add(c.id)
    return [c.id for c in cases]


@pytest.mark.parametrize("case", CASES, ids=_ids(CASES))
def test_bad_input(case: Case, base: Path, tmp_path: Path) -> None:
    d = tmp_path / "w"
    shutil.copytree(base, d)
    if case.mutate is not None:
        case.mutate(d)
    before = touch_snapshot(d)
    r = volcal(*[a.format(d=d) for a in case.args], cwd=d)
    out = r.stdout + r.stderr
    assert "Traceback" not in out, out
    assert r.returncode == 2, f"exit {r.returncode}\nstdout:\n{r.stdout}\nstderr:\n{r.stderr}"
    msg = " ".join(r.stderr.split())
    for e in case.expect:
        assert e.format(d=d) in msg, f"{e!r} not in the message:\n{r.stderr}"
    assert touch_snapshot(d) == before, "the command changed its inputs or left an output"


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="root writes into read-only folders")
@pytest.mark.parametrize("args", [
    ["plan", "-o", "{d}/RO/S"],
    ["identify", "{d}/S", "-o", "{d}/RO/M.json"],
    ["compensate", "{d}/ERRORS.csv", "--format", "csv", "--sign", "error", "-o", "{d}/RO/C"],
    ["report", "{d}/S", "--model", "{d}/MODEL.json", "-o", "{d}/RO/R"],
], ids=["plan", "identify", "compensate", "report"])
def test_output_in_read_only_folder(args: list[str], base: Path, tmp_path: Path) -> None:
    d = tmp_path / "w"
    shutil.copytree(base, d)
    (d / "RO").mkdir()
    (d / "RO").chmod(0o555)
    try:
        before = touch_snapshot(d)
        r = volcal(*[a.format(d=d) for a in args], cwd=d)
        assert "Traceback" not in r.stdout + r.stderr, r.stderr
        assert r.returncode == 2, r.stderr
        assert "not writable" in r.stderr and "RO" in r.stderr
        assert touch_snapshot(d) == before
    finally:
        (d / "RO").chmod(0o755)


PARTIAL_COMMANDS = [
    ["identify", "{d}/S", "-o", "{d}/M3.json"],
    ["evaluate", "session", "{d}/S", "--json"],
    ["evaluate", "iso230-6", "{d}/S"],
    ["evaluate", "session", "{d}/S"],
    ["report", "{d}/S", "-o", "{d}/R"],
    ["classic", "abbe-session", "{d}/S"],
    ["classic", "step-diagonal", "{d}/S"],
    ["classic", "diagonals", "{d}/S"],
]


@pytest.mark.parametrize("args", PARTIAL_COMMANDS, ids=[" ".join(a[:2]) for a in PARTIAL_COMMANDS])
def test_partial_session(args: list[str], base: Path, tmp_path: Path,
                         request: pytest.FixtureRequest) -> None:
    """A partly measured session (one linear line, one diagonal, one step diagonal still
    empty; one missed capture) works on the measured subset and says what it left out.

    The report is written with blank figures and a stub PDF (tests/report_stubs.py): its
    HTML is checked here; a partly measured session's report is drawn for real by
    tests/standards/test_incomplete.py::test_report_lists_missed_readings_and_unmeasured_tests."""
    if args[0] == "report":
        request.getfixturevalue("blank_figures")
        request.getfixturevalue("stub_pdfs")
    d = tmp_path / "w"
    shutil.copytree(base, d)
    for f in ("linear-x2", "diag-ppp", "step-npp"):
        clear_deviations(f"S/{f}.csv")(d)
    set_cell("S/diag-npp.csv", 3, "deviation_um", "missed")(d)
    set_cell("S/linear-y1.csv", 5, "deviation_um", "missed")(d)  # run 1, '+': 1 of 2 runs left
    r = volcal(*[a.format(d=d) for a in args], cwd=d)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Traceback" not in r.stdout + r.stderr
    err = " ".join(r.stderr.split())
    assert "note: no readings yet: step-npp, diag-ppp, linear-x2 (working on the 14 measured)" \
        in err
    assert f"note: {d}/S/diag-npp.csv: missed capture skipped (row 3)" in err
    assert f"note: {d}/S/linear-y1.csv: missed capture skipped (row 5)" in err
    if args[:2] == ["evaluate", "session"] and "--json" in args:
        import json

        y1 = json.loads(r.stdout)["measurements"]["linear-y1"]
        assert y1["complete"] is False and len(y1["missing"]) == 1
        assert sorted(t["n"] for t in y1["targets"]) == [1] + [2] * (len(y1["targets"]) - 1)
    if args[0] == "report":
        html = (d / "R" / "report.html").read_text()
        assert "Missed readings" in html and "n = 1 of 2 runs" in html
        assert "step-npp, diag-ppp, linear-x2" in html  # the planned tests not measured
    if args[0] == "evaluate" and "--json" in args:
        import json

        out = json.loads(r.stdout)
        assert "linear-x2" not in out["measurements"] and "linear-x1" in out["measurements"]
    if args[0] == "identify":
        import json

        fit = json.loads((d / "M3.json").read_text())["fit"]
        assert "linear-x2" not in fit["measurements"]
        assert fit["notes"][0] == ("no readings yet: step-npp, diag-ppp, linear-x2 (working on "
                                   "the 14 measured)")


def test_implausible_scale_is_warned_and_recorded(base: Path, tmp_path: Path) -> None:
    """mm pasted into deviation_um (x1000) of one linear test: identify warns, names it and
    records the warning in the model's notes."""
    d = tmp_path / "w"
    shutil.copytree(base, d)

    def x1000(text: str) -> str:
        rows = [ln.split(",") for ln in text.splitlines()]
        j = rows[0].index("deviation_um")
        for r in rows[1:]:
            r[j] = f"{float(r[j]) * 1000:.3f}"
        return "\n".join(",".join(r) for r in rows) + "\n"

    edit("S/linear-y3.csv", x1000)(d)
    r = volcal("identify", d / "S", "-o", d / "M3.json", cwd=d)
    assert r.returncode == 0, r.stderr
    err = " ".join(r.stderr.split())
    assert "warning: linear-y3: deviations ~" in err and "mm entered as um in linear-y3.csv?" in err
    import json

    notes = json.loads((d / "M3.json").read_text())["fit"]["notes"]
    assert any(n.startswith("warning: linear-y3: deviations ~") for n in notes)
