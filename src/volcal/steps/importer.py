"""Step ``import``: a laser's export -> a measurement of a session (``volcal import``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from numpy.typing import ArrayLike

from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.importer.laser_csv import ImportResult

__all__ = ["Imported", "import_", "is_rtx"]


@dataclass(frozen=True)
class Imported:
    """What :func:`import_` read and wrote.

    Attributes
    ----------
    result : ImportResult
        The measurement, the session folder, whether it was created, the notes on units
        and columns (``.notes``), the header fields read (``.header``) and not read
        (``.header_notes``).
    what : str
        The measurement in words (``'lx1 (X)'``, ``'linear linear-x1'``).
    warnings : tuple of str
        Plausibility warnings of the imported measurement, read back with its session.
    """

    result: ImportResult
    what: str
    warnings: tuple[str, ...] = ()


def is_rtx(path: str | Path) -> bool:
    """A Renishaw dynamic capture: ``.rtx`` suffix, or a file starting with ``HEADER::``.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    bool
    """
    path = Path(path)
    if path.suffix.lower() == ".rtx":
        return True
    try:
        with path.open("rb") as f:
            return f.read(10) == b"HEADER::\r\n"
    except OSError:
        return False


def import_(csv_file: str | Path, *, session: str | Path | None = None,
            map: str | Mapping[str, str] | None = None, axis: str | None = None,
            id: str | None = None, measurement: str | None = None,
            line_mm: ArrayLike = D.TOOL_OFFSET_MM, units: str = D.IMPORT_UNITS,
            deviation_units: str = D.IMPORT_DEVIATION_UNITS, optics: str = D.IMPORT_OPTICS,
            tool_offset: ArrayLike = D.TOOL_OFFSET_MM, travel: ArrayLike | None = None,
            chain: str = D.IMPORT_CHAIN, name: str = D.IMPORT_NAME, replace: bool = False,
            sign: str = D.IMPORT_SIGN, slope_removed: bool = False,
            dwell_s: float = D.IMPORT_DWELL_S) -> Imported:
    """Add a measurement from a laser's export to a session folder (atomically).

    Either a new linear measurement (``axis`` and ``id``; the session is created with
    ``travel`` if it does not exist) or the readings of a planned measurement
    (``measurement``); a Renishaw dynamic capture (``.rtx``) fills a planned measurement.

    Parameters
    ----------
    csv_file : str or Path
        The laser's CSV export, or a Renishaw dynamic capture (``.rtx``).
    session : str or Path
        Session folder (required; created for a new linear measurement).
    map : str or dict
        Columns of a CSV export, ``'target=Pos,deviation=Error'`` or ``{'target':
        'Pos', 'deviation': 'Error'}`` (docs/formats.md); not for ``.rtx``.
    axis : str, optional
        Measured axis ``'X'``, ``'Y'`` or ``'Z'`` of a new linear measurement, or ``'A'``,
        ``'B'``, ``'C'`` of a new rotary one (targets in deg, errors in an angle unit).
    id : str, optional
        Id of the new measurement.
    measurement : str, optional
        Id of a planned measurement to fill.
    line_mm : array_like, shape (3,)
        Machine position of the line [mm].
    units, deviation_units : str
        Units of the target/reading and deviation columns (``'auto'``: the header).
    optics : str
        ``'retroreflector'`` or ``'flat_mirror'``.
    tool_offset : array_like, shape (3,)
        Target on the tool [mm].
    travel : array_like, shape (3, 2), optional
        Travel of a NEW session [mm].
    chain, name : str
        Chain and machine name of a new session.
    replace : bool
        Replace a measurement with this id (or the readings of ``measurement``).
    sign : str
        Direct optics: ``'+'`` (the tool side relative to the workpiece side, volcal's
        sign) or ``'-'``.
    slope_removed : bool
        Straightness: the instrument took the slope out.
    dwell_s : float
        ``.rtx``: the part program's dwell at each target [s].

    Returns
    -------
    Imported
    """
    from volcal.importer.laser_csv import import_csv, parse_mapping
    from volcal.importer.optics import parse_sign

    if session is None:
        raise ParameterError("give {session=}FOLDER (the session to add the readings to)")
    parse_sign(sign)  # checked whatever the file, as dwell_s (used by a .rtx only)
    _checks.number("dwell_s", dwell_s, 0.0, strict=True, unit="s")
    if measurement is not None and _planned_kind(session, measurement) == "probe_sphere":
        from volcal.importer.probe_log import import_probe_log

        r = import_probe_log(csv_file, session, measurement, replace)
        return _imported(r, f"{r.measurement.kind} {r.measurement.id}")
    if is_rtx(csv_file):
        from volcal.importer.rtx_import import import_rtx

        if measurement is None or axis is not None or id is not None:
            raise ParameterError("a dynamic capture (.rtx) fills a planned measurement: give "
                                 "{measurement=}ID (from volcal plan), without {axis} and "
                                 "{id}", csv_file)
        if map is not None:
            raise ParameterError("{map} names CSV columns; a dynamic capture (.rtx) has one "
                                 "quantity: leave it out", csv_file)
        r = import_rtx(csv_file, session, measurement, units, deviation_units, replace,
                       parse_sign(sign), slope_removed, dwell_s)
        return _imported(r, f"{r.measurement.kind} {r.measurement.id}")
    if map is None:
        raise ParameterError("{map} is needed for a CSV export: name its columns, e.g. "
                             "{map=}target=Position,deviation=Error", csv_file)
    text = map if isinstance(map, str) else ",".join(f"{k}={v}" for k, v in map.items())
    mapping = parse_mapping(text)
    if measurement is not None:
        if axis is not None or id is not None:
            raise ParameterError("{measurement} fills a planned measurement: leave out "
                                 "{axis} and {id}")
        from volcal.importer.planned import import_planned

        r = import_planned(csv_file, mapping, session, measurement, units, deviation_units,
                           replace, parse_sign(sign), slope_removed)
        return _imported(r, f"{r.measurement.kind} {r.measurement.id}")
    if axis is None or id is None:
        raise ParameterError("give {axis} and {id} (a new linear measurement) or "
                             "{measurement=}ID (a planned one)")
    if axis.lower() in ("a", "b", "c"):  # a rotary axis: angles (volcal.importer.rotary)
        from volcal.importer.rotary import import_rotary_new

        r = import_rotary_new(csv_file, mapping, axis, session, id, units, deviation_units,
                              travel=None if travel is None else _checks.travel(travel),
                              chain=chain, name=name, replace=replace, sign=parse_sign(sign))
        return _imported(r, f"{r.measurement.id} ({axis.upper()})")
    if not Path(session).exists():
        from volcal.io.paths import check_output_folder

        check_output_folder(session, "session")
    r = import_csv(csv_file, mapping, axis, _checks.vector("line_mm", line_mm), session, id,
                   units, deviation_units, optics, _checks.vector("tool_offset", tool_offset),
                   None if travel is None else _checks.travel(travel), chain, name, replace)
    return _imported(r, f"{r.measurement.id} ({axis.upper()})")


def _planned_kind(session: str | Path, mid: str) -> str | None:
    """The kind of measurement ``mid`` of a session, None if there is none (or no session)."""
    from volcal.session.format import read_session

    if not (Path(session) / "session.toml").is_file():
        return None
    try:
        s = read_session(session, require_deviation=False)
    except VolcalInputError:
        return None  # the importer of the file's own kind says what is wrong
    return next((m.kind for m in s.measurements + s.unmeasured if m.id == mid), None)


def _imported(r: ImportResult, what: str) -> Imported:
    """The result with the plausibility warnings of the imported measurement."""
    from volcal.errors import VolcalInputError
    from volcal.session.format import read_session

    try:
        s = read_session(r.session)
    except VolcalInputError:  # the import itself is done; the session's other tests speak later
        return Imported(r, what)
    return Imported(r, what, tuple(w for w in s.warnings if w.startswith(f"{r.measurement.id}:")))
