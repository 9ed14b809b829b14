"""The column-wise reading of a table gives what the row-wise reading gives, bit for bit.

Session 21: ``parse_table`` reads each column in one pass (``_column_fast``) and falls back
to the row-wise reading (``_read_rows``) at the first cell or row either refuses, so that a
mistake is named at its first file, row and column. Random tables of valid and invalid
cells, read both ways, give the same arrays, marks and extra fields, or the same message.
"""

from __future__ import annotations

import contextlib
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import volcal.io.table as tbl
from volcal.errors import VolcalInputError
from volcal.io.table import Column, TableSpec, parse_table

SPEC = TableSpec((Column("x_mm", min=-10.0, max=1000.0), Column("run", kind="int", min=1),
                  Column("direction", kind="choice", choices=("+", "-")),
                  Column("deviation_um", abs_max=1e4, markers=("missed",), empty=True),
                  Column("note", kind="str", required=False, empty=True)),
                 delimiters=",;", decimal_comma=True, extra_fields=True)
CELLS = ["0", "1.5", "-2", "\u22123.25", "1e3", "2000", "-11", "nan", "inf", "1e400", "abc",
         "", " 7 ", "missed", "MISSED", "+", "-", "3,5", "9" * 400, "0x10", "1_000"]


def _slow(*a, **k):
    raise tbl._Slow


def _read(text: str, columnwise: bool):
    with contextlib.nullcontext() if columnwise else mock.patch.object(tbl, "_read_fast",
                                                                         _slow):
        try:
            t = parse_table(text, SPEC, "t.csv")
        except VolcalInputError as exc:
            return str(exc)
    return ({k: v for k, v in t.columns.items()}, {k: v.tolist() for k, v in t.marked.items()},
            t.extra)


VALID = [["0", "1.5", "\u22123.25", "1e3", " 7 ", "3,5"], ["1", "2", " 3", "1_000"],
         ["+", "-", " + "], ["0", "-2", "1.5", "missed", "MISSED", "", "3,5"],
         ["", "a note", "1"]]
_ROW = st.tuples(*(st.sampled_from(v * 30 + CELLS) for v in VALID)).map(list)


@settings(max_examples=300, deadline=None)
@given(rows=st.lists(st.one_of(_ROW, _ROW, _ROW,
                               st.lists(st.sampled_from(CELLS), min_size=4, max_size=6)),
                     min_size=1, max_size=8),
       delim=st.sampled_from([",", ";"]))
def test_columnwise_equals_rowwise(rows, delim):
    lines = [delim.join(["x_mm", "run", "direction", "deviation_um", "note"])]
    lines += [delim.join(r) for r in rows]
    text = "\n".join(lines) + "\n"
    a, b = _read(text, True), _read(text, False)
    if isinstance(a, str) or isinstance(b, str):
        assert a == b
        return
    assert a[1:] == b[1:] and set(a[0]) == set(b[0])
    for k in a[0]:
        assert a[0][k].dtype == b[0][k].dtype
        if a[0][k].dtype.kind == "f":
            np.testing.assert_array_equal(a[0][k], b[0][k])  # NaN equal to NaN, bit values
        else:
            assert a[0][k].tolist() == b[0][k].tolist()


def test_a_valid_table_is_read_columnwise_and_a_mistake_named_first_in_the_file(monkeypatch):
    text = "x_mm,run,direction,deviation_um\n0,1,+,0\n100,1,+,missed\n200,x,+,1\n300,1,?,2\n"
    with pytest.raises(VolcalInputError) as exc:
        parse_table(text, SPEC, "t.csv")
    assert str(exc.value) == "t.csv, row 4, column 'run': expected a whole number, got 'x'"
    calls = []
    real = tbl._column_fast
    monkeypatch.setattr(tbl, "_column_fast", lambda *a: calls.append(1) or real(*a))
    t = parse_table(text.replace("200,x,+,1\n300,1,?,2\n", "200,2,-,1\n"), SPEC, "t.csv")
    assert len(calls) == 4 and t.marked["deviation_um"].tolist() == [False, True, False]
    np.testing.assert_array_equal(t["deviation_um"], [0.0, np.nan, 1.0])
