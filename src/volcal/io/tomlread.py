"""Read a TOML file a user wrote, with one kind of error for every way it can fail."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from volcal.errors import VolcalInputError

__all__ = ["read_toml"]


def read_toml(path: str | Path, what: str) -> tuple[dict[str, Any], str]:
    """The parsed document and the text of a TOML file.

    Parameters
    ----------
    path : str or Path
        The file.
    what : str
        What the file is, for the messages (``"budget file"``).

    Returns
    -------
    doc : dict
        The document (``tomllib``).
    text : str
        The file's text (to name the line of a key in later errors).

    Raises
    ------
    VolcalInputError
        ``no such <what>``, ``cannot read the <what>: ...`` (permissions, a folder, not
        UTF-8) or ``invalid TOML: ...`` (with tomllib's line and column), naming the file.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise VolcalInputError(f"no such {what}", path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise VolcalInputError(f"cannot read the {what}: {exc}", path) from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise VolcalInputError(f"invalid TOML: {exc}", path) from None
