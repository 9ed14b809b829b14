"""Plan into an existing session: refuse to replace it, replace it with a backup, or add tests.

``volcal plan -o S`` never replaces a session silently (hand-added tests and readings
would be lost, old CSVs orphaned): :func:`existing_session` tells what ``S`` holds and
:func:`refusal` says how to go on. With ``--replace`` :func:`replace_session` moves the
old ``session.toml``, its measurement CSVs and ``truth/`` into ``S/backup/<UTC time>/``
in the same atomic replacement of the folder. ``volcal plan --add S`` appends tests
with :func:`add_tests`: fresh ids (an id or a file name of the folder is never reused),
the existing entries and CSVs untouched byte for byte (``docs/formats.md``).
"""

from __future__ import annotations

import shlex
import shutil
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir
from volcal.io.folders import JOURNAL_FOLDER
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.session.format import Measurement, Session, read_session

__all__ = ["AddResult", "ExistingSession", "add_planned_tests", "add_tests", "existing_session",
           "fresh_id", "refusal", "replace_session", "require_session"]


@dataclass
class ExistingSession:
    """What an existing session folder holds (for the refusal and the backup).

    Attributes
    ----------
    folder : Path
        The session folder.
    files : list of str
        Its measurement files (relative), as ``session.toml`` names them (every top-level
        ``*.csv`` when ``session.toml`` cannot be parsed).
    n_measurements : int
        Entries in ``session.toml`` (0 if unreadable).
    measured : list of str
        Ids of the measurements holding readings (empty if the CSVs cannot be read).
    readable : bool
        ``session.toml`` parses as TOML.
    """

    folder: Path
    files: list[str]
    n_measurements: int
    measured: list[str] = field(default_factory=list)
    readable: bool = True


def existing_session(folder: str | Path) -> ExistingSession | None:
    """The session a folder holds, or None when it holds no ``session.toml``.

    Parameters
    ----------
    folder : str or Path
        A prospective output folder of ``volcal plan``.

    Returns
    -------
    ExistingSession or None
    """
    folder = Path(folder)
    toml_path = folder / "session.toml"
    if not toml_path.is_file():
        return None
    try:
        doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
        entries = doc.get("measurements", [])
        entries = entries if isinstance(entries, list) else []
    except (tomllib.TOMLDecodeError, UnicodeDecodeError, OSError):
        files = sorted(p.name for p in folder.glob("*.csv"))
        return ExistingSession(folder, files, 0, [], False)
    files = [e["file"] for e in entries if isinstance(e, dict) and isinstance(e.get("file"), str)]
    measured: list[str] = []
    try:
        s = read_session(folder, require_deviation=False)
        measured = [m.id for m in [*s.measurements, *s.unmeasured] if m.deviation is not None]
    except VolcalInputError:
        pass  # a damaged session: still a session, still never replaced silently
    return ExistingSession(folder, files, len(entries), measured)


def refusal(e: ExistingSession, shown: str | None = None) -> VolcalInputError:
    """The error of ``volcal plan -o S`` over an existing session without ``--replace``.

    Parameters
    ----------
    e : ExistingSession
        What the folder holds.
    shown : str, optional
        The folder as the user typed it (default ``e.folder``).

    Returns
    -------
    VolcalInputError
        ``S: holds a volcal session (17 measurements, 0 with readings): volcal plan does
        not replace it; give --replace ... or add tests with volcal plan --add S ...``.
    """
    name = shown if shown is not None else str(e.folder)
    what = (f"{e.n_measurements} measurements, {len(e.measured)} with readings"
            if e.readable else "its session.toml cannot be read")
    return VolcalInputError(
        f"holds a volcal session ({what}): `volcal plan` does not replace it. Give --replace "
        "to replace it (its session.toml and measurement CSVs are moved to "
        "backup/<UTC time>/), or add tests to it with `volcal plan --add "
        f"{shlex.quote(name)} --tests ...`; nothing was changed", name)


