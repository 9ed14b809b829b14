"""The optional parts of volcal and the extras that install them.

``pip install volcal`` gives the core (plan, program, simulate, import, identify,
evaluate, compensate, report, certificate). Two extras add libraries the core never
imports (``docs/architecture.md``):

* ``volcal[history]``: the calibration history (SQLAlchemy, Alembic, psycopg for
  PostgreSQL, pandas for its tables, pyarrow for ``volcal history export``);
* ``volcal[dataframe]``: pandas, for the results' ``to_dataframe()``.

A part whose extra is missing says which extra to install (:func:`require_extra`): a
user error (exit code 2 on the command line), never a traceback.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable

from volcal.errors import VolcalInputError

__all__ = ["EXTRAS", "HISTORY_STORE", "MissingExtraError", "missing_modules", "require_extra"]

EXTRAS: dict[str, tuple[str, ...]] = {
    "history": ("sqlalchemy", "alembic", "psycopg", "pandas", "pyarrow"),
    "dataframe": ("pandas",),
    "capture": ("asyncua", "aiohttp"),
}
"""Extra -> the top-level modules it installs (``pyproject.toml``, optional dependencies)."""

HISTORY_STORE: tuple[str, ...] = ("sqlalchemy", "alembic", "pandas")
"""The modules of the ``history`` extra every use of the store needs (psycopg only for
PostgreSQL, pyarrow only for ``volcal history export``)."""


class MissingExtraError(VolcalInputError):
    """A part of volcal was used without the extra that installs its libraries.

    Parameters
    ----------
    what : str
        The part used, as the user named it (``'volcal history'``, ``'History'``).
    extra : str
        The extra to install (a key of :data:`EXTRAS`).
    missing : list of str
        The modules that cannot be imported.
    """

    def __init__(self, what: str, extra: str, missing: list[str]) -> None:
        self.extra = extra
        self.missing = list(missing)
        super().__init__(f"{what} needs the '{extra}' extra: pip install 'volcal[{extra}]' "
                         f"(not installed: {', '.join(missing)})")


def missing_modules(modules: Iterable[str]) -> list[str]:
    """The modules of ``modules`` that cannot be found (nothing is imported).

    Parameters
    ----------
    modules : iterable of str
        Top-level module names.

    Returns
    -------
    list of str
        Those without an import spec (not installed, or blocked: ``None`` in
        ``sys.modules``), in the order given.
    """
    out = []
    for name in modules:
        try:
            found = importlib.util.find_spec(name) is not None
        except (ImportError, ValueError):  # a broken or half-imported package
            found = False
        if not found:
            out.append(name)
    return out


def require_extra(extra: str, what: str, modules: Iterable[str] | None = None) -> None:
    """Refuse to go on when an extra's libraries are missing.

    Parameters
    ----------
    extra : str
        The extra (a key of :data:`EXTRAS`).
    what : str
        The part of volcal about to use them, for the message (``'volcal history'``).
    modules : iterable of str, optional
        The modules needed now; by default every module of the extra.

    Raises
    ------
    MissingExtraError
        One of them cannot be imported: the message names the extra and the pip command.
    """
    missing = missing_modules(EXTRAS[extra] if modules is None else modules)
    if missing:
        raise MissingExtraError(what, extra, missing)
