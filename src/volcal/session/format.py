"""Read and write sessions: a folder with ``session.toml`` and one CSV per measurement.

The format (``volcal-session/1``) is documented in ``docs/formats.md``. Readers validate
everything and raise :class:`~volcal.errors.VolcalInputError` naming the file, row and
column; writers build the whole folder aside and move it into place.
"""

from __future__ import annotations

import csv
import io
import math
import shutil
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError
from volcal.io.atomic import atomic_dir, write_text
from volcal.io.table import Column, TableSpec, read_table
from volcal.io.tomlfmt import dumps as toml_dumps
from volcal.io.values import parse_finite
from volcal.model.chain import parse_chain

SESSION_FORMAT = "volcal-session/1"
KINDS: tuple[str, ...] = ("linear", "diagonal", "step_diagonal")
TARGETS: tuple[str, ...] = ("flat_mirror", "retroreflector", "retroreflector_mirror")
REQUIRED_COLUMNS: tuple[str, ...] = ("x_mm", "y_mm", "z_mm", "deviation_um")
OPTIONAL_COLUMNS: dict[str, str] = {
    "run": "int",
    "direction": "dir",
    "time_s": "float",
    "air_temperature_c": "float",
    "air_pressure_pa": "float",
    "humidity_pct": "float",
    "material_temperature_c": "float",
}
MIN_ROWS = 2
ABSURD_DEVIATION_UM = 10_000.0
"""A reading beyond 10 mm is no laser deviation of a machine axis: an error."""

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


@dataclass
class Measurement:
    """One laser measurement: its set-up and its readings.

    Attributes
    ----------
    id : str
        Unique name within the session.
    kind : str
        ``'linear'``, ``'diagonal'`` or ``'step_diagonal'``.
    target : str
        ``'flat_mirror'`` or ``'retroreflector'``.
    positions : ndarray, shape (n, 3)
        Commanded position of each reading [mm].
    deviation : ndarray, shape (n,), or None
        Laser reading minus commanded displacement along the nominal beam, counted from
        the first row [um]; None in a planned (unmeasured) skeleton.
    beam_direction : ndarray, shape (3,)
        Nominal beam direction, unit vector in machine axes.
    tool_offset : ndarray, shape (3,)
        Target point relative to the tool reference point [mm].
    file : str
        CSV file name, relative to the session folder.
    columns : dict of str to ndarray
        Optional columns (``run``, ``direction``, ``time_s``, environment columns).
    meta : dict
        Optional metadata: ``axis``, ``axis_order``, ``diagonal``, ``plane``, ``notes``,
        ``environment`` (table), ``readings`` (``'deviation'`` or ``'raw'``)...
    """

    id: str
    kind: str
    target: str
    positions: NDArray[np.float64]
    deviation: NDArray[np.float64] | None
    beam_direction: NDArray[np.float64]
    tool_offset: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    file: str = ""
    columns: dict[str, NDArray[Any]] = field(default_factory=dict)
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Validate the set-up: kind, target, shapes, finite values."""
        if self.kind not in KINDS:
            raise VolcalInputError(f"measurement {self.id!r}: unknown kind {self.kind!r}: "
                                   f"expected one of {', '.join(KINDS)}")
        if self.target not in TARGETS:
            raise VolcalInputError(f"measurement {self.id!r}: unknown target {self.target!r}: "
                                   f"expected one of {', '.join(TARGETS)}")
        if not self.file:
            self.file = f"{self.id}.csv"
        try:
            self.positions = np.asarray(self.positions, dtype=float).reshape(-1, 3)
            self.beam_direction = np.asarray(self.beam_direction, dtype=float).reshape(3)
            self.tool_offset = np.asarray(self.tool_offset, dtype=float).reshape(3)
        except (ValueError, TypeError) as exc:
            raise VolcalInputError(f"measurement {self.id!r}: positions must be n x 3, beam "
                                   f"direction and tool offset 3 numbers ({exc})") from None
        for what, v in (("positions", self.positions), ("beam direction", self.beam_direction),
                        ("tool offset", self.tool_offset)):
            if not np.all(np.isfinite(v)):
                raise VolcalInputError(f"measurement {self.id!r}: {what} must be finite")
        if self.deviation is not None:
            self.deviation = np.asarray(self.deviation, dtype=float).reshape(-1)

    @property
    def n(self) -> int:
        """Number of readings."""
        return self.positions.shape[0]

    @property
    def run(self) -> NDArray[np.int64] | None:
        """Run number of each reading, if recorded."""
        return self.columns.get("run")

    @property
    def direction(self) -> NDArray[np.str_] | None:
        """Approach direction ``'+'``/``'-'`` of each reading, if recorded."""
        return self.columns.get("direction")

    @property
    def axis(self) -> int | None:
        """Measured axis index of a linear test (from metadata or the positions)."""
        if self.kind != "linear":
            return None
        a = self.meta.get("axis")
        if isinstance(a, str) and a.upper() in ("X", "Y", "Z"):
            return "XYZ".index(a.upper())
        return int(np.argmax(np.ptp(self.positions, axis=0)))

    def to_toml(self) -> dict[str, Any]:
        """The measurement's entry in ``session.toml``."""
        d: dict[str, Any] = {
            "id": self.id,
            "kind": self.kind,
            "target": self.target,
            "beam_direction": [float(v) for v in self.beam_direction],
            "tool_offset_mm": [float(v) for v in self.tool_offset],
            "file": self.file,
        }
        for k, v in self.meta.items():
            d[k] = v
        return d

    def to_csv(self) -> str:
        """The measurement's CSV text (header ``x_mm,y_mm,z_mm,deviation_um`` + optional)."""
        extra = [c for c in OPTIONAL_COLUMNS if c in self.columns]
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow([*REQUIRED_COLUMNS, *extra])
        for i in range(self.n):
            row = [_fmt(v) for v in self.positions[i]]
            row.append("" if self.deviation is None else f"{self.deviation[i]:.6f}")
            for c in extra:
                v = self.columns[c][i]
                row.append(str(v) if OPTIONAL_COLUMNS[c] in ("int", "dir") else _fmt(v))
            w.writerow(row)
        return buf.getvalue()


