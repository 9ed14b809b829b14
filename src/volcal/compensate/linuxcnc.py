"""LinuxCNC joint compensation files (``[JOINT_n] COMP_FILE``, ``COMP_FILE_TYPE``).

LinuxCNC reads a compensation file per joint at start-up (``usrmotLoadComp``,
``src/emc/motion/usrmotintf.cc``): one entry per line, three numbers separated by
blanks; it **stops at the first line that is not three numbers**, so the files have no
header and no comment. The entries must be strictly increasing in the nominal
position and at most ``EMCMOT_COMP_SIZE`` = 256 per joint (``src/emc/motion/command.c``,
``EMCMOT_SET_JOINT_COMP``). Between entries the motion controller interpolates the
trim linearly and adds it to the joint's commanded position; the forward trim is
used while the joint moves in the positive direction, the reverse trim while it moves
in the negative direction.

* ``COMP_FILE_TYPE = 1`` (volcal's default): ``nominal forward_trim reverse_trim`` [mm],
  the trim being the amount LinuxCNC adds to the command, i.e. the **correction**
  ``-error``;
* ``COMP_FILE_TYPE = 0``: ``nominal actual_forward actual_reverse`` [mm]: the position
  the joint actually reaches when commanded to ``nominal``, i.e. ``nominal + error``;
  LinuxCNC converts it to the trim ``nominal - actual``.

Both types carry the same correction: type 1 is the plain one. The nominal positions are
the model's coordinates, which must be the joint coordinates of the machine (the
README written beside the tables says so).

References
----------
LinuxCNC documentation, "INI Configuration", section ``[JOINT_<num>]``: ``COMP_FILE``,
``COMP_FILE_TYPE``; LinuxCNC source ``src/emc/motion/usrmotintf.cc`` (``usrmotLoadComp``)
and ``src/emc/motion/command.c`` (256 entries, increasing order).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from volcal.compensate.reference import reference_line_notes
from volcal.compensate.tables import AxisTable, axis_grid, require_finite, sign_factor
from volcal.errors import ParameterError
from volcal.model.errorfunctions import MachineErrors
from volcal.model.names import AXES

MAX_ENTRIES = 256
"""``EMCMOT_COMP_SIZE``: entries per joint."""
RESOLUTION_UM = 0.001
"""Values written with 6 decimals in mm."""
DEFAULT_SIGN = "correction"
SIGN_SOURCE = ("LinuxCNC usrmotintf.cc usrmotLoadComp: type 1 trims are added to the "
               "command; type 0 columns are actual positions, trim = nominal - actual")
README_FILE = "README.txt"


def linuxcnc_files(errors: MachineErrors, spacing: float, sign: str = DEFAULT_SIGN,
                   comp_type: int = 1, max_points: int = MAX_ENTRIES, directional=None
                   ) -> dict[str, str]:
    """``X.comp``, ``Y.comp``, ``Z.comp`` and ``README.txt`` for LinuxCNC.

    Parameters
    ----------
    errors : MachineErrors
        The model.
    spacing : float
        Distance between entries [mm].
    sign : str
        ``'correction'`` (default, what LinuxCNC expects) or ``'error'`` (only to
        inspect the table: loading it would double the error).
    comp_type : int
        ``COMP_FILE_TYPE``: 1 (trims, default) or 0 (actual positions).
    max_points : int
        Entries allowed per joint (256 in LinuxCNC).
    directional : DirectionalErrors, optional
        Measured reversal: forward and reverse columns differ by it.

    Returns
    -------
    dict of str to str
        File name -> content.
    """
    s = sign_factor(sign)
    if comp_type not in (0, 1):
        raise ParameterError(f"{{linuxcnc_type=}}{comp_type}: expected 0 or 1")
    if max_points > MAX_ENTRIES:
        raise ParameterError(f"{{max_points=}}{max_points}: LinuxCNC holds at most "
                             f"{MAX_ENTRIES} entries per joint")
    files: dict[str, str] = {}
    for k in range(3):
        lo, hi = errors.travel[k]
        p = axis_grid(lo, hi, spacing, max_points=max_points, what=f"LinuxCNC {AXES[k]}")
        e = errors.component(k, p)[:, k]
        half = directional.half_reversal(k, p) if directional is not None else 0.0 * p
        fwd_um, rev_um = s * (e + half), s * (e - half)
        require_finite(np.column_stack([fwd_um, rev_um]), p, f"LinuxCNC {AXES[k]}.comp")
        # the trim column holds the table in its sign (correction: -error)
        if comp_type == 1:
            lines = [f"{x:.6f} {tf / 1000.0:.6f} {tr / 1000.0:.6f}"
                     for x, tf, tr in zip(p, fwd_um, rev_um, strict=True)]
        else:  # actual = nominal - trim
            lines = [f"{x:.6f} {x - tf / 1000.0:.6f} {x - tr / 1000.0:.6f}"
                     for x, tf, tr in zip(p, fwd_um, rev_um, strict=True)]
        files[f"{AXES[k]}.comp"] = "\n".join(lines) + "\n"
    files[README_FILE] = _readme(errors, spacing, sign, comp_type, directional)
    return files


def _readme(errors: MachineErrors, spacing: float, sign: str, comp_type: int,
            directional) -> str:
    lines = [
        f"volcal: LinuxCNC joint compensation (COMP_FILE_TYPE = {comp_type})",
        "",
        "Add to the machine's INI file (joint numbers as in your configuration):",
    ]
    for k, a in enumerate(AXES):
        lines += ["", f"[JOINT_{k}]", f"COMP_FILE = {a}.comp", f"COMP_FILE_TYPE = {comp_type}"]
    lines += [
        "",
        "Columns: " + ("nominal [mm], forward trim [mm], reverse trim [mm]; the trim is added "
                       "to the commanded joint position." if comp_type == 1 else
                       "nominal [mm], actual position moving forward [mm], actual position "
                       "moving in reverse [mm]; LinuxCNC adds nominal - actual."),
        f"Sign: {sign}" + (" (trim = -error)." if sign == "correction" else
                           " (trim = +error: loading this DOUBLES the error; for inspection "
                           "only)."),
        f"Source: {SIGN_SOURCE}.",
        f"Entries every {spacing:g} mm over the travel "
        + ", ".join(f"{a} {errors.travel[k, 0]:g}..{errors.travel[k, 1]:g}"
                    for k, a in enumerate(AXES))
        + " mm (the model's coordinates: they must be the joint coordinates after homing).",
        f"Limits: at most {MAX_ENTRIES} entries per joint, strictly increasing nominal.",
        "Forward and reverse differ by the reversal measured in the session's ISO 230-2 "
        "tests (" + (directional.source or "none") + ")." if directional is not None else
        "Forward = reverse: no bidirectional linear tests were given (--session).",
        *(directional.notes() if directional is not None else []),
        "Do not set BACKLASH together with a bidirectional table (it would be applied twice).",
        "Restart LinuxCNC to load. Check one point where the trim is large: the deviation "
        "must shrink, not double.",
        "Not corrected: straightness, squareness and angular (Abbe) errors.",
        "",
        *reference_line_notes(errors),
    ]
    return "\n".join(lines) + "\n"


def load_linuxcnc_comp(path: str | Path, comp_type: int = 1
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Load a comp file the way LinuxCNC does: triplets until the first other line.

    Parameters
    ----------
    path : str or Path
        ``X.comp`` etc.
    comp_type : int
        ``COMP_FILE_TYPE`` (0 or 1).

    Returns
    -------
    nominal, forward_trim, reverse_trim : ndarray
        Positions [mm] and trims [mm] (what LinuxCNC adds to the command).
    """
    rows = []
    for line in Path(path).read_text(encoding="ascii").splitlines():
        parts = line.split()
        try:
            vals = [float(v) for v in parts[:3]]
        except ValueError:
            break
        if len(vals) != 3:
            break
        rows.append(vals)
    a = np.array(rows, dtype=float).reshape(-1, 3)
    nom, f, r = a[:, 0], a[:, 1], a[:, 2]
    if comp_type == 0:
        f, r = nom - f, nom - r
    return nom, f, r


def read_linuxcnc(folder: str | Path, sign: str = DEFAULT_SIGN, comp_type: int = 1,
                  direction: str = "+") -> list[AxisTable]:
    """Read ``X.comp``, ``Y.comp``, ``Z.comp`` back into tables in ``sign``.

    Parameters
    ----------
    folder : str or Path
        Folder written by :func:`linuxcnc_files`.
    sign : str
        Sign the tables were written with.
    comp_type : int
        ``COMP_FILE_TYPE``.
    direction : str
        ``'+'`` forward trims, ``'-'`` reverse trims.

    Returns
    -------
    list of AxisTable
        Values [um] in ``sign``.
    """
    out = []
    for k, a in enumerate(AXES):
        nom, f, r = load_linuxcnc_comp(Path(folder) / f"{a}.comp", comp_type)
        trim = f if direction == "+" else r
        out.append(AxisTable(k, k, nom, trim * 1000.0, sign, RESOLUTION_UM))
    return out
