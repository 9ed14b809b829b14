"""Tolerances and the pass/fail verdict before and after compensation.

A tolerance is given on the command line as ``--tolerance-um``:

* a single number, ``--tolerance-um 15``: the largest length of the volumetric error
  over the work zone [um] (ISO 230-1:2012, annex A: the volumetric error vector);
* per-axis ISO 230-2 tolerances, ``--tolerance-um X=10,Y=10,Z=8``: the bidirectional
  accuracy of positioning ``A`` of every linear test of that axis [um] (ISO 230-2:2014,
  3.23; the acceptance figure of most machine specifications);
* both, ``--tolerance-um X=10,Y=10,Z=8,V=15`` (``V`` = volumetric);
* another ISO 230-2 parameter of an axis, ``X.E=6,X.R=4`` (any key of the ISO 230-2
  JSON: ``A, A_up, A_down, E, E_up, E_down, M, R, R_up, R_down, B, B_mean``);
* the direct optics' limits, stated on the calibration certificate
  (``docs/certificate.md``): ``X.straightness_um=4`` (ISO 230-1 straightness of every
  straightness line moving along X, either error direction, least-squares reference
  line [um]) and ``EC0Y.squareness_urad=20`` (the magnitude of a squareness measured
  with an optical square, EC0Y, EB0Z or EA0Z [urad]).

``volcal evaluate iso230-2`` (one axis) takes ``--tolerance-um 10`` (on ``A``) or
``A=10,E=6,R=4`` (:func:`parse_parameter_tolerance`).

The verdict follows a decision rule (:mod:`volcal.standards.decision`): ``simple``
(default; pass when the value is at most the tolerance) or ``guarded`` (guard band).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from volcal.errors import VolcalInputError
from volcal.standards.decision import Decision, decide

__all__ = ["OPTICS_KEYS", "PARAMETER_KEYS", "SQUARENESS_NAMES", "Tolerance", "Verdict",
           "parse_parameter_tolerance", "parse_tolerance"]

#: The direct optics' keys: ``<axis>.straightness_um``, ``<name>.squareness_urad``.
OPTICS_KEYS: tuple[str, str] = ("straightness_um", "squareness_urad")
#: The squareness names an optical square gives (``volcal.model.names``).
SQUARENESS_NAMES: tuple[str, ...] = ("EC0Y", "EB0Z", "EA0Z")

#: ISO 230-2 parameters a tolerance can apply to (the keys of its JSON).
PARAMETER_KEYS: tuple[str, ...] = ("A", "A_up", "A_down", "E", "E_up", "E_down", "M", "R",
                                   "R_up", "R_down", "B", "B_mean")


def _parameter_key(key: str, text: str) -> str:
    for k in PARAMETER_KEYS:
        if k.lower() == key.strip().lower():
            return k
    raise VolcalInputError(f"--tolerance-um {text!r}: unknown ISO 230-2 parameter "
                           f"{key.strip()!r}: expected one of {', '.join(PARAMETER_KEYS)}")


def _positive(s: str, what: str, text: str) -> float:
    try:
        v = float(s)
    except ValueError:
        v = float("nan")
    if not math.isfinite(v) or v <= 0:
        raise VolcalInputError(f"--tolerance-um {text!r}: {what} {s!r} is not a positive "
                               "number of um")
    return v


def parse_parameter_tolerance(text: str) -> dict[str, float]:
    """Read the ``--tolerance-um`` of one axis: ``10`` (on A) or ``A=10,E=6,R=4``.

    Parameters
    ----------
    text : str
        The option's value; units um.

    Returns
    -------
    dict of str to float
        Tolerance per ISO 230-2 parameter [um].

    Raises
    ------
    VolcalInputError
        Not a positive number, an unknown parameter or one given twice.
    """
    text = str(text).strip()
    if "=" not in text:
        return {"A": _positive(text, "value", text)}
    out: dict[str, float] = {}
    for part in (p.strip() for p in text.split(",")):
        key, eq, val = part.partition("=")
        if not eq:
            raise VolcalInputError(f"--tolerance-um {text!r}: expected a number (on A) or "
                                   f"A=..,E=..,R=.. per parameter, found {part!r}")
        k = _parameter_key(key, text)
        if k in out:
            raise VolcalInputError(f"--tolerance-um {text!r}: {k} given twice")
        out[k] = _positive(val.strip(), k, text)
    return out


@dataclass(frozen=True)
class Tolerance:
    """Tolerances of a verdict.

    Attributes
    ----------
    volumetric_um : float or None
        Largest volumetric error length over the work zone [um].
    axis_um : dict of str to float
        ISO 230-2 accuracy ``A`` per axis (``'X'``, ``'Y'``, ``'Z'``) [um].
    parameters : dict of str to dict of str to float
        Other ISO 230-2 parameters per axis, ``{'X': {'E': 6.0}}`` [um].
    rule : str
        Decision rule, ``'simple'`` (default) or ``'guarded'``
        (:mod:`volcal.standards.decision`).
    guard_band_um : float or None
        Guard band of the guarded rule [um] (default: the expanded uncertainty U).
    budget : Budget or None
        Uncertainty budget (:mod:`volcal.uncertainty.budget`) giving U of the ISO 230-2
        parameters.
    straightness_um : dict of str to float
        ISO 230-1 straightness per moving axis (``X.straightness_um=4``) [um]; stated on
        the certificate.
    squareness_urad : dict of str to float
        Magnitude of a squareness by optical square per name (``EC0Y.squareness_urad=20``)
        [urad]; stated on the certificate.
    """

    volumetric_um: float | None = None
    axis_um: dict[str, float] = field(default_factory=dict)
    parameters: dict[str, dict[str, float]] = field(default_factory=dict)
    rule: str = "simple"
    guard_band_um: float | None = None
    budget: Any = None
    straightness_um: dict[str, float] = field(default_factory=dict)
    squareness_urad: dict[str, float] = field(default_factory=dict)

    def text(self) -> str:
        """The tolerance as written on the command line."""
        parts = [f"{a}={v:g}" for a, v in self.axis_um.items()]
        parts += [f"{a}.{k}={v:g}" for a, d in self.parameters.items() for k, v in d.items()]
        parts += [f"{a}.{OPTICS_KEYS[0]}={v:g}" for a, v in self.straightness_um.items()]
        parts += [f"{n}.{OPTICS_KEYS[1]}={v:g}" for n, v in self.squareness_urad.items()]
        if self.volumetric_um is not None:
            parts.append(f"V={self.volumetric_um:g}" if parts else f"{self.volumetric_um:g}")
        return ",".join(parts)


def parse_tolerance(text: str) -> Tolerance:
    """Read ``--tolerance-um``: ``15``, ``X=10,Y=10,Z=8``, ``X=10,Y=10,Z=8,V=15``, ``X.E=6``.

    ``X.straightness_um=4`` and ``EC0Y.squareness_urad=20`` add the direct optics' limits
    (the certificate's statements; ``volcal evaluate session`` and the report's verdict
    do not use them).

    Parameters
    ----------
    text : str
        The option's value; units um.

    Returns
    -------
    Tolerance

    Raises
    ------
    VolcalInputError
        Not a positive number, an unknown key or a key given twice.
    """
    def num(s: str, what: str) -> float:
        try:
            v = float(s)
        except ValueError:
            v = float("nan")
        if not math.isfinite(v) or v <= 0:
            raise VolcalInputError(f"--tolerance-um {text!r}: {what} {s!r} is not a positive "
                                   "number of " + ("urad" if what.endswith("urad") else "um"))
        return v

    text = str(text).strip()
    if "=" not in text:
        return Tolerance(num(text, "value"))
    axis: dict[str, float] = {}
    params: dict[str, dict[str, float]] = {}
    optics: tuple[dict[str, float], dict[str, float]] = ({}, {})
    vol = None
    for part in (p.strip() for p in text.split(",")):
        key, eq, val = part.partition("=")
        key = key.strip()
        name, _, par = key.partition(".")
        if eq and par.strip().lower() in OPTICS_KEYS:
            which = OPTICS_KEYS.index(par.strip().lower())
            name = name.strip().upper()
            valid = ("X", "Y", "Z") if which == 0 else SQUARENESS_NAMES
            if name not in valid:
                raise VolcalInputError(f"--tolerance-um {text!r}: {key!r}: "
                                       f"{OPTICS_KEYS[which]} applies to "
                                       f"{', '.join(valid)}, found {name!r}")
            if name in optics[which]:
                raise VolcalInputError(f"--tolerance-um {text!r}: {name}."
                                       f"{OPTICS_KEYS[which]} given twice")
            optics[which][name] = num(val.strip(), f"{name}.{OPTICS_KEYS[which]}")
            continue
        if eq and "." in key and key.split(".")[0].strip().upper() in ("X", "Y", "Z"):
            ax, _, par = key.partition(".")
            ax = ax.strip().upper()
            k = _parameter_key(par, text)
            if k == "A":
                key = ax
            else:
                if k in params.get(ax, {}):
                    raise VolcalInputError(f"--tolerance-um {text!r}: {ax}.{k} given twice")
                params.setdefault(ax, {})[k] = num(val.strip(), f"{ax}.{k}")
                continue
        key = key.upper()
        if not eq or key not in ("X", "Y", "Z", "V"):
            raise VolcalInputError(f"--tolerance-um {text!r}: expected X=..,Y=..,Z=.. (ISO "
                                   "230-2 accuracy A per axis), X.E=.. (another ISO 230-2 "
                                   "parameter), X.straightness_um=.., "
                                   "EC0Y.squareness_urad=.. (direct optics) and/or V=.. "
                                   f"(volumetric), found {part!r}")
        if key in axis or (key == "V" and vol is not None):
            raise VolcalInputError(f"--tolerance-um {text!r}: {key} given twice")
        if key == "V":
            vol = num(val.strip(), "V")
        else:
            axis[key] = num(val.strip(), key)
    return Tolerance(vol, dict(sorted(axis.items())),
                     {a: params[a] for a in sorted(params)},
                     straightness_um=dict(sorted(optics[0].items())),
                     squareness_urad=optics[1])


@dataclass(frozen=True)
class Verdict:
    """One line of a verdict: a quantity, its tolerance, its value before and after.

    Attributes
    ----------
    quantity : str
        What is checked (``'volumetric error, largest |e|'``, ``'X: ISO 230-2 A'``...).
    tolerance_um : float
        Tolerance [um].
    before_um : float or None
        Value before compensation [um].
    after_um : float or None
        Value after compensation [um] (None when no compensation tables are given).
    rule : str
        Decision rule, ``'simple'`` or ``'guarded'`` (:mod:`volcal.standards.decision`).
    U_before_um, U_after_um : float or None
        Expanded uncertainty of the values [um] (the guarded rule's guard band).
    guard_band_um : float or None
        Guard band given on the command line [um], overriding U.
    """

    quantity: str
    tolerance_um: float
    before_um: float | None
    after_um: float | None = None
    rule: str = "simple"
    U_before_um: float | None = None
    U_after_um: float | None = None
    guard_band_um: float | None = None

    def decision(self, value: float | None, U: float | None) -> Decision | None:
        """The decision for one value (None without a value).

        Parameters
        ----------
        value : float or None
            The value [um].
        U : float or None
            Its expanded uncertainty [um].

        Returns
        -------
        Decision or None
        """
        if value is None or not math.isfinite(value):
            return None
        return decide(value, self.tolerance_um, self.rule, U, self.guard_band_um)

    @staticmethod
    def word(value: float | None, tolerance: float) -> str:
        """Simple acceptance: ``'pass'``, ``'fail'`` or ``'-'`` (no value).

        Parameters
        ----------
        value : float or None
            The value [um].
        tolerance : float
            The tolerance [um].

        Returns
        -------
        str
        """
        if value is None or not math.isfinite(value):
            return "-"
        return decide(value, tolerance).verdict

    @property
    def before(self) -> str:
        """Verdict before compensation (``'-'``: no value)."""
        d = self.decision(self.before_um, self.U_before_um)
        return "-" if d is None else d.verdict

    @property
    def after(self) -> str:
        """Verdict after compensation (``'-'``: no value, no tables)."""
        d = self.decision(self.after_um, self.U_after_um)
        return "-" if d is None else d.verdict

    def to_dict(self) -> dict:
        """JSON-ready dictionary; a verdict without a value is ``null``."""
        def word(w: str) -> str | None:
            return None if w == "-" else w

        out = {"quantity": self.quantity, "tolerance_um": self.tolerance_um,
               "before_um": self.before_um, "after_um": self.after_um,
               "before": word(self.before), "after": word(self.after),
               "rule": self.rule}
        if self.rule == "guarded":
            notes = [d.note for d in (self.decision(self.before_um, self.U_before_um),
                                      self.decision(self.after_um, self.U_after_um))
                     if d is not None and d.note]
            out.update({"U_before_um": self.U_before_um, "U_after_um": self.U_after_um,
                        "guard_band_um": self.guard_band_um, "notes": notes})
        return out
