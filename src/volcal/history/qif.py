"""QIF 3 ``FPSTestType``: a machine's 21 errors as a Cartesian CMM accuracy test.

QIF 3.0 (ANSI/DMSC QIF 3.0-2018, ``QIFMeasurementResources.xsd``) describes the
accuracy of a Cartesian CMM by a *full parametric specification* test, ``FPSTestType``
(element ``CartesianCMMFPSTest``): for each axis its linearity, roll, pitch, yaw and two
straightnesses as discrete functions of the axis position, and three squareness rates.
These are the 21 rigid-body errors of volcal's model (ISO 230-1 names,
``docs/conventions.md``); the element of each and its sign (``docs/history.md``,
"QIF 3 export"):

=====================  ==========  ===================================================
QIF element            volcal      value written
=====================  ==========  ===================================================
XLinearity             EXX         [mm]; QIF: "measured minus reported" = actual - nominal
YLinearity, ZLinearity EYY, EZZ    likewise
XAxisRoll              EAX         [rad], ISO 230-1 sign (right hand about +X)
XAxisPitch, XAxisYaw   EBX, ECX    [rad]
YAxisRoll              EBY         [rad]
YAxisPitch, YAxisYaw   EAY, ECY    [rad]
ZAxisRoll              ECZ         [rad]
ZAxisPitch, ZAxisYaw   EAZ, EBZ    [rad] (pitch about X, yaw about Y: volcal's choice)
XAxisStraightnessY/Z   EYX, EZX    [mm]
YAxisStraightnessX/Z   EXY, EZY    [mm]
ZAxisStraightnessX/Y   EXZ, EYZ    [mm]
XYSquareness           +EC0Y       [rad]; QIF: positive when the angle exceeds 90 deg
XZSquareness           -EB0Z       [rad]; EB0Z > 0 leans Z towards +X: angle < 90 deg
YZSquareness           +EA0Z       [rad]; EA0Z > 0 leans Z towards -Y: angle > 90 deg
=====================  ==========  ===================================================

The functions' domains are the axis positions of volcal's nodes [mm]. The file is a
whole ``QIFDocument`` (units, one ``CartesianCMM`` measurement device with its
``Accuracies``), written with the standard library; :func:`validate_qif` checks it
against the QIF 3.0 XSD with lxml (libxml2), a real XML-schema validator.

References
----------
.. [1] ANSI/DMSC QIF 3.0-2018, Quality Information Framework, part 3 (library) and the
   ``QIFMeasurementResources.xsd`` schema file (``FPSTestType``, ``CartesianCMMAccuracyType``).
.. [2] ISO 230-1:2012, 3.4 and 3.5 (names and signs of the error motions and squareness).
"""

from __future__ import annotations

import datetime as _dt
import os
import uuid
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from volcal.errors import VolcalInputError

#: Namespace of QIF 3.
QIF_NS = "http://qifstandards.org/xsd/qif3"
#: QIF version written in ``versionQIF``.
QIF_VERSION = "3.0.0"

#: (QIF element, volcal name, axis index, component index) of the 18 functions, in the
#: XSD's sequence order. Components: 0..2 EX, EY, EZ [um]; 3..5 EA, EB, EC [urad].
FUNCTIONS: tuple[tuple[str, str, int, int], ...] = (
    ("XLinearity", "EXX", 0, 0),
    ("YLinearity", "EYY", 1, 1),
    ("ZLinearity", "EZZ", 2, 2),
    ("XAxisRoll", "EAX", 0, 3),
    ("XAxisPitch", "EBX", 0, 4),
    ("XAxisYaw", "ECX", 0, 5),
    ("YAxisRoll", "EBY", 1, 4),
    ("YAxisPitch", "EAY", 1, 3),
    ("YAxisYaw", "ECY", 1, 5),
    ("ZAxisRoll", "ECZ", 2, 5),
    ("ZAxisPitch", "EAZ", 2, 3),
    ("ZAxisYaw", "EBZ", 2, 4),
    ("XAxisStraightnessY", "EYX", 0, 1),
    ("XAxisStraightnessZ", "EZX", 0, 2),
    ("YAxisStraightnessX", "EXY", 1, 0),
    ("YAxisStraightnessZ", "EZY", 1, 2),
    ("ZAxisStraightnessX", "EXZ", 2, 0),
    ("ZAxisStraightnessY", "EYZ", 2, 1),
)