def replace_session(session: Session, folder: str | Path, old: ExistingSession) -> str:
    """Write ``session`` into ``folder`` in place of an existing session, keeping a backup.

    The old ``session.toml``, the measurement files it names, ``truth/`` and the capture
    journal ``capture/`` are moved into ``backup/<UTC time>/`` in the same atomic
    replacement of the folder; every other file of the folder (notes, results, earlier
    backups) is kept.

    Parameters
    ----------
    session : Session
        The new session.
    folder : str or Path
        The session folder.
    old : ExistingSession
        What it holds now (:func:`existing_session`).

    Returns
    -------
    str
        The backup folder, relative to ``folder`` (``backup/20261124T031500Z``).
    """
    from volcal.session.provenance import backup_name, backup_session_files

    folder = Path(folder)
    names = [m.file for m in session.measurements]
    if len(set(names)) != len(names):
        raise VolcalInputError("two measurements share one file name")
    rel = backup_name(folder)
    with atomic_dir(folder) as tmp:
        shutil.copytree(folder, tmp, symlinks=True, dirs_exist_ok=True)
        backup_session_files(tmp, old.files, rel)
        for f in ["session.toml", *old.files]:
            p = tmp / f
            if p.is_file() and _inside(tmp, p):
                p.unlink()  # moved: it is in the backup now
        if (tmp / "truth").is_dir():
            shutil.rmtree(tmp / "truth")
        journal = tmp / JOURNAL_FOLDER  # the old plan's capture journal goes with its files:
        if journal.is_dir():  # left here, a capture of the new plan resumed it (session 20)
            shutil.move(journal, tmp / rel / JOURNAL_FOLDER)
        _write(tmp, toml_dumps(session.to_toml()), session.measurements)
    session.path = folder
    return rel


def _inside(root: Path, p: Path) -> bool:
    try:
        p.resolve().relative_to(root.resolve())
    except ValueError:
        return False
    return True


def _write(tmp: Path, toml_text: str, measurements: list[Measurement]) -> None:
    (tmp / "session.toml").write_text(toml_text, encoding="utf-8")
    for m in measurements:
        (tmp / m.file).parent.mkdir(parents=True, exist_ok=True)
        (tmp / m.file).write_text(m.to_csv(), encoding="utf-8")


def fresh_id(base: str, taken: set[str], folder: Path) -> str:
    """``base`` if free, else ``base-2``, ``base-3``...: no id of ``taken``, no file of ``folder``.

    Parameters
    ----------
    base : str
        The planner's id (``diag-ppp``).
    taken : set of str
        Ids in use (the session's and those given out already).
    folder : Path
        The session folder: an id whose ``<id>.csv`` exists there (an orphan, a user's
        file) is not used either.

    Returns
    -------
    str
    """
    k, mid = 1, base
    while mid in taken or (folder / f"{mid}.csv").exists():
        k += 1
        mid = f"{base}-{k}"
    return mid


@dataclass
class AddResult:
    """What :func:`add_tests` added.

    Attributes
    ----------
    session : Path
        The session folder.
    added : list of Measurement
        The new (planned, unmeasured) measurements, with their fresh ids.
    renamed : dict of str to str
        Planner id -> fresh id, where the planner's id was taken.
    n_before : int
        Measurements the session held before.
    """

    session: Path
    added: list[Measurement]
    renamed: dict[str, str]
    n_before: int


