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
