"""The direct test set: each error motion of each axis along one line, with direct optics.

What a service engineer's case measures (Renishaw XL-80/XM-60, Keysight 5530, API XD):
per axis one linear line, two straightness lines, pitch and yaw with angular optics, the
roll with a differential level on a horizontal axis and, on the vertical axis, by its
straightness at two tool offsets against one reference optic; the squareness of each
pair of axes by an optical square (the two straightness lines of the pair in one
reference group). ``docs/formats.md``, "Direct optics"; ISO 230-1:2012, 3.4 and 10.3.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from volcal.model.names import AXES
from volcal.plan.geometry import linear_test
from volcal.session.format import Measurement

__all__ = ["DIRECT_SELECTORS", "OPTIC_LABEL", "direct_tests", "optic_additions",
           "optic_candidates", "select_direct"]

DIRECT_SELECTORS: tuple[str, ...] = ("x", "y", "z", "level-x", "level-y", "level-z",
                                     "roll-x", "roll-y", "roll-z")
"""Parts of the direct set (``plan --tests direct:x``): the lines of one axis, the level
on one (horizontal) axis, or the vertical axis' straightness pair that reads its roll."""

OPTIC_LABEL = "direct optics: "
"""Start of the label of a direct-optics candidate (the identifiability report names the
best of them even when other extra measurements rank higher)."""


def _line(k: int, targets: NDArray[np.float64], base: NDArray[np.float64], runs: int):
    g = linear_test(k, np.array([[0, 1]] * 3, dtype=float), 1, base, runs=runs,
                    bidirectional=True, targets_mm=targets)
    return g


def direct_tests(travel: NDArray[np.float64], targets: list[NDArray[np.float64]], runs: int,
                 offset: NDArray[np.float64], vertical: int = 2,
                 roll_offset_mm: float = 150.0) -> list[Measurement]:
    """Plan the direct test set (deviations empty).

    Parameters
    ----------
    travel : ndarray, shape (3, 2)
        Travel limits [mm]; every line runs at the start of the other axes' travel.
    targets : list of 3 arrays
        Targets of each axis [mm].
    runs : int
        Bidirectional runs of each line.
    offset : ndarray, shape (3,)
        Tool offset of the sensing optics [mm].
    vertical : int
        The vertical axis (its roll is read by two straightness lines).
    roll_offset_mm : float
        Tool offset between the vertical axis' two straightness lines [mm].

    Returns
    -------
    list of Measurement
        ``lin-<a>``, ``str-<a><d>`` (reference group ``<plane>`` with the line of the other
        axis: the optical square of that pair), ``ang-<a><r>`` (angular optics), ``lev-<a><r>``
        (level, roll of a horizontal axis) and ``str-<v><d>-roll`` (vertical axis at the
        roll offset, in the group of ``str-<v><d>``).
    """
    base = travel[:, 0].copy()
    out: list[Measurement] = []

    def add(mid, kind, target, k, meta, toff, notes):
        g = _line(k, targets[k], base, runs)
        cols = {"run": g.run, "direction": g.direction} if kind == "linear" else {
            "run": g.run, "direction": g.direction}
        m = dict(meta, notes=notes)
        out.append(Measurement(mid, kind, target, g.positions, None, g.beam_direction,
                               np.asarray(toff, dtype=float), f"{mid}.csv", cols, m))

    for k in range(3):
        a = AXES[k].lower()
        add(f"lin-{a}", "linear", "retroreflector", k, {"axis": AXES[k]}, offset,
            f"linear {AXES[k]} (laser, linear optics), {runs} bidirectional runs")
        for j in (j for j in range(3) if j != k):
            d = AXES[j].lower()
            plane = "".join(sorted(a + d))
            add(f"str-{a}{d}", "straightness", "straightness_optics", k,
                {"axis": a, "error_direction": d, "reference": plane}, offset,
                f"straightness of {AXES[k]} along {AXES[j]} (E{AXES[j]}{AXES[k]}); reference "
                f"optic {plane.upper()} shared with the other axis of the plane through the "
                "optical square")
        for r in range(3):
            rot = "ABC"[r]
            if r != k:
                add(f"ang-{a}{rot.lower()}", "angular", "angular_optics", k,
                    {"axis": a, "rotation": rot.lower()}, offset,
                    f"E{rot}{AXES[k]} with angular optics")
            elif k != vertical:
                add(f"lev-{a}{rot.lower()}", "angular", "level", k,
                    {"axis": a, "rotation": rot.lower()}, offset,
                    f"roll E{rot}{AXES[k]} with a differential electronic level")
    # the vertical axis' roll: its straightness at a second tool offset, one reference
    v = vertical
    j, h = [i for i in range(3) if i != v]  # read along j, offset along h
    toff = np.asarray(offset, dtype=float).copy()
    toff[h] += roll_offset_mm
    a, d = AXES[v].lower(), AXES[j].lower()
    add(f"str-{a}{d}-roll", "straightness", "straightness_optics", v,
        {"axis": a, "error_direction": d, "reference": "".join(sorted(a + d))}, toff,
        f"straightness of {AXES[v]} along {AXES[j]} at a tool offset of {roll_offset_mm:g} mm "
        f"in {AXES[h]}, the reference optic of str-{a}{d} not moved: roll E{'ABC'[v]}{AXES[v]}")
    return out