def add_tests(folder: str | Path, planned: Session) -> AddResult:
    """Append the measurements of a plan to an existing session, with fresh ids.

    ``session.toml`` keeps its text (comments, order, other tables) and gains one
    ``[[measurements]]`` entry per new test at its end; the existing measurement files
    are not touched. If the readings were written by ``volcal simulate`` and still have
    its digest, the digest is brought up to date (the readings did not change), so that
    ``volcal simulate`` may fill the new tests. The folder is replaced atomically and
    the result is read back before it replaces the old one.

    Parameters
    ----------
    folder : str or Path
        An existing session folder (read with ``require_deviation=False``).
    planned : Session
        The tests to add (from :func:`volcal.plan.planner.plan_session` with the
        session's travel and chain).

    Returns
    -------
    AddResult

    Raises
    ------
    VolcalInputError
        No session in ``folder``, an invalid session, a chain or travel differing from
        the plan's.
    """
    folder = require_session(folder)
    s = read_session(folder, require_deviation=False)
    if planned.chain != s.chain or not (planned.travel == s.travel).all():
        raise VolcalInputError("the tests to add are planned for another chain or travel than "
                               "the session's", folder / "session.toml")
    every = [*s.measurements, *s.unmeasured]
    taken = {m.id for m in every} | {m.file.removesuffix(".csv") for m in every}
    renamed: dict[str, str] = {}
    added: list[Measurement] = []
    refs = _fresh_references(planned.measurements, every)
    for m in planned.measurements:
        mid = fresh_id(m.id, taken, folder)
        taken.add(mid)
        if mid != m.id:
            renamed[m.id] = mid
        meta = dict(m.meta)
        if "reference" in meta:
            meta["reference"] = refs[meta["reference"]]
        added.append(Measurement(mid, m.kind, m.target, m.positions, None, m.beam_direction,
                                 m.tool_offset, f"{mid}.csv", m.columns, meta))
    text = _with_rotary_axes(_appended_toml(folder / "session.toml", s, added), s, planned)
    with atomic_dir(folder) as tmp:
        shutil.copytree(folder, tmp, symlinks=True, dirs_exist_ok=True)
        _write(tmp, text, added)
        back = read_session(tmp, require_deviation=False)  # never commit what does not read
        ids = [m.id for m in [*back.measurements, *back.unmeasured]]
        if ids[:len(every)] != [m.id for m in every] or len(ids) != len(every) + len(added):
            raise RuntimeError("session.toml did not read back with the added tests")
    return AddResult(folder, added, renamed, len(every))


def _with_rotary_axes(text: str, s: Session, planned: Session) -> str:
    """``session.toml`` with the plan's rotary axes the machine does not list yet.

    ``volcal plan --add S --tests rotary:a`` on a session whose ``[[machine.rotary_axes]]``
    lists C alone added the test of A and left the machine without its axis (session 20).
    The entries are appended as text when that reads back as the merged list, else the
    document is rewritten.
    """
    from volcal.session.rotary import read_rotary_axes

    have = {a.name for a in read_rotary_axes(s.meta)}
    new = [a for a in planned.meta.get("rotary_axes", []) if a["name"] not in have]
    if not new:
        return text
    doc = tomllib.loads(text)
    machine = doc.setdefault("machine", {})
    merged = [*machine.get("rotary_axes", []), *new]
    tail = "".join("\n[[machine.rotary_axes]]\n" + toml_dumps(a) for a in new)
    try:
        if tomllib.loads(text + tail).get("machine", {}).get("rotary_axes") == merged:
            return text + tail
    except tomllib.TOMLDecodeError:
        pass
    machine["rotary_axes"] = merged
    return toml_dumps(doc)


def _fresh_references(planned: list[Measurement], every: list[Measurement]) -> dict[str, str]:
    """Planned reference group -> a name no measurement of the session uses.

    A reference group is one reference optic not moved between its lines: the added
    lines were read in a set-up of their own, never in a group of the session's
    (``z-roll`` becomes ``z-roll-2`` when the session has a ``z-roll`` group).
    """
    taken = {str(m.meta["reference"]) for m in every if m.meta.get("reference") is not None}
    out: dict[str, str] = {}
    for m in planned:
        ref = m.meta.get("reference")
        if ref is None or ref in out:
            continue
        k, name = 1, str(ref)
        while name in taken:
            k += 1
            name = f"{ref}-{k}"
        taken.add(name)
        out[ref] = name
    return out


