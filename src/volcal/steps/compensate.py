"""Step ``compensate``: controller tables of an error model (``volcal compensate``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from numpy.typing import ArrayLike

from volcal import defaults as D
from volcal.errors import ParameterError
from volcal.io.sniff import is_model_file
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.compensate.linecheck import LineCheck
    from volcal.compensate.rotary.check import RotaryCheck
    from volcal.identify.result import IdentificationResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.session.format import Session
    from volcal.session.identity import MachineIdentity

__all__ = ["Compensated", "compensate", "sign_note"]


@dataclass(frozen=True)
class Compensated:
    """What :func:`compensate` wrote and checked.

    Attributes
    ----------
    files : tuple of str
        The files written (in ``output``).
    output : Path
        The compensation folder.
    format : str
        The format, lower case.
    sign : str
        The sign of the tables written (``'error'`` or ``'correction'``).
    convention : bool
        ``sign`` is the controller's own (no override given).
    spacing : float
        Distance between points [mm].
    sign_note : str or None
        A sign override of the controller's convention, as a
        :class:`~volcal.errors.ParameterError` template (``{sign=}``): each face
        spells it.
    session : Session or None
        The session of ``session=`` (its notes and warnings).
    directional_notes : tuple of str
        How the forward and reverse tables came from the session's linear tests.
    no_bidirectional : bool
        The session has no bidirectional linear test: forward = reverse.
    forced : tuple of str
        What ``force=True`` let through (the model or table of another session).
    line_checks : tuple of LineCheck
        ISO 230-2 A of every measured linear line before and after the tables written.
    not_checked : tuple of str
        The lines not evaluated, with the reason.
    volumetric_before_um, volumetric_after_um : float or None
        Largest modelled volumetric error over 11³ points of the travel before and after
        the tables [um] (with ``session``).
    moved : str or None
        With ``replace``: where the files volcal did not write were moved
        (``backup/<UTC time>``, relative to ``output``).
    rotary_checks : tuple of RotaryCheck
        ISO 230-2 A of every rotary test before and after its rotary table [urad]
        (:mod:`volcal.compensate.rotary.check`).
    rotary_not_written : tuple of str
        Rotary tests without a table or not evaluated, with the reason.
    rotary_only : bool
        No linear model was given (``model=None``): only the session's rotary tables were
        written (:func:`volcal.compensate.formats.write_rotary_compensation`).
    """

    files: tuple[str, ...]
    output: Path
    format: str
    sign: str
    convention: bool
    spacing: float
    sign_note: str | None = None
    session: Session | None = None
    directional_notes: tuple[str, ...] = ()
    no_bidirectional: bool = False
    forced: tuple[str, ...] = ()
    line_checks: tuple[LineCheck, ...] = ()
    not_checked: tuple[str, ...] = ()
    volumetric_before_um: float | None = None
    volumetric_after_um: float | None = None
    moved: str | None = None
    rotary_checks: tuple[RotaryCheck, ...] = ()
    rotary_not_written: tuple[str, ...] = ()
    rotary_only: bool = False


def sign_note(format: str, sign: str | None) -> str | None:
    """Check the format and the sign; the note of a sign other than the controller's.

    Parameters
    ----------
    format : str
        The format (any case).
    sign : str or None
        ``'error'``, ``'correction'`` or None (the controller's own convention).

    Returns
    -------
    str or None
        The note as a :class:`~volcal.errors.ParameterError` template (``{sign=}``), or
        None when the sign is the controller's.

    Raises
    ------
    ParameterError
        An unknown format or sign.
    """
    from volcal.compensate.formats import FORMAT_INFO
    from volcal.compensate.tables import sign_factor

    fmt = str(format).lower()
    if fmt not in FORMAT_INFO:
        raise ParameterError(f"unknown format {format!r}: expected one of "
                             f"{', '.join(FORMAT_INFO)}")
    info = FORMAT_INFO[fmt]
    if sign is None:
        return None
    sign_factor(sign)
    if sign == info.sign:
        return None
    return (f"{{sign=}}{sign} overrides the {fmt} convention '{info.sign}' "
            f"({info.sign_source}); a table in the wrong sign doubles the error")


def compensate(model: str | Path | IdentificationResult | MachineErrors | None, *,
               format: str, output: str | Path, sign: str | None = D.COMP_SIGN,
               session: str | Path | Session | None = None, force: bool = False,
               spacing: float = D.COMP_SPACING_MM, max_points: int | None = None,
               reference_mm: ArrayLike | None = None, unit_um: float = D.COMP_UNIT_UM,
               magnification: int = D.COMP_MAGNIFICATION,
               max_increment: int = D.COMP_MAX_INCREMENT,
               fanuc_series: str = D.COMP_FANUC_SERIES,
               linuxcnc_type: int = D.COMP_LINUXCNC_TYPE,
               squareness: bool = D.COMP_SQUARENESS,
               rotary_spacing: float = D.COMP_ROTARY_SPACING_DEG,
               tool_offset: ArrayLike = D.TOOL_OFFSET_MM, replace: bool = False,
               machine: MachineIdentity | None = None,
               on_moved: Callable[[str], None] | None = None) -> Compensated:
    """Write compensation tables of a model for a controller, resampled onto its grid.

    Parameters
    ----------
    model : str, Path, IdentificationResult, MachineErrors or None
        ``MODEL.json`` (identified) or an error table ``.csv``, or a model in memory.
        None (no linear model: a machine or a calibration with rotary tests only): with
        ``session``, only the session's rotary tables are written, and their ISO 230-2 A
        before and after checked (``rotary_only``).
    format : str
        ``'fanuc'``, ``'siemens'``, ``'heidenhain'``, ``'linuxcnc'``, ``'csv'``, ``'isg'``
        or ``'grid'``.
    output : str or Path
        Folder for the tables: new, empty or written by this step before.
    sign : str, optional
        Override of the controller's own sign convention: ``'error'`` (actual -
        commanded) or ``'correction'`` (= -error). A table in the wrong sign doubles the
        error.
    session : str, Path or Session, optional
        Session folder (or a session read): its bidirectional ISO 230-2 linear tests give
        forward and reverse tables; a model file must have been identified from it; every
        measured linear line is checked before and after the tables; each rotary test
        gives its rotary table, checked the same way.
    force : bool
        With ``session``: use a model or table of another session.
    spacing : float
        Distance between points [mm].
    max_points : int, optional
        Controller's point limit.
    reference_mm : array_like, shape (3,), optional
        Fanuc reference position [mm] (default: start of travel).
    unit_um : float
        Fanuc detection unit [um].
    magnification : int
        Fanuc magnification (3623).
    max_increment : int
        Fanuc largest value per point.
    fanuc_series : str
        ``'30i'`` or ``'16i'``.
    linuxcnc_type : int
        LinuxCNC ``COMP_FILE_TYPE``, 1 (trims) or 0.
    squareness : bool
        Siemens CEC: add squareness terms.
    rotary_spacing : float
        With ``session``: distance between the points of the rotary tests' Siemens and
        Fanuc tables [deg]; it divides 360 on a full-circle axis (Fanuc: and is a whole
        number of detection units).
    tool_offset : array_like, shape (3,)
        3-D grid: target on the tool [mm].
    replace : bool
        The output folder holds files its manifest does not list (volcal did not write
        them): move them into ``backup/<UTC time>/`` instead of refusing.
    machine : MachineIdentity, optional
        The machine the tables are for (Python: the calibration's session); default the
        session's, else what the model records.
    on_moved : callable, optional
        Called at once with ``backup/<UTC time>`` when ``replace`` moved files there
        (the command line says so before anything else can fail).

    Returns
    -------
    Compensated
    """
    from volcal.compensate.formats import MANIFEST, CompensationOptions, write_compensation
    from volcal.io.folders import manifest_files

    note = sign_note(format, sign)
    fmt = str(format).lower()
    if model is None and session is None:
        raise ParameterError("no model given: the tables of the linear axes need one "
                             "(MODEL.json or an error table); a session with rotary tests "
                             "gives its rotary tables without a model")
    if session is None and isinstance(model, str | Path) and (Path(model) /
                                                               "session.toml").is_file():
        raise ParameterError("a session folder, not a model: give a session as {session=}"
                             f"{model} (its rotary tests' tables, its "
                             "bidirectional linear tests' reversal), and for the linear axes' "
                             f"tables the model identified from it (volcal identify {model} "
                             "-o model.json)", Path(model) / "session.toml")
    rotary_options = {"sign": sign, "linuxcnc_type": linuxcnc_type, "fanuc_series": fanuc_series,
                      "magnification": magnification, "max_increment": max_increment,
                      "spacing_deg": _checks.number("rotary_spacing", rotary_spacing, 0.0,
                                                    strict=True, unit="deg")}
    ref = None if reference_mm is None else tuple(_checks.vector("reference_mm", reference_mm))
    moved = _checks.output_folder(output, "compensation", lambda p: (p / MANIFEST).is_file(),
                                  manifest_files(MANIFEST, "files"), replace)
    if moved is not None and on_moved is not None:
        on_moved(moved)
    directional, sess, none_bidir = None, None, False
    dnotes: tuple[str, ...] = ()
    if session is not None:
        from volcal.compensate.bidirectional import directional_from_session
        from volcal.session.format import Session, read_session

        # the readings as identify and evaluate read them: missed captures skipped
        sess = session if isinstance(session, Session) else read_session(session)
        if model is None:
            return _rotary_only(sess, fmt, output, note, moved, machine, float(spacing),
                                rotary_options)
        directional = directional_from_session(sess)
        dnotes = tuple(directional.notes())
        if not directional.source:
            none_bidir, directional = True, None
    opts = CompensationOptions(sign, spacing, max_points, ref, unit_um, magnification,
                               max_increment, squareness,
                               tuple(_checks.vector("tool_offset", tool_offset)),
                               fanuc_series, linuxcnc_type, directional)
    forced: list[str] = []
    if session is not None and isinstance(model, str | Path):  # the model must belong to it
        from volcal.identify.modelfile import check_model_file_session

        folder = session if isinstance(session, str | Path) else None if sess is None \
            else sess.path
        forced += check_model_file_session(model, folder, force)
    errors, label = _errors(model)
    if machine is None:
        machine = _identity(model, errors, sess, force, forced)
    rotary, rot_skipped = _rotary(sess, fmt, rotary_options)
    files = write_compensation(errors, fmt, output, opts, label, machine, rotary)
    out = Compensated(tuple(files), Path(output), fmt, opts.sign_for(fmt), sign is None,
                      float(spacing), note, sess, dnotes, none_bidir, tuple(forced),
                      moved=moved, rotary_not_written=tuple(rot_skipped))
    if sess is None:
        return out
    return _checked(out, sess, errors, [] if rotary is None else rotary[1])


def _rotary_only(sess: Session, fmt: str, output: str | Path, note: str | None,
                 moved: str | None, machine: MachineIdentity | None, spacing: float,
                 rotary_options: dict[str, Any]) -> Compensated:
    """The rotary tables of the session alone, checked: no linear model (``model=None``)."""
    from volcal.compensate.formats import write_rotary_compensation
    from volcal.compensate.rotary import ROTARY_FORMATS
    from volcal.compensate.rotary.check import check_rotary
    from volcal.session.identity import MachineIdentity

    if not any(m.kind == "rotary" for m in sess.measurements):
        raise ParameterError("no model given and the session has no rotary test: the "
                             "tables of the linear axes need a model (volcal identify)",
                             sess.path)
    rotary, skipped = _rotary(sess, fmt, rotary_options)
    if rotary is None:
        raise ParameterError(f"no model given, and no rotary table in the {fmt} format "
                             f"({'; '.join(skipped) or 'no rotary test'})", sess.path)
    sign = rotary_options["sign"]
    rsign = sign if sign is not None else ROTARY_FORMATS[fmt]
    files = write_rotary_compensation(fmt, output, rsign, machine or MachineIdentity.of(sess),
                                      rotary)
    checks, rskipped = check_rotary(sess, output, fmt, rotary[1])
    return Compensated(tuple(files), Path(output), fmt, rsign, sign is None, spacing, note,
                       sess, moved=moved, rotary_checks=tuple(checks),
                       rotary_not_written=tuple(skipped) + tuple(rskipped), rotary_only=True)


def _rotary(sess: Session | None, fmt: str, options: dict[str, Any]
            ) -> tuple[tuple[dict[str, str], list[dict[str, Any]]] | None, list[str]]:
    """The rotary tables of the session's rotary tests (none without a session).

    ``options`` are :class:`volcal.compensate.rotary.RotaryOptions`' fields.
    """
    if sess is None or not any(m.kind == "rotary" for m in sess.measurements):
        return None, []
    from volcal.compensate.rotary import RotaryOptions, rotary_profiles, rotary_tables

    files, entries, skipped = rotary_tables(rotary_profiles(sess), fmt, RotaryOptions(**options))
    return ((files, entries) if files else None), skipped


def _errors(model: Any) -> tuple[MachineErrors, str]:
    """The error model and the name the manifest records for it."""
    if isinstance(model, str | Path):
        from volcal.compensate.source import load_errors

        return load_errors(model), Path(model).name
    return getattr(model, "errors", model), "model"


def _identity(model: Any, errors: MachineErrors, sess: Session | None, force: bool,
              forced: list[str]) -> MachineIdentity:
    """The machine the tables are for: the session's identity, else what the model records.

    An error table given with a session must have the session's chain and travel (its
    name may differ: a simulated truth is called "virtual ..."); ``force`` overrides.
    """
    from volcal.compensate.manifest import identity_of_errors, model_identity
    from volcal.session.identity import MachineIdentity

    if sess is None:
        if isinstance(model, str | Path):
            return model_identity(model, errors)
        return identity_of_errors(errors)
    me = MachineIdentity.of(sess)
    if isinstance(model, str | Path) and not is_model_file(model):
        why = _checks.table_machine(errors, sess)
        if why is not None:
            text = (f"the error table is not of this session's machine ({why}); the tables "
                    f"would be labelled {me.label()}")
            if not force:
                raise ParameterError(text + "; give {force=True} to write them anyway", model)
            forced.append(text)
    return me


def _checked(out: Compensated, sess: Session, errors: MachineErrors,
             rotary: list[dict[str, Any]] | None = None) -> Compensated:
    """The result with the linear lines, rotary tests and volumetric error checked."""
    from dataclasses import replace

    from volcal.compensate.linecheck import check_lines, volumetric_before_after
    from volcal.compensate.readback import read_written_tables
    from volcal.compensate.rotary.check import check_rotary

    written = read_written_tables(out.output, travel=sess.travel)
    checks, skipped = check_lines(sess, written)
    before, after = volumetric_before_after(errors, written)
    rchecks, rskipped = check_rotary(sess, out.output, out.format, rotary or [])
    return replace(out, line_checks=tuple(checks), not_checked=tuple(skipped),
                   volumetric_before_um=float(before), volumetric_after_um=float(after),
                   rotary_checks=tuple(rchecks),
                   rotary_not_written=out.rotary_not_written + tuple(rskipped))
