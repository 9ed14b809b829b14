"""ISG CSV files read by a parser written from the documented syntax and checked on the
documentation's own example."""

import numpy as np
import pytest

from volcal.compensate import CompensationOptions, write_compensation
from volcal.compensate.volumetric import ISG_FILE
from volcal.measure.virtual import random_machine

TRAVEL = np.array([[0.0, 800.0], [0.0, 600.0], [0.0, 400.0]])


@pytest.fixture(scope="module")
def machine():
    return random_machine(TRAVEL, "XYFZ", 8, n_nodes=9)


def isg_csv_blocks(text):
    """ISG CSV as the TF5280 documentation describes it ("ISG CSV format"): a header line
    names the columns, records follow, ``//`` starts a row comment, ``#`` is a file break
    after which a new header follows; columns are separated by white space."""
    blocks, head = [], None
    for line in text.splitlines():
        line = line.split("//")[0].strip()
        if not line:
            continue
        if line == "#":
            head = None
            continue
        if head is None:
            head = line.split()
            blocks.append((head, []))
        elif line != "…":
            blocks[-1][1].append(dict(zip(head, map(float, line.split()), strict=True)))
    return blocks


# Beckhoff TF5280 TwinCAT 3 CNC Volumetric Compensation, "ISG CSV format", programming
# examples (https://infosys.beckhoff.com/content/1033/tf5280_volumetric_comp/296429067.html),
# joined with the file break the same page describes; "…" lines are the page's ellipses
# (the position-error example is cut to the three columns it shows).
DOC_EXAMPLE = """// The header only contains position errors.
Y0A Z0A X0B
// Position errors are typically (but not necessarily)
// constant. Therefore, one data row is usually sufficient here.
0.1 0.2 0.11
#
// The header contains the argument "X" and component errors.
X EXX EYX EZX EAX EBX ECX
0.0 0.02 0.01 0.07 0.00 0.0042 0.003
10.0 0.00 -0.1 0.01 0.00 0.0011 0.002
…
// Further records depending on X
"""


def test_isg_parser_reads_the_documentation_example():
    (h1, r1), (h2, r2) = isg_csv_blocks(DOC_EXAMPLE)
    assert h1 == ["Y0A", "Z0A", "X0B"] and r1 == [{"Y0A": 0.1, "Z0A": 0.2, "X0B": 0.11}]
    assert h2 == ["X", "EXX", "EYX", "EZX", "EAX", "EBX", "ECX"]
    assert r2[1] == {"X": 10.0, "EXX": 0.0, "EYX": -0.1, "EZX": 0.01, "EAX": 0.0,
                     "EBX": 0.0011, "ECX": 0.002}


@pytest.mark.parametrize("sign", ["error", "correction"])
def test_isg_file_read_as_documented(tmp_path, machine, sign):
    s = 1.0 if sign == "error" else -1.0
    write_compensation(machine, "isg", tmp_path, CompensationOptions(sign, spacing=50.0))
    text = (tmp_path / ISG_FILE).read_text()
    data = [ln for ln in text.splitlines() if not ln.startswith("//")]
    assert not any("," in ln for ln in data)  # white space, no commas
    blocks = {b[0][0]: b for b in isg_csv_blocks(text)}
    assert sorted(blocks) == ["C0Y", "X", "Y", "Z"]
    for k, ax in enumerate("XYZ"):
        head, rows = blocks[ax]
        assert head == [ax] + [c + ax for c in ("EX", "EY", "EZ", "EA", "EB", "EC")]
        pos = np.array([r[ax] for r in rows])
        vals = np.array([[r[c] for c in head[1:]] for r in rows])
        exp = s * machine.component(k, pos)
        np.testing.assert_allclose(vals[:, :3], exp[:, :3] / 1000.0, atol=5e-7 + 1e-12)  # mm, 1 nm
        np.testing.assert_allclose(vals[:, 3:], exp[:, 3:] * 1e-6, atol=5e-10 + 1e-15)  # rad
    head, rows = blocks["C0Y"]
    assert head == ["C0Y", "B0Z", "A0Z"] and len(rows) == 1
    np.testing.assert_allclose([rows[0][n] for n in head], s * machine.squareness * 1e-6,
                               atol=5e-10 + 1e-15)
