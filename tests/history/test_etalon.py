"""Etalon exchange format: the published example read with its values; round trip."""

from __future__ import annotations

import re

import numpy as np
import pytest

from volcal.errors import VolcalInputError
from volcal.history.etalon import read_etalon, to_machine_errors, write_etalon

# The programming example of Beckhoff's TF5280 documentation ("Etalon Exchange Format"),
# its rows as printed (the elided middle rows left out).
PUBLISHED = """// Every parameter is specified in a block.
// The block begins with the name of the parameter in square brackets.
[C0B]
VALUE = 0.000022355737
[A0B]
VALUE = 0.000047622950
// Lookup tables are specified via a 2D array called "Gridpoints".
[EXY]
Gridpoints = {
          -280.0 -0.001358635132
          -270.0 -0.000240680764
          -260.0 0.000877273605
           260.0 -0.001297146744
           270.0 -0.000316265101
}  // end of EXY
"""


def test_published_example(tmp_path):
    p = tmp_path / "example.txt"
    p.write_text(PUBLISHED)
    d = read_etalon(p)
    pos, val = d.functions["EXY"]
    assert pos.tolist() == [-280.0, -270.0, -260.0, 260.0, 270.0]
    # mm -> um: -0.001358635132 mm is -1.358635132 um
    np.testing.assert_allclose(val, [-1.358635132, -0.240680764, 0.877273605, -1.297146744,
                                     -0.316265101], rtol=0, atol=1e-12)
    # rotary-axis location errors are kept, in the file's units, not dropped
    assert d.other == {"C0B": 0.000022355737, "A0B": 0.000047622950}
    assert d.squareness == {}


def test_round_trip(tmp_path):
    from volcal.measure.virtual import random_machine

    m = random_machine([[0, 800], [0, 600], [0, 500]], "XYFZ", seed=5)
    p = write_etalon(m, tmp_path / "m.txt")
    d = read_etalon(p)
    back = to_machine_errors(d, "XYFZ")
    for k in range(3):
        np.testing.assert_allclose(back.nodes[k], m.nodes[k], atol=1e-6)
        np.testing.assert_allclose(back.values[k], m.values[k], atol=1e-6)  # [um, urad]
    np.testing.assert_allclose(back.squareness, m.squareness, atol=1e-6)
    text = p.read_text()
    assert "[C0Y]" in text and f"VALUE = {m.squareness[0] * 1e-6:.12e}" in text


@pytest.mark.parametrize("text, msg, line", [
    ("[EXX]\nGridpoints = {\n0 0\n10 x\n}\n", "expected 'position value'", 4),
    ("[EXX]\nGridpoints = {\n0 0\n10 1\n", "not closed", 2),
    ("[EXX]\n[EYX]\nVALUE = 1\n", "neither VALUE nor Gridpoints", 2),
    ("VALUE = 1\n", "outside any [block]", 1),
    ("[C0Y]\nVALUE = abc\n", "is not a number", 2),
    ("[EXX]\nGridpoints = {\n10 0\n0 1\n}\n", "increasing positions", 2),
])
def test_bad_files(tmp_path, text, msg, line):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(VolcalInputError, match=re.escape(msg)) as exc:
        read_etalon(p)
    assert f"row {line}" in str(exc.value) and str(p) in str(exc.value)
