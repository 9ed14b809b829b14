"""What a file given as a model is: an identified model (JSON) or an error table (CSV).

``volcal identify -o NAME`` writes the model where it is told, with or without the
``.json`` suffix (``NAME`` and ``NAME.npz`` beside it). Every command that takes either an
identified model or an error table (``compensate``, ``evaluate volumetric``, ``report
--model``, ``locate``, ``history add``) asks :func:`is_model_file`, so that a model
named without the suffix is read as the model it is, not as a table with a broken
header.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["is_model_file", "model_path"]

_BOM = b"\xef\xbb\xbf"


def is_model_file(path: str | Path) -> bool:
    """Whether ``path`` is read as an identified model rather than an error table.

    Parameters
    ----------
    path : str or Path
        A file named as a model.

    Returns
    -------
    bool
        True for the suffix ``.json``; False for ``.csv``; for any other suffix (or none),
        True when the file's first character other than white space (and a UTF-8 byte
        order mark) is ``{``, the start of a JSON object. A missing or unreadable file
        is False (the table reader then names the problem).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in (".json", ".csv"):
        return suffix == ".json"
    try:
        with p.open("rb") as f:
            head = f.read(256)
    except OSError:
        return False
    return head.removeprefix(_BOM).lstrip().startswith(b"{")


def model_path(path: str | Path) -> Path:
    """``path`` as a model or error table to read, or the error that says why it is none.

    The one check of every reader of a model or error table
    (:func:`volcal.identify.modelfile.load_model`,
    :func:`volcal.compensate.source.load_errors`).

    Parameters
    ----------
    path : str or Path
        What was given as a model.

    Returns
    -------
    Path
        ``path``, a file.

    Raises
    ------
    VolcalInputError
        ``'model file not found'``, or for a folder what it is and what to give instead:
        a session folder is identified first (``volcal identify``), another folder is no
        model.
    """
    from volcal.errors import VolcalInputError

    p = Path(path)
    if p.is_file():
        return p
    if not p.is_dir():
        raise VolcalInputError("model file not found", p)
    if (p / "session.toml").is_file():
        raise VolcalInputError(f"a session folder, not a model: identify it first "
                               f"(volcal identify {p} -o model.json) and give the model", p)
    raise VolcalInputError("a folder, not a model file (an identified model .json or an error "
                           "table .csv)", p)
