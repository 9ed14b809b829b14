"""Where the history is: ``--db`` wins over ``VOLCAL_DB``, which wins over the default path."""

from __future__ import annotations

import os
from pathlib import Path

from volcal.extras import require_extra

ENV_VAR = "VOLCAL_DB"


def default_path() -> Path:
    """The default SQLite file: ``$XDG_DATA_HOME/volcal/history.sqlite``.

    ``XDG_DATA_HOME`` defaults to ``~/.local/share`` (XDG Base Directory
    Specification).

    Returns
    -------
    Path
    """
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "volcal" / "history.sqlite"


def resolve_url(db: str | None = None) -> str:
    """The SQLAlchemy URL of the store.

    Parameters
    ----------
    db : str, optional
        ``--db``: a URL (``postgresql://user@host/db``, ``sqlite:///file``) or a file path
        (an SQLite file).

    Returns
    -------
    str
        A SQLAlchemy URL; PostgreSQL URLs are given the psycopg 3 driver
        (``postgresql+psycopg://``).
    """
    value = db or os.environ.get(ENV_VAR) or str(default_path())
    if "://" not in value:
        return f"sqlite:///{Path(value).expanduser().resolve()}"
    for plain in ("postgresql://", "postgres://"):
        if value.startswith(plain):
            require_extra("history", "a PostgreSQL history", ("psycopg",))
            return "postgresql+psycopg://" + value[len(plain):]
    return value


def describe(url: str) -> str:
    """The URL without its password, for messages.

    Parameters
    ----------
    url : str
        SQLAlchemy URL.
    """
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except Exception:  # noqa: BLE001 - a malformed URL is reported by open_store
        return url
