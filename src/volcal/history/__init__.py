"""The calibration history: every machine and calibration kept, trends, change tests.

A layer on top of the core (``import volcal`` never loads it): SQLAlchemy 2 with
Alembic migrations, SQLite by default, PostgreSQL by URL (psycopg 3). See
``docs/history.md``. Its libraries are the ``history`` extra
(``pip install 'volcal[history]'``): without them importing this package raises
:class:`~volcal.extras.MissingExtraError`, which names the extra.
"""

from volcal.extras import HISTORY_STORE, require_extra

require_extra("history", "volcal.history", HISTORY_STORE)

from volcal.history.api import History  # noqa: E402  (after the check of its libraries)

__all__ = ["History"]