def add_planned_tests(folder: str | Path, tests: Sequence[str], steps: int = 10, runs: int = 5,
                      step_orders: Sequence[str] = ("xyz",),
                      tool_offset: ArrayLike = (0.0, 0.0, 0.0),
                      step_target: str = "flat_mirror", **options: Any) -> AddResult:
    """``volcal plan --add``: plan ``tests`` on the session's machine and append them.

    Parameters
    ----------
    folder : str or Path
        An existing session folder.
    tests : sequence of str
        Test names of :func:`volcal.plan.planner.plan_session` (``'diagonal'``,
        ``'linear:x'``, ``'direct:level-x'``...; direct optics on the session's
        ``[machine] vertical_axis``).
    steps, runs, step_orders, tool_offset, step_target
        As for :func:`~volcal.plan.planner.plan_session` (the same defaults as
        ``volcal plan``); ``tool_offset`` [mm].
    **options
        Further keywords of :func:`~volcal.plan.planner.plan_session`
        (``iso_spacing``, ``linear_margin_mm``, ``abbe_tool_offset_mm``,
        ``multilateration``).

    Returns
    -------
    AddResult
    """
    from volcal.plan.planner import plan_session
    from volcal.session.optics import vertical_axis

    s = read_session(require_session(folder), require_deviation=False)
    rotary = dict(options.pop("rotary", None) or {})
    if "axes" not in rotary:  # the session's [[machine.rotary_axes]]
        from volcal.session.rotary import read_rotary_axes

        rotary["axes"] = read_rotary_axes(s.meta)
    options["rotary"] = rotary
    planned = plan_session(s.travel, s.chain, steps, list(tests), runs, list(step_orders),
                           tool_offset, s.name, step_target=step_target,
                           vertical_axis=vertical_axis(s.meta), **options)
    return add_tests(folder, planned)


def require_session(folder: str | Path) -> Path:
    """``folder``, checked to hold a ``session.toml`` (the folder of ``volcal plan --add``).

    Parameters
    ----------
    folder : str or Path
        The folder given to ``--add``.

    Returns
    -------
    Path

    Raises
    ------
    VolcalInputError
        No ``session.toml`` there.
    """
    folder = Path(folder)
    if not (folder / "session.toml").is_file():
        raise VolcalInputError("--add needs an existing session folder (with session.toml); "
                               "write a new one with `volcal plan -o FOLDER`", folder)
    return folder


def _appended_toml(toml_path: Path, s: Session, added: list[Measurement]) -> str:
    """``session.toml`` with the new entries appended (text kept), digest updated."""
    from volcal.session.provenance import measured_ids, readings_digest

    old = toml_path.read_text(encoding="utf-8")
    doc: dict[str, Any] = tomllib.loads(old)
    tail = toml_dumps({"measurements": [m.to_toml() for m in added]})
    text = old + ("" if old.endswith("\n") else "\n") + "\n" + tail
    simulated = s.provenance.get("readings") == "simulated" and not measured_ids(s)
    try:
        ok = tomllib.loads(text)["measurements"] == [*doc["measurements"],
                                                      *(m.to_toml() for m in added)]
    except (tomllib.TOMLDecodeError, KeyError):
        ok = False
    if not ok:  # e.g. measurements written as an inline array: rewrite the document
        doc["measurements"] = [*doc["measurements"], *(m.to_toml() for m in added)]
        text = toml_dumps(doc)
    if simulated:
        both = Session(s.name, s.chain, s.travel, [*s.measurements, *s.unmeasured, *added])
        old_digest, new_digest = s.provenance["readings_sha256"], readings_digest(both)
        if text.count(old_digest) == 1:
            text = text.replace(old_digest, new_digest)
        else:
            doc = tomllib.loads(text)
            doc["provenance"]["readings_sha256"] = new_digest
            text = toml_dumps(doc)
    return text