def _fmt(v: float) -> str:
    return f"{float(v):.6f}".rstrip("0").rstrip(".") if math.isfinite(v) else "nan"


@dataclass
class Session:
    """A calibration session: the machine and its measurements.

    Attributes
    ----------
    name : str
        Machine name.
    chain : str
        Kinematic chain code (``'XYFZ'``...).
    travel : ndarray, shape (3, 2)
        Travel limits of X, Y, Z [mm].
    measurements : list of Measurement
    meta : dict
        Other ``[machine]`` keys kept as they were read.
    path : Path, optional
        Folder the session was read from.
    """

    name: str
    chain: str
    travel: NDArray[np.float64]
    measurements: list[Measurement] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def __post_init__(self) -> None:
        self.chain = parse_chain(self.chain).code
        self.travel = np.asarray(self.travel, dtype=float).reshape(3, 2)

    def get(self, mid: str) -> Measurement:
        """Measurement by id.

        Parameters
        ----------
        mid : str
            Measurement id, as in ``session.toml``.

        Returns
        -------
        Measurement

        Raises
        ------
        KeyError
            No measurement has this id.
        """
        for m in self.measurements:
            if m.id == mid:
                return m
        raise KeyError(mid)

    def to_toml(self) -> dict[str, Any]:
        """The content of ``session.toml``."""
        machine: dict[str, Any] = {"name": self.name, "chain": self.chain}
        machine.update(self.meta)
        machine["travel_mm"] = {a: [float(v) for v in self.travel[i]] for i, a in enumerate("xyz")}
        return {"format": SESSION_FORMAT, "machine": machine,
                "measurements": [m.to_toml() for m in self.measurements]}


