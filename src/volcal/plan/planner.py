"""Plan a calibration session: the seeds' test set as a session skeleton.

The default plan is the seeds' full test set: 4 body step diagonals with a flat mirror
(Wang & Liotto, seed 000, section 4), the 4 body diagonals with a retroreflector
(ISO 230-6, section 3) and 3 linear lines per axis at different Abbe offsets
(seed 000 section 6, seed 001), each line with bidirectional runs as ISO 230-2 asks:
unequally spaced targets (ISO 230-2:2014, 5.2) kept 5 mm inside both ends of the travel
so that the part programs' overrun before each reversal (5.3) has room. ``plan``,
``program`` and ``evaluate`` therefore agree without options.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from volcal.errors import ParameterError, VolcalInputError
from volcal.model.chain import parse_chain
from volcal.model.names import AXES
from volcal.plan.geometry import (
    BODY_DIAGONALS,
    FACE_DIAGONALS,
    FACE_PLANES,
    TestGeometry,
    diagonal_test,
    iso_targets,
    linear_test,
    step_diagonal_test,
)
from volcal.plan.optics import DIRECT_SELECTORS
from volcal.session.format import Measurement, Session
from volcal.session.kinds import kind_of

TEST_NAMES: tuple[str, ...] = (
    "step-diagonal", "diagonal", "linear", "face-diagonal", "face-step-diagonal",
    "multilateration", "direct",
)
QUALIFIED: dict[str, tuple[str, ...]] = {
    "linear": ("x", "y", "z"),
    "face-diagonal": FACE_PLANES,
    "face-step-diagonal": FACE_PLANES,
    "direct": DIRECT_SELECTORS,
    "rotary": ("a", "b", "c"),
    "probe_sphere": ("ca", "cb"),
    "r_test": ("ca", "cb"),
}
"""Tests that may be narrowed to one axis or plane: ``linear:x`` (the 3 lines of X),
``face-diagonal:xy``, ``face-step-diagonal:yz``; ``direct:x`` (the direct optics of X),
``direct:level-x`` (a level on X), ``direct:roll-z`` (Z's straightness at two tool
offsets in one reference group); ``rotary:c`` (the C axis' angular positioning)."""

__all__ = ["DEFAULT_OVERRUN_MM", "QUALIFIED", "TEST_NAMES", "PlanOptions", "abbe_lines",
           "plan_session", "plan_test_names", "split_test"]

DEFAULT_OVERRUN_MM = 5.0
"""Room left at both ends of every linear test for the ISO 230-2 overrun [mm]; equal to
the default ``overrun_mm`` of :class:`volcal.program.ProgramOptions`."""


def abbe_lines(axis: int, travel: np.ndarray, chain: str = "XYFZ",
               tool_offset_mm: float = 150.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """Three linear lines for one axis: a reference line, then an Abbe offset in each other axis.

    An offset only gives a lever arm to the axis' angular errors where it moves the target
    relative to that axis' carriage (``docs/conventions.md``): along an axis read after the
    measured one in the chain, the line is moved to the other end of that axis' travel; along
    an axis read before it (moving it does not change the lever arm), the target is mounted
    off the tool axis instead (a tool offset of ``tool_offset_mm``).

    Parameters
    ----------
    axis : int
        Measured axis.
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    chain : str
        Chain code.
    tool_offset_mm : float
        Target offset from the tool reference point used where a machine move cannot
        create the lever arm [mm].

    Returns
    -------
    list of (point, tool offset)
        Point on each line [mm] (the measured axis' coordinate is irrelevant) and the tool
        offset of the target [mm].
    """
    order = parse_chain(chain).order
    downstream = set(order[order.index(axis) + 1:])
    base = travel[:, 0].copy()
    out = [(base.copy(), np.zeros(3))]
    for j in (k for k in range(3) if k != axis):
        p = base.copy()
        t = np.zeros(3)
        if j in downstream:
            p[j] = travel[j, 1]
        else:
            t[j] = tool_offset_mm
        out.append((p, t))
    return out


def _measurement(mid: str, kind: str, target: str, g: TestGeometry, offset, notes: str
                 ) -> Measurement:
    cols: dict[str, NDArray] = {}
    if g.run is not None and kind_of(kind).bidirectional:  # runs of ISO 230-2 tests
        cols["run"] = g.run
    if g.direction is not None:
        cols["direction"] = g.direction
    meta = {k: v for k, v in g.meta.items() if k != "line_mm"}
    if "line_mm" in g.meta:
        meta["line_mm"] = g.meta["line_mm"]
    meta["notes"] = notes
    return Measurement(mid, kind, target, g.positions, None, g.beam_direction, offset,
                       f"{mid}.csv", cols, meta)


def plan_session(travel: ArrayLike, chain: str = "XYFZ", steps: int = 10,
                 tests: Sequence[str] = ("step-diagonal", "diagonal", "linear"),
                 runs: int = 5, step_orders: Sequence[str] = ("xyz",),
                 tool_offset: ArrayLike = (0.0, 0.0, 0.0), name: str = "VMC-1",
                 step_target: str = "flat_mirror", abbe_tool_offset_mm: float = 150.0,
                 iso_spacing: bool = True, linear_margin_mm: float = DEFAULT_OVERRUN_MM,
                 multilateration: dict | None = None, vertical_axis: int = 2,
                 rotary: dict | None = None) -> Session:
    """Plan a session skeleton (commanded poses, deviations empty).

    Parameters
    ----------
    travel : array_like, shape (3, 2)
        Travel limits [mm].
    chain : str
        Chain code.
    steps : int
        Increments per test.
    tests : sequence of str
        Any of ``step-diagonal``, ``diagonal``, ``linear``, ``face-diagonal``,
        ``face-step-diagonal``, ``multilateration``; ``linear:x`` (one axis),
        ``face-diagonal:xy``, ``face-step-diagonal:xy`` (one plane) narrow a test
        (:data:`QUALIFIED`).
    runs : int
        Bidirectional runs of each linear test (ISO 230-2 asks for 5).
    step_orders : sequence of str
        Axis orders of the step diagonals; one set of 4 step diagonals per order.
    tool_offset : array_like, shape (3,)
        Target point relative to the tool reference point [mm].
    name : str
        Machine name.
    step_target : str
        Target of the step diagonals: ``'flat_mirror'`` (Wang), ``'retroreflector'`` or
        ``'retroreflector_mirror'`` (a retroreflector with a return mirror on the workpiece
        side, Soons' second configuration).
    abbe_tool_offset_mm : float
        Target offset used for the Abbe offsets of linear lines that no machine move can
        create (see :func:`abbe_lines`) [mm].
    iso_spacing : bool
        Unequally spaced targets for the linear tests (ISO 230-2:2014, 5.2; the default);
        the three lines of an axis share them. False: the equally spaced step grid.
    linear_margin_mm : float
        Keep the linear-test targets this far inside both ends of the travel, so that the
        ISO 230-2 approach and overrun moves of the part program have room [mm]; default
        the part programs' default overrun (5 mm).
    multilateration : dict, optional
        Keyword arguments of :func:`volcal.plan.multilateration.multilateration_tests`
        (``grid``, ``stations``, ``tool_offsets``, ``station_u_mm``) for the test
        ``multilateration`` (tracking interferometer); default its layout.
    vertical_axis : int
        The machine's vertical axis (0, 1, 2) for the test ``direct``: no level about it;
        its roll is read by its straightness at two tool offsets (``[machine]
        vertical_axis``; ``volcal plan --add`` takes the session's).
    rotary : dict, optional
        Options of the test ``rotary`` (:func:`volcal.plan.rotary.rotary_tests`):
        ``axes`` (list of :class:`volcal.session.rotary.RotaryAxis`, written to
        ``[[machine.rotary_axes]]``), ``targets_deg`` (the targets [deg]), ``mounting``,
        ``eccentricity_mm``, ``target``.

    Returns
    -------
    Session
    """
    t = np.asarray(travel, dtype=float).reshape(3, 2)
    parse_chain(chain)
    tests = [canonical_test(x) for x in tests]
    _check_options(tests, steps, runs, step_target, linear_margin_mm, abbe_tool_offset_mm)
    c = _Plan(t, chain, steps, runs, tuple(step_orders), np.asarray(tool_offset, dtype=float),
              step_target, abbe_tool_offset_mm, iso_spacing, linear_margin_mm,
              multilateration or {}, int(vertical_axis), dict(rotary or {}))
    meas: list[Measurement] = []
    planned_by: dict[str, str] = {}
    for test in tests:
        base, only = split_test(test)
        for m in _planner_of(base).plan(base, c, only):  # the kind that plans it (volcal.kinds)
            _check_once(m.id, test, planned_by.get(m.id))
            planned_by[m.id] = test
            meas.append(m)
    from volcal.plan.rotary import machine_rotary_axes

    axes = machine_rotary_axes(meas, c.rotary.get("axes"))
    return Session(name, chain, t, meas, {"rotary_axes": axes} if axes else {})


def _check_once(mid: str, test: str, earlier: str | None) -> None:
    """Refuse a measurement ``mid`` that the test ``earlier`` planned already."""
    if earlier is None:
        return
    if earlier.lower() == test.lower():
        raise ParameterError(f"{{tests}} names {earlier!r} twice: name each test once")
    whole = [t for t in (earlier, test) if ":" not in t]
    raise ParameterError(
        f"{{tests}}: {earlier!r} and {test!r} both plan the measurement {mid!r}: name each "
        "test once" + (f" ({whole[0]!r} alone plans every axis or plane)" if whole else ""))


def _planner_of(test: str):
    """The registered kind that plans the test ``test`` (:attr:`volcal.kinds.Kind.plan_tests`)."""
    from volcal.session.kinds import kinds

    for k in kinds():
        if test in k.plan_tests:
            return k
    raise VolcalInputError(f"unknown test {test!r}: expected any of "
                           f"{', '.join(plan_test_names())}")


def plan_test_names() -> tuple[str, ...]:
    """Every plannable test: :data:`TEST_NAMES` and those of the kinds added since.

    Returns
    -------
    tuple of str
    """
    from volcal.session.kinds import kinds

    extra = [t for k in kinds() for t in k.plan_tests if t not in TEST_NAMES]
    return (*TEST_NAMES, *extra)


def canonical_test(test: str) -> str:
    """A test name as :func:`plan_test_names` spells it.

    Whatever its case and whether its words are joined by ``-`` or ``_``
    (``Probe-Sphere:CA`` -> ``probe_sphere:CA``, ``step_diagonal`` -> ``step-diagonal``);
    a name that matches none is returned as given (refused then by the checks, which list
    the names).

    Parameters
    ----------
    test : str
        A test name, optionally ``:axis`` or ``:plane``.

    Returns
    -------
    str
    """
    base, sep, only = test.strip().partition(":")
    key = base.strip().lower().replace("_", "-")
    for name in plan_test_names():
        if name.replace("_", "-") == key:
            return f"{name}{sep}{only}"
    return test


def split_test(test: str) -> tuple[str, str | None]:
    """Split a test name into the test and its axis or plane (``'linear:x'``).

    Parameters
    ----------
    test : str
        A name of :data:`TEST_NAMES`, optionally ``:axis`` or ``:plane``.

    Returns
    -------
    base : str
        The test.
    only : str or None
        The axis (``'x'``) or plane (``'xy'``), lower case; None for all.

    Raises
    ------
    VolcalInputError
        Unknown test, or a qualifier the test does not take.
    """
    base, sep, only = test.strip().partition(":")
    if base not in plan_test_names():
        raise VolcalInputError(f"unknown test(s) {test}: expected any of "
                               f"{', '.join(plan_test_names())} ({_qualified_help()})")
    if not sep:
        return base, None
    valid = QUALIFIED.get(base, ())
    if only.strip().lower() not in valid:
        what = (f"one of {', '.join(f'{base}:{v}' for v in valid)}" if valid
                else f"'{base}' without ':'")
        raise VolcalInputError(f"unknown test {test!r}: expected {what}")
    return base, only.strip().lower()


def _qualified_help() -> str:
    return ("linear:x|y|z, face-diagonal:xy|yz|xz, face-step-diagonal:xy|yz|xz for one axis or "
            "plane, direct:x|y|z|level-x|level-y|roll-z (one axis' optics, a level, the "
            "vertical axis' roll pair), rotary:a|b|c (one rotary axis), probe_sphere:ca|cb, "
            "r_test:ca|cb (the trunnion's second axis)")


def _check_options(tests: Sequence[str], steps: int, runs: int, step_target: str,
                   linear_margin_mm: float, abbe_tool_offset_mm: float) -> None:
    names = plan_test_names()
    if not tests:
        raise ParameterError(f"{{tests}}: no test given; expected any of {', '.join(names)}")
    unknown = [x for x in tests if x.partition(":")[0] not in names]
    if unknown:
        raise VolcalInputError(f"unknown test(s) {', '.join(unknown)}: expected any of "
                               f"{', '.join(names)} ({_qualified_help()})")
    for x in tests:
        split_test(x)
    if steps < 1 or steps > 10000:
        raise ParameterError(f"{{steps=}}{steps}: expected 1 to 10000 increments per test")
    if runs < 1:
        raise ParameterError(f"{{runs=}}{runs}: expected at least 1 run per linear test")
    from volcal.session.format import TARGETS

    if step_target not in TARGETS:
        raise VolcalInputError(f"unknown step-diagonal target {step_target!r}: expected one of "
                               f"{', '.join(TARGETS)}")
    if not (np.isfinite(linear_margin_mm) and linear_margin_mm >= 0):
        raise VolcalInputError("the linear margin must be a non-negative number of mm")
    if not (np.isfinite(abbe_tool_offset_mm) and abbe_tool_offset_mm > 0):
        raise VolcalInputError("the Abbe target offset must be a positive number of mm")


@dataclass(frozen=True)
class _Plan:
    """The options of :func:`plan_session`, as the test builders read them."""

    t: NDArray[np.float64]
    chain: str
    steps: int
    runs: int
    step_orders: tuple[str, ...]
    off: NDArray[np.float64]
    step_target: str
    abbe_tool_offset_mm: float
    iso_spacing: bool
    linear_margin_mm: float
    multilateration: dict
    vertical: int = 2
    rotary: dict = field(default_factory=dict)


def _step_diagonals(c: _Plan, only: str | None = None) -> list[Measurement]:
    out = []
    for order in c.step_orders:
        suffix = "" if order == "xyz" else f"-{order}"
        for code in BODY_DIAGONALS:
            g = step_diagonal_test(code, c.t, c.steps, order)
            out.append(_measurement(f"step-{code}{suffix}", "step_diagonal", c.step_target, g,
                                    c.off, f"sequential step diagonal {code}, axis order "
                                    f"{order}, {c.step_target.replace('_', ' ')} on the tool"))
    return out


def _diagonals(c: _Plan, only: str | None = None) -> list[Measurement]:
    return [_measurement(f"diag-{code}", "diagonal", "retroreflector",
                         diagonal_test(code, c.t, c.steps), c.off,
                         f"body diagonal {code} (ISO 230-6), retroreflector")
            for code in BODY_DIAGONALS]


def _face_diagonals(c: _Plan, only: str | None = None) -> list[Measurement]:
    return [_measurement(f"face-{plane}-{code}", "diagonal", "retroreflector",
                         diagonal_test(code, c.t, c.steps, plane=plane), c.off,
                         f"face diagonal {code} in {plane.upper()}")
            for plane in FACE_PLANES if only in (None, plane) for code in FACE_DIAGONALS]


def _face_step_diagonals(c: _Plan, only: str | None = None) -> list[Measurement]:
    return [_measurement(f"fstep-{plane}-{code}", "step_diagonal", c.step_target,
                         step_diagonal_test(code, c.t, c.steps, plane, plane=plane), c.off,
                         f"face step diagonal {code} in {plane.upper()}")
            for plane in FACE_PLANES if only in (None, plane) for code in FACE_DIAGONALS]


def _multilateration(c: _Plan, only: str | None = None) -> list[Measurement]:
    from volcal.plan.multilateration import multilateration_tests

    return list(multilateration_tests(c.t, **c.multilateration))


def _linear(c: _Plan, only: str | None = None) -> list[Measurement]:
    out = []
    for k in (range(3) if only is None else ["xyz".index(only)]):
        lines = abbe_lines(k, c.t, c.chain, c.abbe_tool_offset_mm)
        lo, hi = c.t[k, 0] + c.linear_margin_mm, c.t[k, 1] - c.linear_margin_mm
        if hi <= lo:
            raise ParameterError(f"{{overrun_mm=}}{c.linear_margin_mm:g}: the linear margin "
                                 f"leaves no travel on {AXES[k]}")
        targets = (iso_targets(lo, hi, c.steps, seed=k) if c.iso_spacing
                   else np.linspace(lo, hi, c.steps + 1))
        for i, (line, toff) in enumerate(lines, start=1):
            g = linear_test(k, c.t, c.steps, line, runs=c.runs, bidirectional=True,
                            targets_mm=targets)
            others = ", ".join(f"{AXES[j].lower()}={line[j]:g} mm" for j in range(3) if j != k)
            if np.any(toff):
                others += ", target offset " + ", ".join(
                    f"{AXES[j].lower()}{toff[j]:+g} mm" for j in range(3) if toff[j])
            out.append(_measurement(f"linear-{AXES[k].lower()}{i}", "linear", "retroreflector",
                                    g, c.off + toff, f"linear {AXES[k]} at {others}, {c.runs} "
                                    "bidirectional runs (ISO 230-2)"))
    return out


def _direct(c: _Plan, only: str | None = None) -> list[Measurement]:
    from volcal.plan.optics import direct_tests, select_direct

    targets = []
    for k in range(3):
        lo, hi = c.t[k, 0] + c.linear_margin_mm, c.t[k, 1] - c.linear_margin_mm
        if hi <= lo:
            raise ParameterError(f"{{overrun_mm=}}{c.linear_margin_mm:g}: the linear margin "
                                 f"leaves no travel on {AXES[k]}")
        targets.append(iso_targets(lo, hi, c.steps, seed=k) if c.iso_spacing
                       else np.linspace(lo, hi, c.steps + 1))
    ms = direct_tests(c.t, targets, c.runs, c.off, c.vertical,
                      roll_offset_mm=c.abbe_tool_offset_mm)
    return ms if only is None else select_direct(ms, only)


PlanOptions = _Plan
"""The plan's options as a kind's :meth:`volcal.kinds.Kind.plan` receives them (travel
``t`` [mm], ``chain``, ``steps``, ``runs``, ``off`` (tool offset [mm]), ``iso_spacing``,
``linear_margin_mm``, ``vertical``...)."""
