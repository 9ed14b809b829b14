"""LinuxCNC joint screw compensation: ``X.comp``, ``Y.comp``, ``Z.comp`` and ``README.txt``.

LinuxCNC loads one file per joint (INI ``[JOINT_n] COMP_FILE``, ``COMP_FILE_TYPE``).
Each line holds three numbers separated by white space, in machine units (mm here):

* ``COMP_FILE_TYPE = 1``: nominal position, forward trim, reverse trim. The trim is
  the amount LinuxCNC adds to the commanded position while the joint moves in that
  direction, so it is the **correction** (the negative of the ISO 230-1 error).
* ``COMP_FILE_TYPE = 0``: nominal position, actual position when approached in the
  forward direction, actual position in reverse. LinuxCNC converts to trims as
  ``trim = nominal - actual``.

The loader (``usrmotLoadComp`` in ``src/emc/motion/usrmotintf.cc``) stops silently
at the first line that is not three numbers, so these files carry no header and no
comment. The table holds at most ``EMCMOT_COMP_SIZE`` = 256 entries, nominal
positions strictly increasing; motion interpolates the trim linearly between entries
(choosing the forward or reverse trim from the direction of motion) and holds the
end values outside the table.

References
----------
LinuxCNC source, ``src/emc/motion/usrmotintf.cc`` (``usrmotLoadComp``),
``src/emc/motion/command.c`` (``EMCMOT_SET_JOINT_COMP``), ``src/emc/motion/control.c``
(``compute_screw_comp``). LinuxCNC documentation, "INI Configuration", section
``[JOINT_<num>]``, keys ``COMP_FILE`` and ``COMP_FILE_TYPE``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.compensate.tables import AxisTable, axis_grid, pitch_table, quantize
from volcal.errors import VolcalInputError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

MAX_ENTRIES = 256
RESOLUTION_UM = 0.001
README = "README.txt"


def comp_file(axis: int) -> str:
    """File name of an axis (``'X.comp'``...).

    Parameters
    ----------
    axis : int
        0, 1, 2 = X, Y, Z.

    Returns
    -------
    str
    """
    return f"{AXES[axis]}.comp"


def linuxcnc_files(errors: MachineErrors, spacing: float, sign: str = "correction",
                   max_points: int = MAX_ENTRIES, file_type: int = 1,
                   reversal_um=None) -> dict[str, str]:
    """LinuxCNC compensation files of the positioning errors of X, Y, Z.

    Parameters
    ----------
    errors : MachineErrors
        The model (its positioning errors are the bidirectional mean).
    spacing : float
        Distance between entries [mm].
    sign : str
        ``'correction'`` (LinuxCNC's own convention: the trim is added to the command)
        or ``'error'`` (override: writes the negative, for controls configured so).
    max_points : int
        Entries per file, at most 256 (``EMCMOT_COMP_SIZE``).
    file_type : int
        ``COMP_FILE_TYPE``: 1 (trims) or 0 (actual positions).
    reversal_um : sequence of 3 callables, optional
        Per axis, ``f(positions [mm]) -> reverse minus forward error [um]`` (from the
        bidirectional ISO 230-2 runs, :mod:`volcal.compensate.bidirectional`); forward
        gets ``-r/2``, reverse ``+r/2``; default none (forward = reverse).

    Returns
    -------
    dict of str to str
        File name -> content.
    """
    if file_type not in (0, 1):
        raise VolcalInputError(f"--linuxcnc-type {file_type}: expected 0 or 1")
    if max_points > MAX_ENTRIES:
        raise VolcalInputError(f"--max-points {max_points}: LinuxCNC holds at most "
                               f"{MAX_ENTRIES} entries per joint")
    out: dict[str, str] = {}
    for k in range(3):
        p = axis_grid(*errors.travel[k], spacing, max_points=max_points,
                      what=f"LinuxCNC {AXES[k]}")
        fwd = pitch_table(errors, k, p, sign, RESOLUTION_UM).values
        rev = fwd.copy()
        if reversal_um is not None and reversal_um[k] is not None:
            # the model is the bidirectional mean: forward - r/2, reverse + r/2
            s = 1.0 if sign == "error" else -1.0
            half = s * np.asarray(reversal_um[k](p), dtype=float) / 2.0
            fwd, rev = quantize(fwd - half, RESOLUTION_UM), quantize(fwd + half, RESOLUTION_UM)
        if np.any(np.diff(p) <= 0):  # axis_grid is uniform; kept as a guard
            raise VolcalInputError(f"LinuxCNC {AXES[k]}: positions not strictly increasing")
        lines = []
        for pos, f, r in zip(p, fwd, rev, strict=True):
            if file_type == 1:
                a, b = f / 1000.0, r / 1000.0
            else:  # actual = nominal - trim; trim = -error for sign 'correction'
                a, b = pos - f / 1000.0, pos - r / 1000.0
            lines.append(f"{pos:.6f} {a:.6f} {b:.6f}")
        out[comp_file(k)] = "\n".join(lines) + "\n"
    out[README] = _readme(file_type, sign, spacing)
    return out


def _readme(file_type: int, sign: str, spacing: float) -> str:
    what = ("nominal, forward trim, reverse trim [mm]; trim = amount added to the command"
            if file_type == 1 else
            "nominal, actual position forward, actual position reverse [mm]")
    lines = ["volcal: LinuxCNC screw compensation of the positioning errors EXX, EYY, EZZ.",
             f"Columns: {what}. Spacing {spacing:g} mm. Sign: {sign}"
             + (" (LinuxCNC's convention)." if sign == "correction"
                else " (OVERRIDE: not LinuxCNC's convention, the trims are the errors)."),
             "The .comp files have no comments: LinuxCNC stops reading at the first line",
             "that is not three numbers. Add to the machine's INI file (joint numbers as",
             "in your configuration; the files must be in the configuration folder):", ""]
    for k in range(3):
        lines += [f"[JOINT_{k}]", f"COMP_FILE = {comp_file(k)}",
                  f"COMP_FILE_TYPE = {file_type}", ""]
    lines += ["Restart LinuxCNC and home the machine; measure one point where the trim is",
              "large: the deviation must shrink, not double. Straightness, angular and",
              "squareness errors stay uncorrected."]
    return "\n".join(lines) + "\n"


def read_linuxcnc(folder: str | Path, file_type: int = 1) -> list[tuple[AxisTable, AxisTable]]:
    """Read ``X.comp``... back as (forward, reverse) trim tables [um], sign 'correction'.

    Parameters
    ----------
    folder : str or Path
        Folder with the ``.comp`` files.
    file_type : int
        ``COMP_FILE_TYPE`` the files were written for.

    Returns
    -------
    list of (AxisTable, AxisTable)
        X, Y, Z; trims as LinuxCNC uses them (added to the command).
    """
    out = []
    for k in range(3):
        path = Path(folder) / comp_file(k)
        try:
            text = path.read_text(encoding="ascii")
        except (OSError, UnicodeDecodeError) as exc:
            raise VolcalInputError(f"cannot read ({exc.__class__.__name__})", path) from None
        rows = []
        for i, line in enumerate(text.splitlines(), start=1):
            parts = line.split()
            try:
                rows.append([float(v) for v in parts])
            except ValueError:
                raise VolcalInputError("expected three numbers", path, i) from None
            if len(parts) != 3:
                raise VolcalInputError("expected three numbers", path, i)
        a = np.array(rows).reshape(-1, 3)
        if file_type == 0:
            a[:, 1:] = a[:, :1] - a[:, 1:]
        out.append((AxisTable(k, k, a[:, 0], a[:, 1] * 1000.0, "correction", RESOLUTION_UM),
                    AxisTable(k, k, a[:, 0], a[:, 2] * 1000.0, "correction", RESOLUTION_UM)))
    return out
