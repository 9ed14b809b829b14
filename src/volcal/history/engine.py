"""Open a history store: engine, schema at the head revision, clear errors.

SQLite and PostgreSQL are driven through the same code; the differences are here:
inserts are serialised by ``BEGIN IMMEDIATE`` on SQLite and by a transaction-level
advisory lock on PostgreSQL, so that concurrent writers never fork the chain.
"""

from __future__ import annotations

import threading
from pathlib import Path

from volcal.errors import VolcalInputError

#: Key of the PostgreSQL advisory lock taken by every insert (``pg_advisory_xact_lock``).
ADVISORY_LOCK_KEY = 0x766F6C63  # "volc"
HEAD = "0004"
#: Alembic keeps its migration context in module globals: one migration at a time per
#: process (threads opening stores at once); across processes the database lock serialises.
_ALEMBIC_LOCK = threading.Lock()


def _alembic_config(connection):
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(Path(__file__).with_name("migrations")))
    cfg.attributes["connection"] = connection
    return cfg


def make_engine(url: str, create: bool = True):
    """A SQLAlchemy engine for ``url`` with volcal's locking and time-outs.

    Parameters
    ----------
    url : str
        SQLAlchemy URL (:func:`volcal.history.url.resolve_url`).
    create : bool
        Create the folder of an SQLite file (``False``: refuse a folder or file that does
        not exist).

    Returns
    -------
    sqlalchemy.engine.Engine

    Raises
    ------
    VolcalInputError
        A malformed URL, an unknown database kind, a missing driver, a folder that
        cannot be created.
    """
    from sqlalchemy import create_engine, event
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError
    from sqlalchemy.pool import NullPool

    from volcal.history.url import describe

    try:
        if url.startswith("sqlite"):
            path = url.split(":///", 1)[1] if ":///" in url else ""
            if path and path != ":memory:" and not create:
                _require_file(Path(path))
            elif path and path != ":memory:":
                try:
                    Path(path).parent.mkdir(parents=True, exist_ok=True)
                except OSError as exc:
                    raise VolcalInputError(f"cannot create the folder of the history "
                                           f"database ({exc.strerror})", path) from None
            engine = create_engine(url, poolclass=NullPool, connect_args={"timeout": 60})

            @event.listens_for(engine, "connect")
            def _connect(dbapi_conn, _rec):  # take transactions out of pysqlite's hands
                dbapi_conn.isolation_level = None
                dbapi_conn.execute("PRAGMA foreign_keys = ON")

            @event.listens_for(engine, "begin")
            def _begin(conn):  # writers: one at a time, from the first statement
                write = conn.get_execution_options().get("volcal_write", False)
                conn.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")

            return engine
        if url.startswith("postgresql"):
            return create_engine(url, poolclass=NullPool)
    except (ArgumentError, NoSuchModuleError) as exc:
        raise VolcalInputError(f"cannot use the history database {describe(url)}: {exc}") \
            from None
    raise VolcalInputError(f"history database {describe(url)}: expected a file path, "
                           "sqlite:///FILE or postgresql://USER@HOST/DB")


def _require_file(path: Path) -> None:
    """Refuse an SQLite history that does not exist (a store is created only on request)."""
    if not path.parent.is_dir():
        raise VolcalInputError(f"no history here: the folder {path.parent} does not exist "
                               "(a typo? volcal history add --create makes a new store)",
                               path)
    if not path.is_file():
        raise VolcalInputError("no history file here (a typo? volcal history add --create "
                               "makes a new store)", path)


def lock(conn) -> None:
    """Serialise writers inside the current transaction (PostgreSQL advisory lock).

    On SQLite the transaction itself is the lock (``BEGIN IMMEDIATE``).

    Parameters
    ----------
    conn : Connection
        A connection inside a transaction.
    """
    if conn.dialect.name == "postgresql":
        from sqlalchemy import text

        conn.execute(text("SELECT pg_advisory_xact_lock(:k)"), {"k": ADVISORY_LOCK_KEY})


