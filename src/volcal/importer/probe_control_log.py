"""Trip points printed by volcal's HEIDENHAIN and Siemens probe_sphere programs.

volcal's probe programs for HEIDENHAIN and Siemens
(:mod:`volcal.program.probe_sphere_controls`) write one line per probed point:

* HEIDENHAIN (``FN 16: F-PRINT`` with the program's format file): ``VOLCAL_TNC X Y Z R1
  R2``, the spindle position at the contact (``Q115``-``Q117``) [mm] and the pose's angles
  (``Q1``, ``Q2``) [deg] in the order of the chain's rotary letters, numbers as ``%10.4LF``
  prints them (right-aligned, 4 decimals);
* Siemens (``WRITE``): ``VOLCAL_840D X Y Z R1 R2``, ``$AA_MM[X]``, ``$AA_MM[Y]``,
  ``$AA_MM[Z]`` as the NC converts a REAL to text, then the pose's angles as the program
  wrote them.

Blank lines are skipped. Any other line, a number that does not parse, a missing or an
extra column are refused, naming the file, the line and the column (``tag``, ``X [mm]``,
..., ``C [deg]``). The
points come back in the layout of LinuxCNC's probe log (``X Y Z A B C U V W``,
:func:`volcal.importer.probe_log.read_linuxcnc_probe_log`), so that one fit serves every
control (:func:`volcal.importer.probe_log.pose_centres`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["LAYOUTS", "control_log_layout", "read_control_probe_log"]

LAYOUTS = {"VOLCAL_TNC": "heidenhain-fn16-log", "VOLCAL_840D": "siemens-write-log"}
"""First word of a line -> the layout named in the imported measurement's ``import.layout``."""
_CONTROL = {"VOLCAL_TNC": "HEIDENHAIN FN 16", "VOLCAL_840D": "Siemens WRITE"}


def _text(path: Path) -> str:
    try:
        return path.read_bytes().decode("latin-1")  # every byte: a stray one is named by row
    except OSError as e:
        raise VolcalInputError(f"cannot read the probe log: {e}", path) from None


def control_log_layout(path: str | Path) -> str | None:
    """The tag of a HEIDENHAIN or Siemens probe log (its first non-blank line's first word).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str or None
        ``'VOLCAL_TNC'``, ``'VOLCAL_840D'``, or None for another file (LinuxCNC's log).
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            head = f.read(4096).decode("ascii", "replace")
    except OSError:
        return None
    for line in head.splitlines():
        if line.strip():
            word = line.split()[0]
            return word if word in LAYOUTS else None
    return None


def read_control_probe_log(path: str | Path, letters: tuple[str, ...]
                           ) -> tuple[NDArray[np.float64], NDArray[np.int64], str]:
    """The probed points of a HEIDENHAIN (``FN 16``) or Siemens (``WRITE``) probe log.

    Parameters
    ----------
    path : str or Path
        The file the program wrote.
    letters : tuple of str
        The chain's rotary letters, in the order the program prints their angles.

    Returns
    -------
    points : ndarray, shape (n, 9)
        ``X Y Z`` [mm], ``A B C`` [deg] (the letters not in the chain 0), ``U V W`` = 0.
    rows : ndarray of int
        Line of each point (1-based).
    layout : str
        ``'heidenhain-fn16-log'`` or ``'siemens-write-log'``.

    Raises
    ------
    VolcalInputError
        A line of another shape, naming the file, line and column.
    """
    p = Path(path)
    tag = control_log_layout(p)
    if tag is None:
        raise VolcalInputError(f"not a probe log of volcal's HEIDENHAIN or Siemens program "
                               f"(lines start with {' or '.join(LAYOUTS)})", p)
    names = ["tag", "X [mm]", "Y [mm]", "Z [mm]"] + [f"{r} [deg]" for r in letters]
    col = {"A": 3, "B": 4, "C": 5}
    pts: list[list[float]] = []
    rows: list[int] = []
    for i, line in enumerate(_text(p).splitlines(), start=1):
        f = line.split()
        if not f:
            continue
        if f[0] != tag:
            raise VolcalInputError(f"expected a line starting with {tag} ({_CONTROL[tag]} of "
                                   f"volcal's program), got {line.strip()[:60]!r}", p, i, "tag")
        if len(f) != len(names):
            missing = names[len(f)] if len(f) < len(names) else f"{len(names) + 1} (extra)"
            raise VolcalInputError(f"expected {len(names)} columns ({', '.join(names)}), got "
                                   f"{len(f)}", p, i, missing)
        v = []
        for j, x in enumerate(f[1:], start=2):
            try:
                y = float(x)
            except ValueError:
                y = math.nan
            if not math.isfinite(y):
                raise VolcalInputError(f"{x!r} is not a number", p, i, names[j - 1])
            v.append(y)
        row = [v[0], v[1], v[2], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        for k, r in enumerate(letters):
            row[col[r]] = v[3 + k]
        pts.append(row)
        rows.append(i)
    if not pts:
        raise VolcalInputError("the probe log holds no probed point", p)
    return np.array(pts), np.array(rows, dtype=np.int64), LAYOUTS[tag]