def write_session(session: Session, folder: str | Path, extra_files: dict[str, str] | None = None,
                  keep_existing: bool = False) -> Path:
    """Write a session folder atomically (built aside, then moved into place).

    Parameters
    ----------
    session : Session
        The session.
    folder : str or Path
        Target folder; replaced if it exists.
    extra_files : dict of str to str, optional
        Further text files to write, relative path -> content (e.g. the simulation truth).
    keep_existing : bool
        Copy every other file of an existing ``folder`` (results of later commands, the
        user's notes) into the new folder; files written here replace their old versions.

    Returns
    -------
    Path
        The folder.
    """
    folder = Path(folder)
    names = [m.file for m in session.measurements]
    if len(set(names)) != len(names):
        raise VolcalInputError("two measurements share one file name")
    with atomic_dir(folder) as tmp:
        if keep_existing and folder.is_dir():
            shutil.copytree(folder, tmp, symlinks=True, dirs_exist_ok=True)
        (tmp / "session.toml").write_text(toml_dumps(session.to_toml()), encoding="utf-8")
        for m in session.measurements:
            (tmp / m.file).parent.mkdir(parents=True, exist_ok=True)
            (tmp / m.file).write_text(m.to_csv(), encoding="utf-8")
        for rel, text in (extra_files or {}).items():
            (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
            (tmp / rel).write_text(text, encoding="utf-8")
    session.path = folder
    return folder


def update_measurement_files(session: Session) -> None:
    """Rewrite the CSV files and ``session.toml`` of a session read from disk, file by file.

    Each file is replaced atomically.

    Parameters
    ----------
    session : Session
        A session with ``path`` set.
    """
    assert session.path is not None
    for m in session.measurements:
        write_text(session.path / m.file, m.to_csv())
    write_text(session.path / "session.toml", toml_dumps(session.to_toml()))


# ----------------------------------------------------------------------------- readers

def _err(msg: str, file: Path, row: int | None = None, col: str | None = None):
    return VolcalInputError(msg, file, row, col)


def _vec3(value: Any, file: Path, key: str, nonzero: bool = False) -> NDArray[np.float64]:
    if not isinstance(value, list) or len(value) != 3:
        raise _err("expected a list of 3 numbers", file, None, key)
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise _err(f"expected finite numbers, got {v!r}", file, None, key)
        out.append(float(v))
    a = np.array(out)
    if nonzero and np.linalg.norm(a) < 1e-12:
        raise _err("a direction must not be the zero vector", file, None, key)
    return a


_parse_float = parse_finite


_UNIT_HINTS = {"deviation": "um", "x": "mm", "y": "mm", "z": "mm"}


MEASUREMENT_TABLE = TableSpec(
    columns=(
        Column("x_mm"), Column("y_mm"), Column("z_mm"),
        Column("deviation_um", empty=True, abs_max=ABSURD_DEVIATION_UM),
        Column("run", kind="int", required=False, min=0),
        Column("direction", kind="choice", required=False, choices=("+", "-")),
        *(Column(c, required=False) for c, k in OPTIONAL_COLUMNS.items()
          if k == "float"),
    ),
    min_rows=MIN_ROWS,
    min_rows_message="need at least {min} readings, found {n}",
    what="measurement file",
)
"""Columns of a measurement CSV (``docs/formats.md``)."""


def read_measurement_csv(path: str | Path, require_deviation: bool = True):
    """Read one measurement CSV.

    Parameters
    ----------
    path : str or Path
        CSV file with the header ``x_mm,y_mm,z_mm,deviation_um`` and optional columns.
    require_deviation : bool
        If False, an empty ``deviation_um`` column is accepted (a planned skeleton).

    Returns
    -------
    positions : ndarray, shape (n, 3)
        Commanded positions [mm].
    deviation : ndarray, shape (n,) or None
        Deviations [um]; None if the column is empty and not required.
    columns : dict
        Optional columns.

    Raises
    ------
    VolcalInputError
        Naming file, row (1-based, header = row 1) and column.
    """
    t = read_table(path, MEASUREMENT_TABLE)
    pos = np.stack([t["x_mm"], t["y_mm"], t["z_mm"]], axis=1)
    dev: NDArray[np.float64] | None = t["deviation_um"]
    missing = np.isnan(dev)
    if missing.all() and not require_deviation:
        dev = None
    elif missing.any():
        raise t.error("missing deviation", int(np.argmax(missing)), "deviation_um")
    out = {c: t[c] for c in OPTIONAL_COLUMNS if t.has(c)}
    return pos, dev, out


def read_session(folder: str | Path, require_deviation: bool = True) -> Session:
    """Read and validate a session folder.

    Parameters
    ----------
    folder : str or Path
        Folder with ``session.toml`` (or the path of ``session.toml`` itself).
    require_deviation : bool
        If False, planned skeletons with empty deviations load.

    Returns
    -------
    Session

    Raises
    ------
    VolcalInputError
        Naming the file, row and column (TOML key) of the first problem.
    """
    folder = Path(folder)
    if folder.is_file():
        if folder.name != "session.toml":
            raise _err("a file, not a session folder (a folder with session.toml)", folder)
        folder = folder.parent
    elif not folder.exists():
        raise _err("session folder not found (no session.toml here)", folder)
    toml_path = folder / "session.toml"
    if not toml_path.is_file():
        raise _err("no session.toml in this folder (is it a volcal session?)", folder)
    try:
        doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _err(f"invalid TOML: {exc}", toml_path) from None
    except OSError as exc:
        raise _err(f"cannot read the file ({exc.__class__.__name__})", toml_path) from None
    fmt = doc.get("format")
    if fmt != SESSION_FORMAT:
        raise _err(f"expected format = \"{SESSION_FORMAT}\", got {fmt!r}", toml_path, None,
                   "format")
    machine = doc.get("machine")
    if not isinstance(machine, dict):
        raise _err("missing [machine] table", toml_path, None, "machine")
    name = machine.get("name", "machine")
    if not isinstance(name, str):
        raise _err("machine name must be a string", toml_path, None, "machine.name")
    chain = machine.get("chain")
    try:
        parse_chain(chain)
    except VolcalInputError as exc:
        raise _err(exc.message, toml_path, None, "machine.chain") from None
    tr = machine.get("travel_mm")
    if not isinstance(tr, dict):
        raise _err("missing [machine.travel_mm] table with x, y, z = [min, max]", toml_path, None,
                   "machine.travel_mm")
    travel = np.empty((3, 2))
    unknown = sorted(set(tr) - {"x", "y", "z"})
    if unknown:
        raise _err(f"unknown axis {unknown[0]!r}: expected x, y, z", toml_path, None,
                   f"machine.travel_mm.{unknown[0]}")
    for i, a in enumerate("xyz"):
        v = tr.get(a)
        key = f"machine.travel_mm.{a}"
        if (not isinstance(v, list) or len(v) != 2
                or any(isinstance(x, bool) or not isinstance(x, int | float) for x in v)
                or not all(math.isfinite(x) for x in v)):
            raise _err("expected [min, max] in mm", toml_path, None, key)
        if v[1] <= v[0]:
            raise _err("travel max must exceed min", toml_path, None, key)
        travel[i] = v
    meta = {k: v for k, v in machine.items() if k not in ("name", "chain", "travel_mm")}
    raw = doc.get("measurements", [])
    if not isinstance(raw, list) or not raw:
        raise _err("no [[measurements]] in the session", toml_path, None, "measurements")
    seen: set[str] = set()
    meas = []
    for i, e in enumerate(raw):
        m = _read_entry(e, i, folder, toml_path, seen, require_deviation)
        check_in_travel(m, travel, folder / m.file)
        if m.meta.get("readings") == "raw" and m.deviation is not None:
            from volcal.environment.apply import compensate_measurement

            m = compensate_measurement(m, f"{toml_path} [{m.id}]")
        meas.append(m)
    return Session(name, chain, travel, meas, meta, folder)


TRAVEL_MARGIN_MM = 1.0
TRAVEL_MARGIN_REL = 0.005
"""A commanded pose may lie this far outside the stated travel: 1 mm + 0.5 % of the axis
length (rounding of the stated limits); anything further is an error."""


def check_in_travel(m: Measurement, travel: NDArray[np.float64], path: Path) -> None:
    """Refuse commanded poses outside the travel, naming file, row and column.

    Parameters
    ----------
    m : Measurement
        A measurement as read.
    travel : ndarray, shape (3, 2)
        Travel limits [mm].
    path : Path
        Its CSV file, for the message.

    Raises
    ------
    VolcalInputError
        The first pose (row, header = row 1) beyond the travel plus
        :data:`TRAVEL_MARGIN_MM` + :data:`TRAVEL_MARGIN_REL` of the axis length.
    """
    margin = TRAVEL_MARGIN_MM + TRAVEL_MARGIN_REL * (travel[:, 1] - travel[:, 0])
    out = (m.positions < travel[:, 0] - margin) | (m.positions > travel[:, 1] + margin)
    if np.any(out):
        i, k = (int(v[0]) for v in np.nonzero(out))
        raise VolcalInputError(
            f"commanded position {m.positions[i, k]:g} mm lies outside the travel "
            f"{travel[k, 0]:g}..{travel[k, 1]:g} mm of {'XYZ'[k]}", path, i + 2,
            f"{'xyz'[k]}_mm")


def _read_entry(e: Any, i: int, folder: Path, toml_path: Path, seen: set[str],
                require_deviation: bool) -> Measurement:
    where = f"measurements[{i}]"
    if not isinstance(e, dict):
        raise _err("each [[measurements]] entry must be a table", toml_path, None, where)
    mid = e.get("id")
    if not isinstance(mid, str) or not mid:
        raise _err("missing or empty id", toml_path, None, f"{where}.id")
    if mid in seen:
        raise _err(f"duplicate measurement id {mid!r}", toml_path, None, f"{where}.id")
    seen.add(mid)
    kind = e.get("kind")
    if kind not in KINDS:
        raise _err(f"unknown kind {kind!r}: expected one of {', '.join(KINDS)}", toml_path, None,
                   f"{where}.kind")
    target = e.get("target", "retroreflector")
    if target not in TARGETS:
        raise _err(f"unknown target {target!r}: expected one of {', '.join(TARGETS)}", toml_path,
                   None, f"{where}.target")
    file = e.get("file")
    if not isinstance(file, str) or not file:
        raise _err("missing file name", toml_path, None, f"{where}.file")
    csv_path = folder / file
    if not csv_path.is_file():
        raise _err(f"measurement file {file!r} not found beside session.toml", toml_path, None,
                   f"{where}.file")
    offset = _vec3(e.get("tool_offset_mm", [0, 0, 0]), toml_path, f"{where}.tool_offset_mm")
    pos, dev, cols = read_measurement_csv(csv_path, require_deviation)
    if "beam_direction" in e:
        n = _vec3(e["beam_direction"], toml_path, f"{where}.beam_direction", nonzero=True)
    else:
        d = pos - pos[0]
        far = int(np.argmax(np.linalg.norm(d, axis=1)))
        if np.linalg.norm(d[far]) < 1e-9:
            raise _err("all readings at one position: cannot infer the beam direction",
                       csv_path)
        n = d[far]
    n = n / np.linalg.norm(n)
    meta = {k: v for k, v in e.items()
            if k not in ("id", "kind", "target", "file", "tool_offset_mm", "beam_direction")}
    if kind == "linear" and "axis" in meta:
        a = meta["axis"]
        if not isinstance(a, str) or a.upper() not in ("X", "Y", "Z"):
            raise _err(f"axis must be \"X\", \"Y\" or \"Z\", got {a!r}", toml_path, None,
                       f"{where}.axis")
        moving = int(np.argmax(np.ptp(pos, axis=0)))
        if "XYZ".index(a.upper()) != moving:
            raise _err(f"axis = {a!r} but the positions in {file} move along "
                       f"{'XYZ'[moving]}", toml_path, None, f"{where}.axis")
    env = meta.get("environment")
    if env is not None and not isinstance(env, dict):
        raise _err("environment must be a table", toml_path, None, f"{where}.environment")
    return Measurement(mid, kind, target, pos, dev, n, offset, file, cols, meta)
