"""Tolerances and the pass/fail verdict before and after compensation.

A tolerance is given on the command line as ``--tolerance-um``:

* a single number, ``--tolerance-um 15``: the largest length of the volumetric error
  over the work zone [um] (ISO 230-1:2012, annex A: the volumetric error vector);
* per-axis ISO 230-2 tolerances, ``--tolerance-um X=10,Y=10,Z=8``: the bidirectional
  accuracy of positioning ``A`` of every linear test of that axis [um] (ISO 230-2:2014,
  3.23; the acceptance figure of most machine specifications);
* both, ``--tolerance-um X=10,Y=10,Z=8,V=15`` (``V`` = volumetric).

A value passes when it is at most the tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from volcal.errors import VolcalInputError

__all__ = ["Tolerance", "Verdict", "parse_tolerance"]


@dataclass(frozen=True)
class Tolerance:
    """Tolerances of a verdict.

    Attributes
    ----------
    volumetric_um : float or None
        Largest volumetric error length over the work zone [um].
    axis_um : dict of str to float
        ISO 230-2 accuracy ``A`` per axis (``'X'``, ``'Y'``, ``'Z'``) [um].
    """

    volumetric_um: float | None = None
    axis_um: dict[str, float] = field(default_factory=dict)

    def text(self) -> str:
        """The tolerance as written on the command line."""
        parts = [f"{a}={v:g}" for a, v in self.axis_um.items()]
        if self.volumetric_um is not None:
            parts.append(f"V={self.volumetric_um:g}" if parts else f"{self.volumetric_um:g}")
        return ",".join(parts)


def parse_tolerance(text: str) -> Tolerance:
    """Read ``--tolerance-um``: ``15``, ``X=10,Y=10,Z=8`` or ``X=10,Y=10,Z=8,V=15``.

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
                                   "number of um")
        return v

    text = str(text).strip()
    if "=" not in text:
        return Tolerance(num(text, "value"))
    axis: dict[str, float] = {}
    vol = None
    for part in (p.strip() for p in text.split(",")):
        key, eq, val = part.partition("=")
        key = key.strip().upper()
        if not eq or key not in ("X", "Y", "Z", "V"):
            raise VolcalInputError(f"--tolerance-um {text!r}: expected X=..,Y=..,Z=.. (ISO "
                                   "230-2 accuracy A per axis) and/or V=.. (volumetric), "
                                   f"found {part!r}")
        if key in axis or (key == "V" and vol is not None):
            raise VolcalInputError(f"--tolerance-um {text!r}: {key} given twice")
        if key == "V":
            vol = num(val.strip(), "V")
        else:
            axis[key] = num(val.strip(), key)
    return Tolerance(vol, dict(sorted(axis.items())))


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
    """

    quantity: str
    tolerance_um: float
    before_um: float | None
    after_um: float | None = None

    @staticmethod
    def word(value: float | None, tolerance: float) -> str:
        """``'pass'``, ``'FAIL'`` or ``'-'`` (no value).

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
        return "pass" if value <= tolerance else "FAIL"

    @property
    def before(self) -> str:
        """Verdict before compensation."""
        return self.word(self.before_um, self.tolerance_um)

    @property
    def after(self) -> str:
        """Verdict after compensation."""
        return self.word(self.after_um, self.tolerance_um)

    def to_dict(self) -> dict:
        """JSON-ready dictionary."""
        return {"quantity": self.quantity, "tolerance_um": self.tolerance_um,
                "before_um": self.before_um, "after_um": self.after_um,
                "before": self.before, "after": self.after}
