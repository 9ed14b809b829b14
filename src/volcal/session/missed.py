"""A missed capture in a measurement file: its marker and the refusal of a missed first row.

``volcal capture`` writes ``missed`` where it took no reading (``docs/capture.md``); the
session readers of the linear kinds (:mod:`volcal.session.format`) and of the rotary test
(:mod:`volcal.session.rotary`) read it, and refuse it in the first row, the reference of
the others. :func:`reading_cells` writes a reading column's cells with it (the CSV writer
and the readings' digest, :mod:`volcal.session.provenance`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["FIRST_ROW_MISSED", "MISSED", "reading_cells"]

MISSED = "missed"
"""The deviation cell (or ``status``) of a reading the capture missed."""

FIRST_ROW_MISSED = ("the first row is the reference of the readings (deviation 0 by "
                    "definition): it cannot be a missed capture; capture the measurement "
                    "again (volcal capture SESSION --measurement ID --again, docs/capture.md)")
"""The session readers' refusal of a file whose first reading was missed."""


def reading_cells(values: NDArray[np.float64], fmt: str) -> list[str]:
    """A reading column's cells as the measurement CSV holds them.

    Parameters
    ----------
    values : ndarray
        The column's values in the file's unit (:meth:`volcal.session.kinds.Kind.csv_values`),
        NaN for a missed reading.
    fmt : str
        The kind's ``str.format`` pattern.

    Returns
    -------
    list of str
        ``fmt`` of each value, ``missed`` for NaN.
    """
    return [MISSED if np.isnan(v) else fmt.format(v) for v in values]
