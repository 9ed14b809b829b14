"""How the OPC UA source tells a rotary axis from a linear one, and checks a plan's axes.

OPC 40502 ``CncAxisType`` has ``IsRotational`` (true for a rotational axis) and its
positions an ``EngineeringUnits`` (UNECE codes: ``DD`` degree, ``C81`` radian, ``MMT``
millimetre...). :func:`volcal.capture.opcua_link.axis_scale` turns them into a factor to
mm or deg and the axis' kind; :func:`volcal.capture.opcua.check_axes` refuses a control that
lacks a measurement's axis or has it of the other kind. Against the server:
tests/capture/test_capture_opcua.py.
"""

from __future__ import annotations

import math

import pytest

from volcal.capture.opcua import ControlAxesError, check_axes
from volcal.capture.opcua_link import AxisNode, OpcUaError, axis_scale

ROT = "rotary-c"


@pytest.mark.parametrize("unit_id, rotational, factor, rotary", [
    (17476, True, 1.0, True),  # DD, degree
    (17476, False, 1.0, True),  # IsRotational left at the type's false: the unit decides
    (4405297, True, 180.0 / math.pi, True),  # C81, radian
    (None, True, 1.0, True),  # no EngineeringUnits: the model's degrees
    (None, None, 1.0, False),  # nothing said: the model's mm
    (5066068, False, 1.0, False),  # MMT
    (4804168, None, 25.4, False),  # INH
])
def test_the_axis_unit_and_kind(unit_id, rotational, factor, rotary):
    assert axis_scale(unit_id, "", rotational, "here") == (pytest.approx(factor, rel=1e-15),
                                                           rotary)


def test_a_length_on_a_rotational_axis_or_an_unknown_unit_is_refused():
    with pytest.raises(OpcUaError, match=r"axis C PosDirect is in mm but the axis' "
                                         r"IsRotational is true"):
        axis_scale(5066068, "mm", True, "opc.tcp://h:1/: axis C PosDirect")
    with pytest.raises(OpcUaError, match=r"is in KGM: expected mm, m, inch .* or deg or rad"):
        axis_scale(4933453, "", None, "opc.tcp://h:1/: axis C PosDirect")


class _Pm:
    """The frame and id of a planned measurement (all :func:`check_axes` reads)."""

    def __init__(self, mid, frame):
        self.id, self.frame = mid, frame


def test_check_axes_names_the_missing_or_linear_axis():
    from volcal.capture.frame import LINEAR, rotary_frame

    lin = [AxisNode(n, f"ns=2;s={n}", f"ns=2;s={n}.p") for n in "XYZ"]
    rot = [_Pm("linear-x", LINEAR), _Pm(ROT, rotary_frame("c", True))]
    check_axes([*lin, AxisNode("C", "c", "c.p", rotary=True, unit="DD")], rot, "opcua:u")
    with pytest.raises(ControlAxesError, match=r"^control=opcua:u: measurement rotary-c "
                       r"turns axis C \(rotary \[deg\]\), but the server reports no such "
                       r"CncAxisType object; the server's axes: X \(linear \[mm\]\), "
                       r"Y \(linear \[mm\]\), Z \(linear \[mm\]\)\. Give a control"):
        check_axes(lin, rot, "opcua:u")
    with pytest.raises(ControlAxesError, match=r"rotary-c turns axis C \(rotary \[deg\]\), "
                       r"but the server's axis C is linear \[mm\] \(IsRotational, "
                       r"EngineeringUnits MMT\)"):
        check_axes([*lin, AxisNode("C", "c", "c.p", unit="MMT")], rot, "opcua:u")
    with pytest.raises(ControlAxesError, match=r"linear-x moves axis Z \(linear \[mm\]\), "
                       r"but the server's axis Z is rotary"):
        check_axes([*lin[:2], AxisNode("Z", "z", "z.p", rotary=True)], rot, "opcua:u")


class _Link:
    """The link's last snapshot, as a connected server gives it (no network)."""

    def __init__(self, axes, positions):
        from types import SimpleNamespace

        self.snap = SimpleNamespace(connected=True, axes=axes, positions=positions,
                                    reason="", status="ok", program_status=None)

    def snapshot(self):
        return self.snap


def _control(text, axes, positions):
    """An OPC UA control made from its source text, on a stub link."""
    pytest.importorskip("asyncua")
    from volcal.capture.sources import Clock, SourceContext, make_control

    src = make_control(text, SourceContext(clock=Clock()))
    src.link = _Link(axes, positions)
    return src


def test_axes_key_renames_the_servers_axes_to_volcals_letters():
    """A control naming its axes X1, Y1, Z1 and its table C1 beside a spindle named C:
    ``axes=X:X1/Y:Y1/Z:Z1/C:C1`` reads them as X, Y, Z, C, the spindle left out."""
    from volcal.capture.frame import LINEAR, rotary_frame

    axes = [AxisNode("X1", "x", "x.p"), AxisNode("Y1", "y", "y.p"),
            AxisNode("Z1", "z", "z.p"), AxisNode("C1", "c1", "c1.p", rotary=True, unit="DD"),
            AxisNode("C", "c", "c.p", rotary=True, unit="DD")]
    positions = {"X1": 1.0, "Y1": 2.0, "Z1": 3.0, "C1": 90.5, "C": 7.0}
    src = _control("opcua:opc.tcp://h:4840;axes=X:X1/Y:Y1/z:Z1/C:C1", axes, positions)
    assert src.axes == ["X", "Y", "Z", "C"]
    assert src.poll().positions == {"X": 1.0, "Y": 2.0, "Z": 3.0, "C": 90.5}
    check_axes(src._renamed(axes), [_Pm("linear-x", LINEAR), _Pm(ROT, rotary_frame("c", True))],
               "opcua:u")
    # without the key the server's names: X1 is no X, and the message says how to map it
    bare = _control("opcua:opc.tcp://h:4840", axes, positions)
    assert bare.poll().positions == positions
    with pytest.raises(ControlAxesError, match=r"moves axis X \(linear \[mm\]\), but the "
                       r"server reports no such CncAxisType object; the server's axes: X1 "
                       r"\(linear \[mm\]\).*Give a control that reports X, or name the "
                       r"server's axis: axes=X:NAME"):
        check_axes(bare._renamed(axes), [_Pm("linear-x", LINEAR)], "opcua:u")
    # a name the server does not have: refused at the connection, naming what it has
    wrong = _control("opcua:opc.tcp://h:4840;axes=C:TABLE", axes, positions)
    with pytest.raises(ControlAxesError, match=r"axes=C:TABLE: the server reports no "
                       r"CncAxisType object of that name; the server's axes: X1 \(linear"):
        wrong._renamed(axes)


@pytest.mark.parametrize("text, match", [
    ("axes=C", r"'C' is not LETTER:NAME with LETTER one of X, Y, Z, A, B, C"),
    ("axes=W:W1", r"'W:W1' is not LETTER:NAME"),
    ("axes=C:", r"'C:' is not LETTER:NAME"),
    ("axes=C:C1/C:C2", r"C given twice"),
    ("axes=A:C1/C:C1", r"C1 given twice"),
])
def test_axes_key_mistakes_are_refused(text, match):
    pytest.importorskip("asyncua")
    from volcal.capture.sources import Clock, SourceContext, make_control
    from volcal.errors import VolcalInputError

    with pytest.raises(VolcalInputError, match=match):
        make_control(f"opcua:opc.tcp://h:4840;{text}", SourceContext(clock=Clock()))