#: (QIF element, volcal name, sign): QIF value [rad] = sign * volcal value [urad] * 1e-6.
SQUARENESS: tuple[tuple[str, str, float], ...] = (
    ("XYSquareness", "EC0Y", 1.0),
    ("XZSquareness", "EB0Z", -1.0),
    ("YZSquareness", "EA0Z", 1.0),
)

#: What volcal has and FPSTestType cannot hold (written down in docs/history.md).
NOT_MAPPED: tuple[str, ...] = (
    "uncertainties: U and the covariance of every function and squareness",
    "the kinematic chain (which axis carries which) and the reference lines of the "
    "functions (tool point, axes after the measured one at 0)",
    "volcal's normalisation (zero at the start of travel, straightness zero at its end) "
    "and interpolation rule (linear between nodes, constant outside)",
    "reversal (backlash) of bidirectional runs",
    "ISO 230-2 / 230-6 results and the volumetric indices",
)

#: Unit names of the range values: volcal's own, defined in ``FileUnits/OtherUnits``
#: (micrometre and microradian, SI factors 1e-6), so that the numbers are volcal's.
_LEN, _ANG = "um", "urad"


def _q(tag: str) -> str:
    return f"{{{QIF_NS}}}{tag}"


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    e = ET.SubElement(parent, _q(tag), attrib)
    if text is not None:
        e.text = text
    return e


def _unit(parent: ET.Element, tag: str, si: str, name: str, factor: str | None) -> None:
    u = _sub(parent, tag)
    _sub(u, "SIUnitName", si)
    _sub(u, "UnitName", name)
    if factor is not None:
        _sub(_sub(u, "UnitConversion"), "Factor", factor)


def _nums(a: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in a)


@dataclass
class QifMachine:
    """What the document says of the machine besides its errors (all optional).

    Attributes
    ----------
    name : str
        Machine name (``[machine] name``).
    make, model, serial : str or None
        ``Manufacturer``, ``ModelNumber``, ``SerialNumber``.
    travel_mm : sequence of (float, float) or None
        Travel of X, Y, Z [mm]: ``Size`` gets their lengths.
    location : str or None
        ``Location/LocationDescription`` (default "not stated").
    date : str or None
        Date of measurement (ISO 8601): ``Calibrations/Calibration/CalibrationDate``.
    due : str or None
        Next calibration due (ISO 8601): its ``ExpirationDate`` (QIF requires one when a
        calibration is given: without ``due`` no ``Calibrations`` is written).
    """

    name: str = "machine"
    make: str | None = None
    model: str | None = None
    serial: str | None = None
    travel_mm: Any = None
    location: str | None = None
    date: str | None = None
    due: str | None = None


def _datetime(d: str) -> str:
    return d if "T" in d else f"{d}T00:00:00Z"


