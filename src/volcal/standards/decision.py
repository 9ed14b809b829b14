"""Decision rules for a statement of conformity with a tolerance.

ISO/IEC 17025:2017 7.8.6 asks for the decision rule of every statement of conformity.
Two rules, named as ILAC-G8:09/2019 names them, for an upper tolerance ``T`` on a
value ``y`` with expanded uncertainty ``U`` (95 %):

``simple``
    Simple acceptance (ILAC-G8 4.2.1, "shared risk"): ``pass`` when ``y <= T``,
    otherwise ``fail``; never ``conditional``. The risk of a wrong ``pass`` reaches
    50 % for a value at the limit.
``guarded``
    Guarded acceptance (ILAC-G8 4.2.2; ISO 14253-1:2017 8.2, acceptance zone reduced by
    the guard band ``w``, by default ``w = U``): ``pass`` at or below ``T - w``,
    ``conditional`` above ``T - w`` up to ``T``, ``fail`` above ``T``. With ``w = U``
    the risk of a wrong ``pass`` is below 2.5 %. When ``w >= T`` no value can pass;
    the decision says so.

References
----------
.. [1] ILAC-G8:09/2019, Guidelines on decision rules and statements of conformity.
.. [2] ISO 14253-1:2017, Geometrical product specifications (GPS) - Inspection by
   measurement of workpieces and measuring equipment - Part 1: Decision rules for
   verifying conformity or nonconformity with specifications.
.. [3] ISO/IEC 17025:2017, 7.8.6 (reporting statements of conformity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from volcal.errors import VolcalInputError

__all__ = ["RULES", "RULE_TEXT", "VERDICTS", "Decision", "check_acceptance", "check_rule",
           "combine", "conformity_verdict", "decide", "require_uncertainty"]

RULES: tuple[str, ...] = ("simple", "guarded")
VERDICTS: tuple[str, ...] = ("pass", "fail", "conditional")

#: One line per rule, for outputs that name the rule.
RULE_TEXT: dict[str, str] = {
    "simple": "simple acceptance (ILAC-G8:09/2019 4.2.1; shared risk): pass when the value "
              "is at most the tolerance, otherwise fail; the measurement uncertainty is not "
              "subtracted, so at the limit the risk of a wrong pass is up to 50 %",
    "guarded": "guarded acceptance (ILAC-G8:09/2019 4.2.2, ISO 14253-1:2017): pass at or "
               "below T - w, conditional between T - w and T, fail above T; guard band "
               "w = U (the expanded uncertainty) unless stated",
}


def check_rule(rule: str, option: str = "--decision-rule") -> str:
    """Validate a rule name.

    Parameters
    ----------
    rule : str
        ``'simple'`` or ``'guarded'`` (case-insensitive).
    option : str
        Name used in the error.

    Returns
    -------
    str
        The rule, lower case.

    Raises
    ------
    VolcalInputError
        Unknown rule.
    """
    r = str(rule).strip().lower()
    if r not in RULES:
        raise VolcalInputError(f"{option} {rule!r}: expected one of {', '.join(RULES)}",
                               column=option)
    return r


def check_acceptance(rule: str, guard_band_um: float | None = None,
                     option: str = "--decision-rule") -> str:
    """Validate a decision rule with its guard band, once, where they are given.

    Parameters
    ----------
    rule : str
        ``'simple'`` or ``'guarded'`` (case-insensitive).
    guard_band_um : float, optional
        Guard band w [um]: only with the guarded rule, finite and >= 0.
    option : str
        Name of the rule in the error.

    Returns
    -------
    str
        The rule, lower case.

    Raises
    ------
    VolcalInputError
        Unknown rule; a guard band with the simple rule; a negative or non-finite guard
        band.
    """
    r = check_rule(rule, option)
    if guard_band_um is not None:
        _guard_band(guard_band_um)
        if r != "guarded":
            raise VolcalInputError("--guard-band-um applies to --decision-rule guarded",
                                   column="--guard-band-um")
    return r


def require_uncertainty(rule: str, guard_band_um: float | None, have_U: bool,
                        what: str = "") -> None:
    """Refuse the guarded rule when there is neither an expanded uncertainty nor a guard band.

    Parameters
    ----------
    rule : str
        The (checked) rule.
    guard_band_um : float or None
        Guard band w [um].
    have_U : bool
        Whether the values carry their expanded uncertainty U (a budget was given).
    what : str
        What is judged, for the message (``' on the volumetric tolerance (V)'``).

    Raises
    ------
    VolcalInputError
        ``rule == 'guarded'`` with no U and no guard band.
    """
    if rule == "guarded" and guard_band_um is None and not have_U:
        raise VolcalInputError(f"--decision-rule guarded{what} needs the expanded uncertainty "
                               "(--budget FILE) or a guard band (--guard-band-um W)",
                               column="--decision-rule")


def _guard_band(w: float) -> float:
    if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w < 0:
        raise VolcalInputError(f"guard band {w!r} must be a finite number >= 0 um",
                               column="--guard-band-um")
    return float(w)


@dataclass(frozen=True)
class Decision:
    """The outcome of a decision rule.

    Attributes
    ----------
    verdict : str
        ``'pass'``, ``'fail'`` or ``'conditional'``.
    rule : str
        ``'simple'`` or ``'guarded'``.
    value : float
        The value [um].
    tolerance : float
        The tolerance T [um].
    guard_band : float
        Guard band w [um] (0 for the simple rule).
    acceptance_limit : float
        ``T - w`` [um].
    note : str
        Why, when it is not obvious (``U >= T``: no pass possible).
    """

    verdict: str
    rule: str
    value: float
    tolerance: float
    guard_band: float
    acceptance_limit: float
    note: str = ""

    def to_dict(self) -> dict[str, object]:
        """JSON-friendly dict."""
        return {"verdict": self.verdict, "rule": self.rule, "value_um": self.value,
                "tolerance_um": self.tolerance, "guard_band_um": self.guard_band,
                "acceptance_limit_um": self.acceptance_limit, "note": self.note}


def decide(value: float, tolerance: float, rule: str = "simple", U: float | None = None,
           guard_band: float | None = None, *, without_U: str = "refuse") -> Decision:
    """Apply a decision rule to a value with an upper tolerance.

    Parameters
    ----------
    value : float
        The measured value [um] (a parameter such as the accuracy A).
    tolerance : float
        Upper limit T [um].
    rule : str
        ``'simple'`` (default) or ``'guarded'``.
    U : float, optional
        Expanded uncertainty of ``value`` [um]: the guard band of the guarded rule
        unless ``guard_band`` is given.
    guard_band : float, optional
        Guard band w [um], overriding ``U``.
    without_U : {'refuse', 'conditional'}
        The guarded rule with neither ``U`` nor ``guard_band``: refused (``'refuse'``:
        the verdicts of ``evaluate`` and the report), or stated ``'conditional'`` (no
        pass can be proven; ``'fail'`` above T: the certificate's statements).

    Returns
    -------
    Decision

    Raises
    ------
    VolcalInputError
        Unknown rule; a guarded rule with neither ``U`` nor ``guard_band`` (``without_U
        = 'refuse'``); a negative or non-finite guard band.

    Examples
    --------
    >>> decide(9.0, 10.0).verdict
    'pass'
    >>> decide(9.0, 10.0, "guarded", U=2.0).verdict
    'conditional'
    """
    rule = check_rule(rule)
    v, t = float(value), float(tolerance)
    if rule == "simple":
        return Decision("pass" if v <= t else "fail", rule, v, t, 0.0, t)
    if guard_band is not None:
        w = float(guard_band)
        src = "--guard-band-um"
    elif U is not None:
        w = float(U)
        src = "U"
    elif without_U == "conditional":
        if v > t:
            return Decision("fail", rule, v, t, math.nan, math.nan)
        return Decision("conditional", rule, v, t, math.nan, math.nan,
                        "guarded rule without an expanded uncertainty or guard band: no "
                        "pass can be stated")
    else:
        raise VolcalInputError("the guarded decision rule needs the expanded uncertainty "
                               "(--budget FILE) or a guard band (--guard-band-um W)",
                               column="--decision-rule")
    _guard_band(w)
    limit = t - w
    note = ""
    if w >= t:
        note = (f"no pass is possible: the guard band w = {w:.3g} um ({src}) is not "
                f"smaller than the tolerance T = {t:g} um")
    if v > t:
        verdict = "fail"
    elif v <= limit and w < t:
        verdict = "pass"
    else:
        verdict = "conditional"
        if not note:
            note = (f"value within T but above T - w = {limit:.3g} um: conformity not "
                    "proven at 95 %")
    return Decision(verdict, rule, v, t, w, limit, note)


def combine(verdicts: list[str]) -> str:
    """One verdict for several: any ``fail``, else any ``conditional``, else ``pass``.

    Parameters
    ----------
    verdicts : list of str
        Verdicts (``'-'`` entries, no value, are ignored).

    Returns
    -------
    str
    """
    vs = [v for v in verdicts if v in VERDICTS]
    if "fail" in vs:
        return "fail"
    if "conditional" in vs:
        return "conditional"
    return "pass"


def conformity_verdict(value_um: float, tolerance_um: float, rule: str = "simple",
                       U_um: float | None = None, guard_band_um: float | None = None
                       ) -> tuple[str, str]:
    """Statement of conformity of one value with a decision rule.

    The rules are :func:`decide`'s (one definition for ``evaluate``, the report and the
    certificate), with the certificate's case of a guarded rule without any U or guard
    band stated as ``conditional`` (no pass can be proven) instead of refused
    (``decide(..., without_U='conditional')``).

    Parameters
    ----------
    value_um : float
        Measured value (an upper-limit quantity: A, E, R, |e|...) [um].
    tolerance_um : float
        Its tolerance T [um].
    rule : {'simple', 'guarded'}
        ``simple``: ILAC-G8:09/2019 simple acceptance (shared risk), pass when the value
        is at most T; it never gives ``conditional``. ``guarded``: ISO 14253-1:2017 /
        ILAC-G8 guarded acceptance with guard band w (``guard_band_um``, default the
        expanded uncertainty U): ``pass`` at or below T - w, ``conditional`` between
        T - w and T, ``fail`` above T.
    U_um : float, optional
        Expanded uncertainty of the value [um] (k stated with it).
    guard_band_um : float, optional
        Guard band w [um] of the guarded rule.

    Returns
    -------
    verdict : str
        ``'pass'``, ``'fail'`` or ``'conditional'``.
    note : str
        Why, when the rule could not give a pass (w >= T, or no U) or the value lies in
        the guard band.
    """
    d = decide(value_um, tolerance_um, rule, U_um, guard_band_um, without_U="conditional")
    return d.verdict, d.note
