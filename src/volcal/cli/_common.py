"""Small parsing helpers shared by the CLI modules."""

from __future__ import annotations

import numpy as np

from volcal.errors import VolcalInputError


def parse_travel(text: str) -> np.ndarray:
    """Parse ``'0:800,0:600,0:500'`` into a (3, 2) array [mm]."""
    parts = text.split(",")
    if len(parts) != 3:
        raise VolcalInputError(f"--travel {text!r}: expected three ranges min:max,min:max,min:max")
    out = np.empty((3, 2))
    for i, p in enumerate(parts):
        try:
            lo, hi = (float(v) for v in p.split(":"))
        except ValueError:
            raise VolcalInputError(f"--travel {text!r}: range {p!r} is not min:max in mm") from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            raise VolcalInputError(f"--travel {text!r}: range {p!r} needs max > min")
        out[i] = lo, hi
    return out


def parse_vector(text: str, option: str) -> np.ndarray:
    """Parse ``'x,y,z'`` into a (3,) array."""
    try:
        v = np.array([float(s) for s in text.split(",")])
    except ValueError:
        raise VolcalInputError(f"{option} {text!r}: expected three numbers x,y,z") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise VolcalInputError(f"{option} {text!r}: expected three finite numbers x,y,z")
    return v


def print_session_notes(session: object) -> None:
    """Print a session's reader notes and plausibility warnings on stderr, one a line.

    Stderr, so that ``--json`` outputs on stdout stay valid JSON.

    Parameters
    ----------
    session : Session
        As returned by :func:`volcal.session.format.read_session`.
    """
    from rich.console import Console
    from rich.markup import escape

    err = Console(stderr=True, soft_wrap=True)
    for n in getattr(session, "notes", []):
        err.print(f"[cyan]note:[/] {escape(n)}", highlight=False)
    for w in getattr(session, "warnings", []):
        err.print(f"[yellow]warning:[/] {escape(w)}", highlight=False)