def qif_tree(errors: Any, machine: QifMachine | None = None, source: str = "volcal",
             qpid: str | None = None) -> ET.ElementTree[ET.Element]:
    """The ``QIFDocument`` of a machine's errors.

    Parameters
    ----------
    errors : MachineErrors
        Error functions on their nodes [um, urad] and squareness [urad].
    machine : QifMachine, optional
        Name, identity keys, travel and dates of the machine.
    source : str
        Written into the device's ``Description`` and the accuracy source.
    qpid : str, optional
        The document's QPId (a UUID); a new random one by default.

    Returns
    -------
    xml.etree.ElementTree.ElementTree
    """
    m = machine or QifMachine(name=getattr(errors, "name", "machine"))
    ET.register_namespace("", QIF_NS)
    root = ET.Element(_q("QIFDocument"), {"versionQIF": QIF_VERSION, "idMax": "2"})
    _sub(root, "QPId", qpid or str(uuid.uuid4()))
    units = _sub(root, "FileUnits")
    prim = _sub(units, "PrimaryUnits")
    _unit(prim, "AngularUnit", "radian", "radian", None)
    _unit(prim, "LinearUnit", "meter", "mm", "0.001")
    other = _sub(units, "OtherUnits", n="2")
    _unit(other, "AngularUnit", "radian", _ANG, "0.000001")
    _unit(other, "LinearUnit", "meter", _LEN, "0.000001")
    devs = _sub(_sub(root, "MeasurementResources"), "MeasurementDevices", n="1")
    cmm = _sub(devs, "CartesianCMM", id="1")
    _sub(cmm, "Name", " ".join(str(m.name).split()) or "machine")
    _sub(cmm, "Description", f"machine tool calibrated by laser interferometry; {source}; "
         f"kinematic chain {getattr(errors, 'chain', '?')}")
    for tag, v in (("Manufacturer", m.make), ("ModelNumber", m.model),
                   ("SerialNumber", m.serial)):
        if v:
            _sub(cmm, tag, str(v))
    if m.travel_mm is not None:
        size = _sub(cmm, "Size")
        for ax, (lo, hi) in zip("XYZ", m.travel_mm, strict=True):
            _sub(size, f"{ax}AxisLength", repr(float(hi) - float(lo)))
    loc = _sub(cmm, "Location", id="2")
    _sub(loc, "LocationDescription", m.location or "not stated")
    if m.date and m.due:
        cal = _sub(_sub(cmm, "Calibrations", n="1"), "Calibration")
        _sub(cal, "CalibrationDate", _datetime(m.date))
        _sub(cal, "ExpirationDate", _datetime(m.due))
    acc = _sub(_sub(cmm, "Accuracies", n="1"), "CartesianCMMAccuracy")
    env = _sub(acc, "EnvironmentalRange")
    _sub(env, "Description", "readings referred to 20 C (ISO 1) where the session "
         "records its temperatures")
    fps = _sub(acc, "CartesianCMMFPSTest")
    for tag, _name, k, c in FUNCTIONS:
        x = np.asarray(errors.nodes[k], dtype=float)
        y = np.asarray(errors.values[k][:, c], dtype=float)
        f = _sub(fps, tag, n=str(x.size))
        _sub(f, "DomainValues", _nums(x))
        _sub(f, "RangeValues", _nums(y))
        _sub(f, "DomainLinearUnit", "mm")
        _sub(f, "RangeLinearUnit" if c < 3 else "RangeAngularUnit", _LEN if c < 3 else _ANG)
    sq = np.asarray(errors.squareness, dtype=float)
    from volcal.model.names import SQUARENESS_NAMES

    for tag, name, sign in SQUARENESS:
        _sub(fps, tag, repr(sign * float(sq[SQUARENESS_NAMES.index(name)]) * 1e-6))
    src = _sub(acc, "AccuracySource")
    _sub(src, "OtherAccuracySource", f"laser-interferometer calibration ({source})")
    tree: ET.ElementTree[ET.Element] = ET.ElementTree(root)
    ET.indent(tree, space=" ")
    return tree


def write_qif(errors: Any, path: str | Path, machine: QifMachine | None = None,
              source: str = "volcal", qpid: str | None = None) -> Path:
    """Write a machine's errors as a QIF 3 document, atomically.

    Parameters
    ----------
    errors : MachineErrors
        Error functions on their nodes [um, urad] and squareness [urad].
    path : str or Path
        Output file (``.qif``).
    machine : QifMachine, optional
        Name, identity keys, travel and dates.
    source : str
        Named in the document (program and record).
    qpid : str, optional
        The document's QPId (a UUID); a new random one by default.

    Returns
    -------
    Path
    """
    from volcal.io.atomic import write_bytes

    tree = qif_tree(errors, machine, source, qpid)
    data = ET.tostring(tree.getroot(), encoding="utf-8", xml_declaration=True)
    write_bytes(path, data + b"\n")
    return Path(path)


