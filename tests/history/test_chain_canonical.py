"""The chain's hash: a stored result reads back to the same hash."""

from __future__ import annotations

from volcal.history.chain import record_hash


def _hash(value: float) -> str:
    rec = {"seq": 1, "id": "C000001", "payload": "{}"}
    res = [{"name": "EC0Y", "value": value, "U": 0.5, "unit": "urad"}]
    return record_hash("0" * 64, rec, [], res, [])


def test_negative_zero_hashes_as_zero():
    """SQLite reads a stored -0.0 result back as 0.0 (the squareness of a session of one
    line is -0.0): the record's hash must not change by the round trip."""
    assert _hash(-0.0) == _hash(0.0)
    assert _hash(-1e-9) != _hash(1e-9)  # only zero is folded
