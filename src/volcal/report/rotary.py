"""Report section of the rotary tests: ISO 230-2 of each rotary axis [urad or arcsec]."""

from __future__ import annotations

from functools import partial
from typing import Any

from volcal.report.document import FigureItem, Section, Table, fmt
from volcal.report.wording import ISO230_2_HEADS, ISO230_2_LEGEND

__all__ = ["NO_LINEAR_MODEL", "parse_rotary_tolerance", "rotary_results", "rotary_section",
           "rotary_verdicts"]

_KEYS = ("A", "A_up", "A_down", "E", "M", "R", "R_up", "R_down", "B", "B_mean")
NO_LINEAR_MODEL = (
    "No linear model was identified: the session holds no test of the linear axes (only "
    "rotary tests, each evaluated on its own to ISO 230-2), so this report has no error "
    "functions, volumetric indices or linear compensation; the rotary tables come from "
    "`volcal compensate --session S --format F -o OUT` without a model.")
"""What the report and the certificate say of a calibration without a linear model."""


def rotary_results(inp: Any) -> dict[str, Any]:
    """The rotary evaluations of the report's inputs, by measurement id.

    The session's one evaluation (``inp.evaluation.rotary``) when there is one; else each
    rotary test with readings evaluated here (the report of a session without an
    evaluation).

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results.

    Returns
    -------
    dict of str to RotaryIso2302Result
    """
    ev = getattr(inp, "evaluation", None)
    if ev is not None and getattr(ev, "rotary", None) is not None:
        return dict(ev.rotary)
    from volcal.standards.iso230_2_rotary import evaluate_rotary_measurement

    return {m.id: evaluate_rotary_measurement(m, budget=getattr(inp, "budget", None))
            for m in inp.session.measurements if m.kind == "rotary"
            and m.deviation is not None and "run" in m.columns and "direction" in m.columns}


def rotary_section(inp: Any, units: str | None = None) -> Section | None:
    """Deviation plot per direction with the ISO 230-2 bands, the table, U, verdict.

    Parameters
    ----------
    inp : volcal.report.sections.ReportInputs
        Session and results; ``inp.angle_units`` (``'urad'`` or ``'arcsec'``) when set.
    units : str, optional
        Overrides ``inp.angle_units``.

    Returns
    -------
    Section or None
        None without a rotary test with readings.
    """
    from volcal.plot.rotary import rotary_deviation_plot
    from volcal.standards.iso230_2_rotary import UNITS

    res = rotary_results(inp)
    if not res:
        return None
    units = units or getattr(inp, "angle_units", None) or "urad"
    f = UNITS[units]
    u = "µrad" if units == "urad" else "arcsec"
    sec = Section("rotary", "Rotary axes: angular positioning (ISO 230-2)")
    sec.paragraphs.append(
        "Angular positioning of each rotary axis read by an angular interferometer on a "
        "rotary calibrator (or against a precision index table), evaluated as ISO 230-2 "
        "asks for rotary axes: the deviation is the actual minus the commanded angle, "
        "positive counter-clockwise looking from the positive end of the axis towards the "
        f"origin (ISO 841); every angle in {u} (1 arcsec = 4.848 µrad). On a full-circle "
        "axis 0 and 360° are one position read at both ends of each pass: their "
        "difference (the closure) shows drift or a lost count.")
    if getattr(inp, "result", None) is None:
        sec.paragraphs.append(NO_LINEAR_MODEL)
    rows = []
    for mid, r in res.items():
        rows.append([mid, r.axis, *(fmt(r.value(k, units), 3) for k in _KEYS),
                     "-" if not r.closure_urad else
                     f"{fmt(r.closure_urad['up'] * f, 3)} / "
                     f"{fmt(r.closure_urad['down'] * f, 3)}"])
        sec.warnings.extend(f"{mid}: {w}" for w in r.warnings)
        sec.warnings.extend(f"{mid}: {n}" for n in r.iso.notes)
    edition = next(iter(res.values())).iso.edition
    sec.tables.append(Table(
        ["measurement", "axis", *(f"{ISO230_2_HEADS[k]} [{u}]" for k in _KEYS),
         f"closure ↑ / ↓ [{u}]"],
        rows, f"ISO 230-2:{edition} positioning parameters of the rotary axes",
        ISO230_2_LEGEND))
    with_u = {k: r for k, r in res.items() if r.uncertainty is not None}
    if with_u:
        sec.tables.append(Table(
            ["measurement", *(f"U({k}) [{u}]" for k in ("A", "E", "M", "R", "B")), "k (A)"],
            [[k, *(fmt(r.uncertainty.parameters[p].U * f, 3) for p in ("A", "E", "M", "R",
                                                                         "B")),
              fmt(r.uncertainty.parameters["A"].k)] for k, r in with_u.items()],
            "Expanded uncertainty of the rotary parameters (95 %)",
            "From the [angular] budget: calibrator (or index table), eccentric mounting, "
            "repeatability (docs/uncertainty.md, Rotary axes)."))
    verdict = _verdicts(inp, res)
    if verdict:
        sec.tables.append(Table(["measurement", "parameter", f"value [{u}]",
                                 f"tolerance [{u}]", "verdict"], verdict,
                                "Verdict of the rotary axes (simple rule unless stated)"))
    for mid, r in res.items():
        m = inp.session.get(mid)
        sec.figures.append(FigureItem(
            partial(rotary_deviation_plot, m, r, units),
            f"{mid}: angular deviation of every run with the mean ± 2 s bands of each "
            "approach direction (ISO 230-2, Figure 1, rotary axis)"
            + (" and x̄ ± U (95 %)" if r.uncertainty is not None else "") + ".",
            f"{mid}-rotary"))
    return sec


