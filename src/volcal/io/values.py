"""Parsing of single values from user files, with errors that locate the value."""

from __future__ import annotations

import math
from pathlib import Path

from volcal.errors import VolcalInputError

__all__ = ["parse_finite"]


def parse_finite(text: str, file: str | Path | None, row: int | None, column: str | None
                 ) -> float:
    """Parse a finite number, or raise an error naming file, row and column.

    Parameters
    ----------
    text : str
        The field as read (surrounding blanks are ignored).
    file : str or Path, optional
        File the field comes from.
    row : int, optional
        1-based row (the header is row 1).
    column : str, optional
        Column name.

    Returns
    -------
    float

    Raises
    ------
    VolcalInputError
        For anything that is not a finite number (empty, text, NaN, inf).
    """
    s = text.strip()
    try:
        v = float(s)
    except ValueError:
        raise VolcalInputError(f"not a number: {s!r}", file, row, column) from None
    if not math.isfinite(v):
        raise VolcalInputError(f"not a finite number: {s!r}", file, row, column)
    return v
