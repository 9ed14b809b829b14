"""Session files: the open format every volcal command reads (``docs/formats.md``)."""

from volcal.session.format import (
    KINDS,
    SESSION_FORMAT,
    TARGETS,
    Measurement,
    Session,
    read_measurement_csv,
    read_session,
    write_session,
)

__all__ = [
    "KINDS",
    "SESSION_FORMAT",
    "TARGETS",
    "Measurement",
    "Session",
    "read_measurement_csv",
    "read_session",
    "write_session",
]