def open_engine(url: str, upgrade: bool = True, create: bool = True):
    """An engine whose database is a volcal history at the head revision.

    An empty database is given the schema; an older volcal schema is upgraded (Alembic);
    anything else is refused.

    Parameters
    ----------
    url : str
        SQLAlchemy URL.
    upgrade : bool
        Create or upgrade the schema (``False``: refuse a database not at the head).
    create : bool
        Make a new store: an SQLite file (and its folder) that does not exist, the schema
        in an empty database (``False``: refuse them).

    Returns
    -------
    sqlalchemy.engine.Engine
        Its attribute ``volcal_created`` is true when this call made a new store.

    Raises
    ------
    VolcalInputError
        Not a database (a corrupted or foreign file), a database of another program, a
        newer volcal schema, a server that cannot be reached.
    """
    from sqlalchemy import inspect, text
    from sqlalchemy.exc import DatabaseError, OperationalError

    from volcal.history.url import describe

    engine = make_engine(url, create)
    where = describe(url)
    created = False
    try:
        # a store at the head revision is only read here: the writers' lock is a write
        # transaction, and on an SQLite file whose header is damaged (its page count, at
        # offset 28) committing one rewrites the header: a reader must write nothing
        # (found by the store fuzz run: garbage at offset 27)
        with engine.connect() as conn:
            names = set(inspect(conn).get_table_names())
            if "alembic_version" in names:
                version = conn.execute(text("SELECT version_num FROM alembic_version")).scalar()
                if version == HEAD:
                    _check_schema(names, version, upgrade, where)
                    engine.volcal_created = False
                    return engine
        # one transaction under the writers' lock: look, then create or upgrade the
        # schema, so that writers opening a new store at once never both create it
        with writer(engine) as conn:
            lock(conn)
            names = set(inspect(conn).get_table_names())
            if not names:
                _refuse_truncated(url, where)
            version = None
            if "alembic_version" in names:
                version = conn.execute(text("SELECT version_num FROM alembic_version")).scalar()
            _check_schema(names, version, upgrade, where)
            if not names and not create:
                raise VolcalInputError("this database holds no volcal history (volcal "
                                       "history add --create makes one there)", where)
            created = not names
            if version != HEAD:
                from alembic import command

                with _ALEMBIC_LOCK:  # alembic's migration context is process-global
                    command.upgrade(_alembic_config(conn), "head")
            conn.commit()
    except (DatabaseError, OperationalError) as exc:
        msg = str(exc.orig) if getattr(exc, "orig", None) is not None else str(exc)
        raise VolcalInputError(f"not a usable history database ({msg.splitlines()[0]})",
                               where) from None
    engine.volcal_created = created
    return engine


def _refuse_truncated(url: str, where: str) -> None:
    """Refuse an SQLite file that holds bytes but no table.

    SQLite reads a file shorter than its header as an empty database: a truncated store
    would be given a new schema.
    """
    if not url.startswith("sqlite") or ":///" not in url:
        return
    path = Path(url.split(":///", 1)[1])
    size = path.stat().st_size if path.is_file() else 0
    if size > 0:
        raise VolcalInputError(f"not a usable history database (a file of {size} bytes "
                               "without a table: truncated, or not a database)", where)


def _check_schema(names: set[str], version: str | None, upgrade: bool, where: str) -> None:
    """Refuse a database of another program, a newer schema, or an old one without upgrade."""
    others = names - {"alembic_version", "records", "files", "results", "equipment"}
    if names and (version is None or others):
        raise VolcalInputError("this database holds tables of another program "
                               f"({', '.join(sorted(names))[:200]}), not a volcal history",
                               where)
    if version not in (None, "0001", "0002", "0003", HEAD):
        raise VolcalInputError(f"history schema revision {version!r} is unknown to this "
                               f"volcal (head {HEAD}): a newer volcal wrote it", where)
    if version != HEAD and not upgrade:
        raise VolcalInputError(f"history schema at revision {version}, not {HEAD}", where)


def writer(engine):
    """A connection whose transactions take the writers' lock (use as a context manager).

    Parameters
    ----------
    engine : Engine
        The store's engine.
    """
    return engine.connect().execution_options(volcal_write=True)


def migrate(engine, revision: str = "head") -> None:
    """Upgrade the schema to ``revision`` (Alembic), under the writers' lock.

    Parameters
    ----------
    engine : Engine
        The store's engine.
    revision : str
        Target revision (``head``, ``0001``, ...).
    """
    from alembic import command

    with writer(engine) as conn:
        lock(conn)
        with _ALEMBIC_LOCK:
            command.upgrade(_alembic_config(conn), revision)
        conn.commit()