def select_direct(measurements: list[Measurement], only: str) -> list[Measurement]:
    """A part of the direct set (:data:`DIRECT_SELECTORS`).

    Parameters
    ----------
    measurements : list of Measurement
        The direct set (:func:`direct_tests`).
    only : str
        ``'x'`` (every line of X), ``'level-x'`` (the level on X), ``'roll-z'`` (Z's
        straightness at the two tool offsets, in one reference group of their own).

    Returns
    -------
    list of Measurement

    Raises
    ------
    VolcalInputError
        An unknown selector, or one the plan has no line for (a level on the vertical axis).
    """
    from volcal.errors import VolcalInputError

    o = only.strip().lower()
    if o not in DIRECT_SELECTORS:
        raise VolcalInputError(f"unknown test 'direct:{only}': expected one of "
                               f"{', '.join('direct:' + s for s in DIRECT_SELECTORS)}")
    if o in ("x", "y", "z"):
        return [m for m in measurements if str(m.meta.get("axis", "")).lower() == o]
    kind, a = o.split("-")
    if kind == "level":
        out = [m for m in measurements if m.target == "level" and m.meta["axis"] == a]
    else:
        out = [m for m in measurements if m.kind == "straightness" and m.meta["axis"] == a
               and m.id.endswith("-roll")]
        if out:
            first = next(m for m in measurements if m.id == out[0].id[:-len("-roll")])
            out = [first, *out]
            for m in out:
                m.meta["reference"] = f"{a}-roll"
    if not out:
        raise VolcalInputError(f"'direct:{only}': no such line in the direct set (a level reads "
                               "the roll of a horizontal axis; the straightness pair, that of "
                               "the vertical axis)")
    return out


def optic_candidates(travel: NDArray[np.float64], steps: int, vertical: int = 2,
                     roll_offset_mm: float = 150.0) -> dict[str, list[Measurement]]:
    """Direct optics to rank among the extra measurements (``advise``, identify's report).

    Parameters
    ----------
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    steps : int
        Increments per line.
    vertical : int
        The vertical axis (no level about it).
    roll_offset_mm : float
        Tool offset between the vertical axis' two straightness lines [mm].

    Returns
    -------
    dict of str to list of Measurement
        Label -> planned measurements (zero readings): a level on each horizontal axis
        (its roll), the vertical axis' straightness at two tool offsets in one reference
        group (its roll).
    """
    t = np.asarray(travel, dtype=float)
    targets = [np.linspace(t[k, 0], t[k, 1], steps + 1) for k in range(3)]
    every = direct_tests(t, targets, 1, np.zeros(3), vertical, roll_offset_mm)
    by_id = {m.id: m for m in every}
    out: dict[str, list[Measurement]] = {}
    for k in range(3):
        if k == vertical:
            continue
        m = by_id[f"lev-{'xyz'[k]}{'abc'[k]}"]
        out[f"{OPTIC_LABEL}a level on {AXES[k]} determines E{'ABC'[k]}{AXES[k]} (roll of "
            f"{AXES[k]}), line {m.id} of `plan --tests direct`"] = [m]
    v = vertical
    j = [i for i in range(3) if i != v][0]
    a, d = AXES[v].lower(), AXES[j].lower()
    pair = [by_id[f"str-{a}{d}"], by_id[f"str-{a}{d}-roll"]]
    for m in pair:
        m.meta["reference"] = f"{a}-roll"
    out[f"{OPTIC_LABEL}the straightness of {AXES[v]} along {AXES[j]} at two tool offsets "
        f"{roll_offset_mm:g} mm apart against one reference determines E{'ABC'[v]}{AXES[v]} "
        f"(roll of {AXES[v]})"] = pair
    for ms in out.values():
        for m in ms:
            m.deviation = np.zeros(m.n)
            m.columns = {}
    return out


def optic_additions(vertical: int = 2, roll_offset_mm: float = 150.0
                    ) -> list[tuple[str, tuple[str, ...]]]:
    """The candidates of :func:`optic_candidates` as ``plan --tests`` parts.

    Parameters
    ----------
    vertical : int
        The vertical axis.
    roll_offset_mm : float
        Tool offset between the vertical axis' two straightness lines [mm].

    Returns
    -------
    list of (label, tests)
        The same labels as :func:`optic_candidates`, each with its ``--tests`` value
        (``('direct:level-x',)``, ``('direct:roll-z',)``).
    """
    labels = list(optic_candidates(np.array([[0.0, 1.0]] * 3), 1, vertical,
                                   roll_offset_mm))
    tests = [f"direct:level-{'xyz'[k]}" for k in range(3) if k != vertical]
    tests.append(f"direct:roll-{'xyz'[vertical]}")
    return [(lb, (t,)) for lb, t in zip(labels, tests, strict=True)]