def read_qif(path: str | Path, chain: str, name: str = "qif") -> Any:
    """The FPS test of a QIF document as a volcal machine (inverse of :func:`write_qif`).

    Parameters
    ----------
    path : str or Path
        QIF document with one ``CartesianCMMFPSTest``.
    chain : str
        Kinematic chain of the machine (QIF does not record it).
    name : str
        Machine name.

    Returns
    -------
    MachineErrors
        Functions [um, urad] on the union of each axis' domains (linear interpolation),
        squareness [urad] with volcal's signs.

    Raises
    ------
    VolcalInputError
        Not XML, no FPS test, a function whose lengths disagree with ``n``, or a unit
        other than mm / radian.
    """
    from volcal.model.errorfunctions import MachineErrors
    from volcal.model.names import SQUARENESS_NAMES

    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise VolcalInputError(f"cannot read the QIF document ({exc})", path) from None
    fps = root.find(f".//{_q('CartesianCMMFPSTest')}")
    if fps is None:
        raise VolcalInputError("no CartesianCMMFPSTest element", path)
    funcs: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
    for tag, _name, k, c in FUNCTIONS:
        e = fps.find(_q(tag))
        if e is None:
            raise VolcalInputError(f"FPS test without {tag}", path, column=tag)
        try:
            x = np.array((e.findtext(_q("DomainValues")) or "").split(), dtype=float)
            v = np.array((e.findtext(_q("RangeValues")) or "").split(), dtype=float)
        except ValueError:
            raise VolcalInputError(f"{tag}: values that are not numbers", path,
                                   column=tag) from None
        if x.size != int(e.get("n", -1)) or v.size != x.size or x.size < 1:
            raise VolcalInputError(f"{tag}: n={e.get('n')} but {x.size} domain and "
                                   f"{v.size} range values", path, column=tag)
        ru = e.findtext(_q("RangeLinearUnit" if c < 3 else "RangeAngularUnit"))
        du = e.findtext(_q("DomainLinearUnit"))
        want = _LEN if c < 3 else _ANG
        if du != "mm" or ru != want:
            raise VolcalInputError(f"{tag}: units {du}/{ru}; volcal reads mm/{want}",
                                   path, column=tag)
        funcs[(k, c)] = (x, v)
    nodes, values = [], []
    for k in range(3):
        x = np.unique(np.concatenate([funcs[(k, c)][0] for c in range(6)]))
        vals = np.zeros((x.size, 6))
        for c in range(6):
            px, pv = funcs[(k, c)]
            vals[:, c] = np.interp(x, px, pv)
        nodes.append(x)
        values.append(vals)
    sq = np.zeros(3)
    for tag, nm, sign in SQUARENESS:
        t = fps.findtext(_q(tag))
        try:
            if t is None:
                raise ValueError(f"no {tag}")
            sq[SQUARENESS_NAMES.index(nm)] = sign * float(t) * 1e6
        except ValueError:
            raise VolcalInputError(f"{tag}: {t!r} is not a number", path, column=tag) from None
    return MachineErrors(chain, nodes, values, sq, name=name)


# ------------------------------------------------------------------ validation
#: Environment variable naming the QIF 3.0 schema set: ``QIFDocument.xsd`` or the folder
#: holding ``QIFApplications/QIFDocument.xsd`` and ``QIFLibrary/*.xsd``.
XSD_ENV = "VOLCAL_QIF_XSD"


