"""Step ``plan``: the tests of a machine, as a session skeleton (``volcal plan``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from numpy.typing import ArrayLike

from volcal import defaults as D
from volcal.errors import ParameterError, VolcalInputError
from volcal.steps import _checks

if TYPE_CHECKING:
    from volcal.plan.extend import AddResult
    from volcal.session.format import Session
    from volcal.session.rotary import RotaryAxis

__all__ = ["Added", "Planned", "add", "plan"]

MULTILATERATION_KEYS = ("grid", "n_stations", "stations", "tool_offsets", "station_u_mm")
"""The keys of ``multilateration=``."""


@dataclass(frozen=True)
class Planned:
    """What :func:`plan` planned (and wrote).

    Attributes
    ----------
    session : Session
        The planned session (no readings).
    n_readings : int
        Planned readings over every measurement.
    output : Path or None
        The session folder written (``output=``), or None.
    backup : Path or None
        With ``replace=True`` over an existing session: the folder keeping its old files.
    n_backed_up : int
        Measurement files kept in ``backup``.
    """

    session: Session
    n_readings: int
    output: Path | None = None
    backup: Path | None = None
    n_backed_up: int = 0


@dataclass(frozen=True)
class Added:
    """What :func:`add` appended to an existing session.

    Attributes
    ----------
    folder : Path
        The session folder.
    result : AddResult
        The added measurements (``.added``), the count before (``.n_before``) and the ids
        renamed because they were taken (``.renamed``).
    n_readings : int
        Planned readings of the added measurements.
    """

    folder: Path
    result: AddResult
    n_readings: int


def multilateration_layout(multilateration: Mapping[str, object] | None) -> dict[str, object]:
    """The multilateration layout: the keys given over the defaults (``volcal.defaults``).

    Parameters
    ----------
    multilateration : mapping, optional
        Keys of :data:`MULTILATERATION_KEYS`.

    Returns
    -------
    dict
    """
    out: dict[str, object] = {"grid": D.ML_GRID, "n_stations": D.ML_STATIONS,
                              "tool_offsets": D.ML_TOOL_OFFSETS_MM}
    for key in multilateration or {}:
        if key not in MULTILATERATION_KEYS:
            import difflib

            close = difflib.get_close_matches(key, MULTILATERATION_KEYS, n=1, cutoff=0.5)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ParameterError(f"{{multilateration}}: unknown key {key!r}{hint}; valid "
                                 f"keys: {', '.join(MULTILATERATION_KEYS)}")
    out.update(multilateration or {})
    if "stations" in out:  # pivots given: not a count of default stations
        out.pop("n_stations", None)
    return out


def rotary_options(targets: str | Sequence[float] | None,
                   rotary_axes: str | Sequence[RotaryAxis] | None) -> dict[str, Any]:
    """The rotary plan's options from the step's keywords (text or values).

    Parameters
    ----------
    targets : str or sequence of float, optional
        Target angles [deg].
    rotary_axes : str or sequence of RotaryAxis, optional
        ``'c:0:360:modulo,...'`` or the axes.

    Returns
    -------
    dict
        ``targets_deg`` and ``axes`` where given.
    """
    from volcal.plan.rotary import rotary_axis_spec

    out: dict[str, Any] = {}
    if targets is not None:
        if isinstance(targets, str):
            try:
                vals = [float(v) for v in targets.replace(";", ",").split(",") if v.strip()]
            except ValueError:
                raise ParameterError(f"{{targets=}}{targets!r}: expected angles in deg, "
                                     "comma-separated") from None
        else:
            vals = [float(v) for v in targets]
        out["targets_deg"] = vals
    if rotary_axes is not None and isinstance(rotary_axes, str):
        try:
            out["axes"] = rotary_axis_spec(rotary_axes)
        except VolcalInputError as exc:
            text = str(exc).replace("{", "{{").replace("}", "}}")
            raise ParameterError(f"{{rotary_axes}}: {text}") from None
    elif rotary_axes is not None:
        out["axes"] = list(rotary_axes)
    return out


def plan(travel: ArrayLike, *, chain: str = D.CHAIN, steps: int = D.PLAN_STEPS,
         tests: str | Sequence[str] = D.PLAN_TESTS, runs: int = D.PLAN_RUNS,
         name: str = D.PLAN_NAME, step_orders: str | Sequence[str] = D.PLAN_STEP_ORDERS,
         tool_offset: ArrayLike = D.PLAN_TOOL_OFFSET_MM, iso_spacing: bool = True,
         step_target: str = D.PLAN_STEP_TARGET, overrun_mm: float = D.PROG_OVERRUN_MM,
         abbe_offset_mm: float = D.PLAN_ABBE_OFFSET_MM,
         multilateration: Mapping[str, object] | None = None,
         targets: str | Sequence[float] | None = None,
         rotary_axes: str | Sequence[RotaryAxis] | None = None,
         output: str | Path | None = None, replace: bool = False) -> Planned:
    """Plan the tests of a machine (no readings yet); write them with ``output``.

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    chain : str
        Kinematic chain code, workpiece to tool (``'XYFZ'``...).
    steps : int
        Increments per test.
    tests : sequence of str, or str
        ``'step-diagonal'``, ``'diagonal'``, ``'linear'``, ``'face-diagonal'``,
        ``'face-step-diagonal'``, ``'multilateration'``, ``'direct'``; one axis or plane:
        ``'linear:x'``...
    runs : int
        Bidirectional runs per linear test (ISO 230-2).
    name : str
        Machine name.
    step_orders : sequence of str, or str
        Axis orders of the step diagonals (``'xyz'``, ``'yxz'``...).
    tool_offset : array_like, shape (3,)
        Target point on the tool [mm].
    iso_spacing : bool
        Unequally spaced linear-test targets (ISO 230-2:2014, 5.2).
    step_target : str
        ``'flat_mirror'``, ``'retroreflector'`` or ``'retroreflector_mirror'``.
    overrun_mm : float
        Linear-test targets kept this far inside the travel [mm].
    abbe_offset_mm : float
        Target offset from the spindle of the Abbe lines [mm].
    multilateration : mapping, optional
        ``grid``, ``n_stations`` or ``stations`` [mm], ``tool_offsets`` [mm],
        ``station_u_mm`` of a multilateration plan; the keys not given take
        :data:`volcal.defaults.ML_GRID`, ``ML_STATIONS``, ``ML_TOOL_OFFSETS_MM``.
    targets : str or sequence of float, optional
        Target angles of the rotary tests [deg] (``'0,47.3,133.9,360'``); default the ISO
        230-2 spread over the axis' range (:mod:`volcal.plan.rotary`).
    rotary_axes : str or sequence of RotaryAxis, optional
        The machine's rotary axes, ``'c:0:360:modulo,a:-120:30:limited'`` (name:min:max
        [deg]), written to ``[[machine.rotary_axes]]``; an axis of ``rotary:a`` not given
        is a full circle 0..360 deg.
    output : str or Path, optional
        Session folder to write: a new or empty folder, or an existing session with
        ``replace``.
    replace : bool
        Replace the session in ``output``; its old files are moved to
        ``backup/<UTC time>/``.

    Returns
    -------
    Planned
    """
    from volcal.plan.planner import plan_session

    t = _checks.travel(travel)
    steps, runs = _checks.whole("steps", steps), _checks.whole("runs", runs)
    overrun_mm = _checks.number("overrun_mm", overrun_mm, 0.0)
    abbe_offset_mm = _checks.number("abbe_offset_mm", abbe_offset_mm, 0.0, strict=True)
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f"{{name=}}{name!r}: expected the machine's name (it identifies "
                             "the machine in reports and the history)")
    ml = multilateration_layout(multilateration)
    old = None
    if output is not None:
        from volcal.io.paths import check_output_folder
        from volcal.plan.extend import existing_session, refusal

        output = Path(output)
        old = existing_session(output) if output.is_dir() else None
        if old is None:
            check_output_folder(output, "session")
        elif not replace:
            raise refusal(old, str(output))
    elif replace:
        raise ParameterError("{replace} belongs to {output} (a new session)")
    s = plan_session(t, chain, steps, _checks.names("tests", tests), runs,
                     _checks.names("step_orders", step_orders),
                     _checks.vector("tool_offset", tool_offset), name,
                     step_target=step_target, iso_spacing=iso_spacing,
                     linear_margin_mm=overrun_mm, abbe_tool_offset_mm=abbe_offset_mm,
                     multilateration=ml, rotary=rotary_options(targets, rotary_axes))
    n = sum(m.n for m in s.measurements)
    if output is None:
        return Planned(s, n)
    if old is None:
        from volcal.session.format import write_session

        write_session(s, output, keep_existing=True)
        return Planned(s, n, output)
    from volcal.plan.extend import replace_session

    rel = replace_session(s, output, old)
    return Planned(s, n, output, output / rel, len(old.files))


def add(folder: str | Path, *, steps: int = D.PLAN_STEPS,
        tests: str | Sequence[str] = D.PLAN_TESTS, runs: int = D.PLAN_RUNS,
        step_orders: str | Sequence[str] = D.PLAN_STEP_ORDERS,
        tool_offset: ArrayLike = D.PLAN_TOOL_OFFSET_MM, iso_spacing: bool = True,
        step_target: str = D.PLAN_STEP_TARGET, overrun_mm: float = D.PROG_OVERRUN_MM,
        abbe_offset_mm: float = D.PLAN_ABBE_OFFSET_MM,
        multilateration: Mapping[str, object] | None = None,
        targets: str | Sequence[float] | None = None,
        rotary_axes: str | Sequence[RotaryAxis] | None = None) -> Added:
    """Plan tests on an existing session's machine and append them (``plan --add``).

    Parameters
    ----------
    folder : str or Path
        An existing session folder: its travel, chain and name are used; its
        measurements and readings are untouched.
    steps, tests, runs, step_orders
        As :func:`plan`.
    tool_offset, iso_spacing, step_target
        As :func:`plan` (``tool_offset`` [mm]).
    overrun_mm, abbe_offset_mm, multilateration
        As :func:`plan` ([mm]).
    targets, rotary_axes
        As :func:`plan` ([deg]); the rotary axes default to the session's
        ``[[machine.rotary_axes]]``.

    Returns
    -------
    Added
    """
    from volcal.plan.extend import add_planned_tests

    r = add_planned_tests(folder, _checks.names("tests", tests), _checks.whole("steps", steps),
                          _checks.whole("runs", runs),
                          _checks.names("step_orders", step_orders),
                          _checks.vector("tool_offset", tool_offset), step_target,
                          iso_spacing=iso_spacing, linear_margin_mm=overrun_mm,
                          abbe_tool_offset_mm=abbe_offset_mm,
                          multilateration=multilateration_layout(multilateration),
                          rotary=rotary_options(targets, rotary_axes))
    return Added(Path(folder), r, sum(m.n for m in r.added))