def rotary_verdicts(res: dict[str, Any], tolerance_urad: Any, units: str = "urad"
                    ) -> list[list[str]]:
    """Verdict of the accuracy A of each rotary test under its axis' tolerance.

    The simple rule (:func:`volcal.standards.decision.decide`): pass when A is at most the
    tolerance.

    Parameters
    ----------
    res : dict of str to RotaryIso2302Result
        The rotary evaluations.
    tolerance_urad : mapping of str to float
        Axis letter (``'C'``) -> tolerance of A [urad].
    units : str
        Unit of the cells (``'urad'`` or ``'arcsec'``).

    Returns
    -------
    list of list of str
        ``[id, 'A', value, tolerance, verdict]``.
    """
    from volcal.standards.decision import decide
    from volcal.standards.iso230_2_rotary import UNITS

    rows = []
    for mid, r in res.items():
        t = (tolerance_urad or {}).get(r.axis.upper())
        if t is None:
            continue
        d = decide(float(r.iso.A), float(t), "simple")
        rows.append([mid, "A", fmt(r.value("A", units), 3), fmt(float(t) * UNITS[units], 3),
                     d.verdict])
    return rows


def parse_rotary_tolerance(text: str | None) -> dict[str, float] | None:
    """``'C=25,A=30'`` -> ``{'C': 25.0, 'A': 30.0}`` (tolerance of A per rotary axis [urad]).

    Parameters
    ----------
    text : str or None
        The option's text.

    Returns
    -------
    dict or None
    """
    from volcal.errors import VolcalInputError

    if text is None:
        return None
    out: dict[str, float] = {}
    for part in (p.strip() for p in text.split(",") if p.strip()):
        k, sep, v = part.partition("=")
        try:
            x = float(v)
        except ValueError:
            x = float("nan")
        if not sep or k.strip().upper() not in ("A", "B", "C") or not x > 0:
            raise VolcalInputError(f"--rotary-tolerance-urad {part!r}: expected AXIS=urad with "
                                   "AXIS A, B or C and a positive tolerance (C=25)")
        out[k.strip().upper()] = x
    return out


def _verdicts(inp: Any, res: dict[str, Any]) -> list[list[str]]:
    """The rows of :func:`rotary_verdicts` for the inputs' tolerances (none: none)."""
    tol = getattr(inp, "rotary_tolerance_urad", None)
    if not tol:
        return []
    return rotary_verdicts(res, tol, getattr(inp, "angle_units", None) or "urad")