def find_xsd(extra: list[Path] | None = None) -> Path | None:
    """The QIF 3 schema's ``QIFDocument.xsd``, or ``None`` when none is found.

    Looked up in ``extra`` (``QIFDocument.xsd`` itself or folders holding
    ``QIFApplications/``), then in ``$VOLCAL_QIF_XSD``. volcal does not ship the schema
    (``docs/history.md``, "QIF 3 export").

    Parameters
    ----------
    extra : list of Path, optional
        Further folders to try.
    """
    cands = [Path(c) for c in extra or []]
    if os.environ.get(XSD_ENV):
        cands.append(Path(os.environ[XSD_ENV]))
    for c in cands:
        for p in (c, c / "QIFApplications" / "QIFDocument.xsd"):
            if p.is_file():
                return p
    return None


_DSIG_URL = "http://www.w3.org/TR/2002/REC-xmldsig-core-20020212/xmldsig-core-schema.xsd"


def _dsig_local(xsd: Path) -> Path | None:
    """A local copy of the W3C XML-signature schema that QIFDocument.xsd imports."""
    p = xsd.parent.parent / "QIFLibrary" / "xmldsig-core-schema.xsd"
    if p.is_file():
        return p
    try:
        import xmlschema  # ships the W3C schema
    except ImportError:
        return None
    q = Path(xmlschema.__file__).parent / "schemas" / "DSIG" / "xmldsig-core-schema.xsd"
    return q if q.is_file() else None


def load_schema(xsd: str | Path) -> Any:
    """The QIF 3 schema as an ``lxml.etree.XMLSchema``, read without network.

    The W3C signature schema that ``QIFDocument.xsd`` imports by URL is taken from
    ``QIFLibrary/xmldsig-core-schema.xsd`` beside it or from the ``xmlschema`` package's
    copy; any other network reference is refused.

    Parameters
    ----------
    xsd : str or Path
        ``QIFDocument.xsd`` (or another top-level QIF schema file).

    Raises
    ------
    VolcalInputError
        lxml missing, or the schema does not load.
    """
    try:
        from lxml import etree
    except ImportError:
        raise VolcalInputError("validating QIF needs lxml (pip install lxml)") from None
    xsd = Path(xsd)
    dsig = _dsig_local(xsd)

    class _Local(etree.Resolver):
        def resolve(self, url, pubid, context):  # noqa: D102
            if url == _DSIG_URL and dsig is not None:
                return self.resolve_filename(str(dsig), context)
            if url.startswith(("http:", "https:")):
                raise VolcalInputError(f"the schema refers to {url}: no network reference "
                                       "is followed", xsd)
            return None

    parser = etree.XMLParser(no_network=True)
    parser.resolvers.add(_Local())
    try:
        return etree.XMLSchema(etree.parse(str(xsd), parser))
    except (OSError, etree.XMLSchemaParseError, etree.XMLSyntaxError) as exc:
        raise VolcalInputError(f"cannot load the QIF schema ({exc})", xsd) from None


def validate_qif(path: str | Path, xsd: str | Path | Any) -> list[str]:
    """Schema errors of a QIF document (empty when it validates).

    Parameters
    ----------
    path : str or Path
        The document.
    xsd : str, Path or lxml.etree.XMLSchema
        ``QIFDocument.xsd``, or a schema already loaded by :func:`load_schema`.

    Returns
    -------
    list of str
        ``line N: message`` of each violation.
    """
    from lxml import etree

    schema = load_schema(xsd) if isinstance(xsd, str | Path) else xsd
    doc = etree.parse(str(path))
    if schema.validate(doc):
        return []
    return [f"line {e.line}: {e.message}" for e in schema.error_log]


def due_date(date: str | None, interval_days: int | None) -> str | None:
    """``date`` plus ``interval_days`` (ISO 8601), or ``None``.

    Parameters
    ----------
    date : str or None
        Date of measurement.
    interval_days : int or None
        Calibration interval [days].
    """
    from volcal.history.due import measured_on

    d = measured_on(date)
    try:
        days = int(interval_days or 0)
    except (TypeError, ValueError):  # a damaged record (its reader warns of it)
        return None
    if d is None or not days:
        return None
    return (d + _dt.timedelta(days=days)).isoformat()
