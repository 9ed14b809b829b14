"""The calibration history: every machine and calibration kept, trends, change tests.

A layer on top of the core (``import volcal`` never loads it): SQLAlchemy 2 with
Alembic migrations, SQLite by default, PostgreSQL by URL (psycopg 3). See
``docs/history.md``.
"""

from volcal.history.api import History

__all__ = ["History"]
