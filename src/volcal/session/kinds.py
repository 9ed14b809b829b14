"""The registry of measurement kinds: one object per ``kind`` of ``session.toml``.

A measurement kind is everything volcal knows about one sort of reading: the keys of its
``[[measurements]]`` entry and its CSV reader, its forward model (exact readings of a
virtual machine) and its Jacobian rows with the set-up nuisances and their priors (what
the estimator needs), how it is simulated, planned and programmed where it has such hooks,
and which standard evaluates it. Every step of the flow looks the kind up here
(:func:`kind_of`) instead of comparing the ``kind`` string.

The built-in kinds live in :mod:`volcal.kinds.linear`, :mod:`volcal.kinds.diagonal`,
:mod:`volcal.kinds.step_diagonal`, :mod:`volcal.kinds.multilateration`,
:mod:`volcal.kinds.straightness`, :mod:`volcal.kinds.angular` and
:mod:`volcal.kinds.rotary`; they are imported on
the first look-up. Another kind is a subclass of :class:`Kind` passed to
:func:`register_kind` (``docs/architecture.md``, "Adding a measurement kind").

The registry sits low, beside the session format (it imports nothing of volcal but its
errors), so that every room that handles measurements (the session reader, measure,
identify, plan, program, standards, report) can look a kind up; the kind modules sit
above them all (``volcal.kinds``, they use the readers, the forward models, the
estimator's rows, the planners and the report's sections) and are found by name
(:data:`BUILTIN_KINDS`), like any plug-in. :mod:`volcal.kinds` re-exports this API.
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from volcal.errors import VolcalInputError

__all__ = ["BUILTIN_KINDS", "Kind", "ReadContext", "RowBlock", "hooks_of", "kind_names",
           "kind_of", "kinds", "register_kind", "target_names", "unregister_kind"]

BUILTIN_KINDS: dict[str, str] = {
    "linear": "volcal.kinds.linear",
    "diagonal": "volcal.kinds.diagonal",
    "step_diagonal": "volcal.kinds.step_diagonal",
    "multilateration": "volcal.kinds.multilateration",
    "straightness": "volcal.kinds.straightness",
    "angular": "volcal.kinds.angular",
    "rotary": "volcal.kinds.rotary",
    "probe_sphere": "volcal.kinds.probe_sphere",
    "r_test": "volcal.kinds.r_test",
}
"""Built-in kind -> the module that registers it (imported on the first look-up)."""


@dataclass(frozen=True)
class ReadContext:
    """What the session reader hands a kind's :meth:`Kind.read` for one entry.

    Attributes
    ----------
    where : str
        TOML key of the entry (``'measurements[3]'``), for messages.
    id, kind, target, file : str
        The entry's checked ``id``, ``kind``, ``target`` and ``file``.
    csv_path : Path
        The measurement's CSV file.
    toml_path : Path
        The session's ``session.toml``.
    tool_offset : ndarray, shape (3,)
        ``tool_offset_mm`` [mm].
    require_deviation : bool
        False for planned skeletons (plan, program, simulate): missed captures stay NaN.
    travel : ndarray, shape (3, 2)
        The machine's travel [mm].
    notes : list of str
        The reader's notes (a kind appends what the user should know).
    vertical : int
        The machine's vertical axis (0, 1, 2).
    machine : dict
        The other keys of the session's ``[machine]`` table (``rotary_axes``...).
    """

    where: str
    id: str
    kind: str
    target: str
    file: str
    csv_path: Path
    toml_path: Path
    tool_offset: NDArray[np.float64]
    require_deviation: bool
    travel: NDArray[np.float64]
    notes: list[str] = field(default_factory=list)
    vertical: int = 2
    machine: dict[str, Any] = field(default_factory=dict)


@dataclass
class RowBlock:
    """Rows of one measurement in the unified estimator.

    Attributes
    ----------
    J : scipy.sparse matrix, shape (n, P)
        Rows on the full parameter layout [reading unit per parameter unit], weighted by
        :meth:`Kind.row_weight`.
    y : ndarray, shape (n,)
        The readings, weighted the same way.
    N : ndarray, shape (n, k)
        Nuisance columns (dense), weighted the same way.
    names : list of str
        Nuisance names; a name seen in several measurements is one shared column.
    """

    J: Any
    y: NDArray[np.float64]
    N: NDArray[np.float64]
    names: list[str]

    def __iter__(self):
        """Unpack as ``J, y, N, names``."""
        return iter((self.J, self.y, self.N, self.names))


class Kind:
    """One measurement kind. Subclass it, set the class attributes, implement the hooks.

    Required: :attr:`name`, :attr:`targets`, :meth:`read`, :meth:`exact` and
    :meth:`rows`. Everything else has a default that fits a kind without it (no plan
    test, no part-program notes, no standard).

    Attributes
    ----------
    name : str
        The ``kind`` of ``session.toml``.
    targets : tuple of str
        Targets (``target``) this kind accepts; the first is the default.
    own_targets : tuple of str
        Targets that belong to this kind only (refused in any other kind, naming this one).
    default_target : str or None
        Target of an entry without ``target``; None: the first of :attr:`targets`.
    value_column : str
        Reading column of its CSV files (``deviation_um``, ``angle_urad``...).
    value_unit : str
        Unit of the readings: ``'um'`` or ``'urad'``.
    beam_in_session : bool
        Whether ``beam_direction`` is part of the set-up written to ``session.toml``.
    bidirectional : bool
        Readings approached from both directions along one axis (ISO 230-2): a reversal
        nuisance in identify, the machine's reversal in simulation, the overrun in the
        part programs.
    standard : str or None
        The standard evaluating it alone (``'ISO 230-2'``, ``'ISO 230-6'``) or None.
    systematic : str or None
        Its systematic errors in the budget: ``'length'`` (a laser length along the beam:
        wavelength, air and material scale, :mod:`volcal.identify.systematic`),
        ``'optic'`` (the scale of the optic), None (none modelled).
    plan_tests : tuple of str
        Names this kind adds to ``volcal plan --tests`` (built by :meth:`plan`).
    in_design : bool
        Whether its readings enter the identification of the linear axes' errors
        (``volcal identify``); False for a kind evaluated on its own (``rotary``).
    raw_readings : bool
        Its readings are laser lengths: ``readings = "raw"`` (as the laser counted them,
        not compensated for the air) is accepted and compensated from the measurement's
        environment (:func:`volcal.environment.apply.prepare_readings`).
    referable : bool
        volcal refers its compensated readings to 20 degC when the session says they are
        not (``referred_to_20c = false``, ISO 1; the material correction of a length
        along a line).
    linear_nodes : bool
        Whether its positions place nodes of the linear axes' error functions (the
        identification's grid, :func:`volcal.identify.design.choose_nodes`); False for a
        kind whose positions are no readings along the linear axes (the sphere centres
        of ``probe_sphere``: dozens of positions without a reading of the linear axes).
    description : str
        One line for the documentation and the report.
    along_beam : bool
        Its poses run along its beam direction (a line, a diagonal, the steps of a step
        diagonal, an optic along its axis): the session's plausibility check warns when
        they run against it (rows in reverse order). False for poses that circle or
        spread around (a tracker's grid, the R-test's paths, probed sphere centres).
    captured_by : str
        Empty when ``volcal capture`` takes its readings (one value per dwell of its part
        program at a position of the linear axes, or at an angle of a rotary axis: a
        ``rotary`` test; three values per pose of an ``r_test``); else how its readings
        reach the session instead, as ``volcal capture`` says when it passes such a
        measurement over.
    from_first_row : bool
        Its readings count from the first row (the instrument zeroed there: a rotary
        calibrator) though they are no displacement along a beam: ``volcal capture``
        writes each reading minus the first's (a displacement kind is counted from the
        first row anyway, :attr:`displacement`).
    evaluated_by : str
        For a kind outside the identification (:attr:`in_design` False): what evaluates
        it instead, as `volcal identify` says when it leaves such measurements out.
    """

    name: ClassVar[str] = ""
    targets: ClassVar[tuple[str, ...]] = ()
    own_targets: ClassVar[tuple[str, ...]] = ()
    default_target: ClassVar[str | None] = None
    value_column: ClassVar[str] = "deviation_um"
    value_unit: ClassVar[str] = "um"
    beam_in_session: ClassVar[bool] = True
    bidirectional: ClassVar[bool] = False
    standard: ClassVar[str | None] = None
    systematic: ClassVar[str | None] = None
    plan_tests: ClassVar[tuple[str, ...]] = ()
    in_design: ClassVar[bool] = True
    raw_readings: ClassVar[bool] = False
    referable: ClassVar[bool] = False
    linear_nodes: ClassVar[bool] = True
    description: ClassVar[str] = ""
    along_beam: ClassVar[bool] = True
    captured_by: ClassVar[str] = ""
    from_first_row: ClassVar[bool] = False
    evaluated_by: ClassVar[str] = ""

    @property
    def displacement(self) -> bool:
        """Its readings are laser displacements along its beam, counted from the first row.

        ``beam_in_session`` and read in ``deviation_um``: ``volcal capture`` writes each
        reading as the change since the first, and the plausibility check expects the first
        near 0 (a rotary test's or an optic's first reading is an error like any other).
        """
        return bool(self.beam_in_session) and self.value_column == "deviation_um"

    # -- session ---------------------------------------------------------------------
    def read(self, entry: dict[str, Any], ctx: ReadContext) -> Any:
        """Read one ``[[measurements]]`` entry and its CSV file.

        Parameters
        ----------
        entry : dict
            The entry as parsed from ``session.toml``.
        ctx : ReadContext
            Checked id, kind, target, file and the session's context.

        Returns
        -------
        volcal.session.format.Measurement

        Raises
        ------
        VolcalInputError
            Naming the file, row and key of what is wrong.
        """
        raise NotImplementedError(f"kind {self.name!r} has no reader")

    def axis(self, m: Any) -> int | None:
        """Measured axis (0, 1, 2) of a measurement along one axis, else None.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return None

    def csv_values(self, m: Any) -> tuple[str, NDArray[np.float64] | None, str]:
        """Reading column, values and number format of the CSV a measurement writes.

        Parameters
        ----------
        m : Measurement
            The measurement.

        Returns
        -------
        column : str
        values : ndarray or None
            In the file's unit (None: a planned skeleton).
        fmt : str
            ``str.format`` pattern of a value.
        """
        return self.value_column, m.deviation, "{:.6f}"

    def csv_text(self, m: Any) -> str | None:
        """The whole CSV text of a measurement of its own layout; None: the common layout.

        The common layout is ``x_mm, y_mm, z_mm``, the reading column of
        :meth:`csv_values` and the optional columns; a kind whose CSV has other columns
        (``rotary``: ``target_deg, run, direction, deviation_urad``) writes it here.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return None

    # -- forward model and estimator -------------------------------------------------
    def exact(self, machine: Any, m: Any, setup: Any = None) -> NDArray[np.float64]:
        """Exact readings of a virtual machine, without noise [value_unit].

        Parameters
        ----------
        machine : MachineErrors
            The machine.
        m : Measurement
            The measurement (positions and set-up).
        setup : object, optional
            The set-up errors :meth:`simulate` draws; None: a perfect set-up.

        Returns
        -------
        ndarray, shape (n,)
        """
        raise NotImplementedError(f"kind {self.name!r} has no forward model")

    def rows(self, chain_order: Any, nodes: Any, m: Any, *, drift: bool = False,
             tilts: bool = True) -> RowBlock:
        """Jacobian rows of a measurement's readings with its nuisance columns.

        Parameters
        ----------
        chain_order : sequence of int
            ``Chain.order``.
        nodes : list of 3 arrays
            Node positions per axis [mm].
        m : Measurement
            The measurement (with readings).
        drift : bool
            Add a drift nuisance where it is separable from the geometry.
        tilts : bool
            Add the set-up tilt nuisances where the kind has them.

        Returns
        -------
        RowBlock
        """
        raise NotImplementedError(f"kind {self.name!r} has no Jacobian rows")

    def nuisance_priors(self, m: Any) -> dict[str, tuple[float, float]]:
        """Informative priors of nuisances: name -> (mean, standard deviation).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return {}

    def row_weight(self, m: Any) -> float:
        """Weight of the rows (the estimator's unit over the readings'); 1 by default.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return 1.0

    def design_notes(self, measurements: list[Any]) -> list[str]:
        """What the measurements of this kind add, in plain words (identify, advise).

        Parameters
        ----------
        measurements : list of Measurement
            The measurements (of every kind) of the design.
        """
        return []

    def advise_notes(self, session: Any, planned: Any, options: Any) -> list[str]:
        """What ``volcal advise`` says about this kind's measurements before measuring.

        Parameters
        ----------
        session : Session
            The planned session.
        planned : Session
            Its copy with zero readings (the design's).
        options : IdentifyOptions
            The options of ``advise`` (``suggest``: also compare alternatives).

        Returns
        -------
        list of str
        """
        return []

    # -- simulation ------------------------------------------------------------------
    def prepare(self, session: Any) -> None:
        """Make the session ready for simulation or identification (once per kind).

        Parameters
        ----------
        session : Session
            The session (modified in place).
        """

    def simulate(self, m: Any, machine: Any, rng: np.random.Generator, options: Any,
                 shared: dict[str, Any]) -> Any:
        """Fill ``m.deviation`` (and ``time_s``) from a virtual machine, in place.

        The default: :meth:`exact` with a perfect set-up, the drift, and noise of
        ``options.noise_um`` in the reading's unit, counted from the first row.

        Parameters
        ----------
        m : Measurement
            Planned measurement.
        machine : MachineErrors
            The virtual machine.
        rng : numpy.random.Generator
            The simulation's generator.
        options : SimulationOptions
            Noise, drift, dwell.
        shared : dict
            State shared by the measurements of one simulation (stations, groups, the
            session folder as ``'path'``, the tracker options as ``'tracker'``).

        Returns
        -------
        object
            The set-up errors drawn (part of the truth), or None.
        """
        dev = self.exact(machine, m)
        time_s = np.arange(m.n) * options.dwell_s
        dev = dev + options.drift_um_per_h * time_s / 3600.0
        if options.noise_um > 0:
            noise = rng.normal(0.0, options.noise_um, m.n)
            dev = dev + noise - noise[0]
        m.deviation = dev - dev[0]
        m.columns["time_s"] = time_s
        m.columns.pop("status", None)
        return None

    # -- plan, program, evaluate, report -------------------------------------------
    def plan(self, test: str, options: Any, only: str | None = None) -> list[Any]:
        """Measurements of one of :attr:`plan_tests` (``volcal plan --tests``).

        Parameters
        ----------
        test : str
            One of :attr:`plan_tests`.
        options : volcal.plan.planner.PlanOptions
            Travel, chain, steps, runs... of the plan.
        only : str or None
            Axis or plane qualifier (``linear:x``).

        Returns
        -------
        list of Measurement
        """
        raise VolcalInputError(f"kind {self.name!r} plans no test {test!r}")

    def program_setup_lines(self, m: Any) -> list[str] | None:
        """Set-up lines of the part program's header (which optic, how); None: the default.

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return None

    def program_text(self, m: Any, dialect: str, name: str, number: int, options: Any
                     ) -> tuple[str, list[str]] | None:
        """The whole part program of a measurement in its own shape; None: the common one.

        The common program (:mod:`volcal.program.steps`) moves the linear axes to the
        poses; a kind that moves other axes (``rotary``) writes its program here.

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
        name : str
            Program name.
        number : int
            Fanuc program number.
        options : volcal.program.steps.ProgramOptions
            Dwell, feed, overruns, decimals, safe Z.

        Returns
        -------
        (text, warnings) or None
        """
        return None

    def program_positions(self, m: Any, dialect: str) -> list[tuple[str, Any]] | None:
        """The linear positions a kind's own program commands, to check against the travel.

        :func:`volcal.program.writer.write_programs` refuses a program with one outside the
        session's travel, naming the measurement, the position's label and the axis.

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect.

        Returns
        -------
        list of (str, array_like) or None
            Label (``'pose 3'``, ``'between pose 3 and 4'`` ...) and machine position X, Y,
            Z [mm] of each; None: nothing to check (the common program checks its poses).
        """
        return None

    def program_files(self, m: Any, dialect: str, name: str) -> dict[str, str]:
        """Files the measurement's part program needs beside it (default none).

        Parameters
        ----------
        m : Measurement
            The measurement.
        dialect : str
            The dialect.
        name : str
            The program's name.

        Returns
        -------
        dict of str to str
            File name to text.
        """
        return {}

    def evaluate_positioning(self, m: Any, edition: str, budget: Any) -> Any:
        """Its own ISO 230-2 evaluation (a rotary axis); None: the linear one.

        :func:`volcal.standards.session.evaluate_session` asks a kind whose
        :attr:`standard` is ISO 230-2; the linear evaluation reads positions along an
        axis, a kind whose targets are something else (angles) evaluates itself here.

        Parameters
        ----------
        m : Measurement
            The measurement (with readings).
        edition : str
            ISO 230-2 edition.
        budget : Budget or None
            The uncertainty budget.

        Returns
        -------
        object or None
        """
        return None

    def evaluate(self, m: Any) -> dict[str, Any] | None:
        """Evaluation of one measurement by itself (None: none; see :attr:`standard`).

        Parameters
        ----------
        m : Measurement
            The measurement.
        """
        return None

    def report_section(self, inp: Any) -> Any:
        """The report's section for this kind's measurements (None: none).

        Parameters
        ----------
        inp : volcal.report.sections.ReportInputs
            The session and its results.
        """
        return None


_REGISTRY: dict[str, Kind] = {}
_BUILTINS_LOADED = False
_LOAD_LOCK = threading.Lock()
_LOADER: int | None = None  # the thread importing the built-in kinds


def _load_builtins() -> None:
    # Loaded is set only once every module is imported, under a lock: a second thread
    # waits for the first instead of reading a registry still being filled (two threads
    # reading sessions at once saw "unknown kind 'step_diagonal': expected one of "). The
    # loading thread's own calls (each module registers its kind) return at once.
    global _BUILTINS_LOADED, _LOADER
    if _BUILTINS_LOADED or _LOADER == threading.get_ident():
        return
    with _LOAD_LOCK:
        if _BUILTINS_LOADED:
            return
        _LOADER = threading.get_ident()
        try:
            for module in BUILTIN_KINDS.values():
                importlib.import_module(module)
            _BUILTINS_LOADED = True
        finally:
            _LOADER = None


def register_kind(kind: Kind | type[Kind], replace: bool = False) -> Kind:
    """Register a measurement kind (an instance or a class with no-argument constructor).

    Parameters
    ----------
    kind : Kind or type of Kind
        The kind.
    replace : bool
        Replace a kind already registered under this name.

    Returns
    -------
    Kind
        The registered instance (so that ``register_kind`` works as a class decorator's
        companion: ``MY = register_kind(MyKind)``).

    Raises
    ------
    VolcalInputError
        No name or targets, or the name already registered (without ``replace``).
    """
    k = kind() if isinstance(kind, type) else kind
    if not isinstance(k, Kind):
        raise VolcalInputError(f"a measurement kind must be a volcal.kinds.Kind, got {k!r}")
    if not k.name or not k.name.isidentifier():
        raise VolcalInputError(f"a measurement kind needs a name (an identifier), got "
                               f"{k.name!r}")
    if not k.targets:
        raise VolcalInputError(f"kind {k.name!r}: no targets")
    _load_builtins()  # the built-in kinds first, in their documented order
    if not replace and k.name in _REGISTRY:
        raise VolcalInputError(f"measurement kind {k.name!r} is already registered")
    _REGISTRY[k.name] = k
    return k


def unregister_kind(name: str) -> None:
    """Remove a registered kind (tests registering their own kind clean up with it).

    Parameters
    ----------
    name : str
        The kind's name; built-in kinds cannot be removed.

    Raises
    ------
    VolcalInputError
        A built-in kind.
    """
    if name in BUILTIN_KINDS:
        raise VolcalInputError(f"the built-in kind {name!r} cannot be unregistered")
    _REGISTRY.pop(name, None)


def kinds() -> tuple[Kind, ...]:
    """Every registered kind, the built-in ones first in their documented order."""
    _load_builtins()
    # a kind's module imported before the first look-up registers it early: keep the order
    builtin = [_REGISTRY[n] for n in BUILTIN_KINDS if n in _REGISTRY]
    return tuple(builtin + [k for n, k in _REGISTRY.items() if n not in BUILTIN_KINDS])


def kind_names() -> tuple[str, ...]:
    """Names of every registered kind (``kind`` values a session may hold)."""
    return tuple(k.name for k in kinds())


def target_names() -> tuple[str, ...]:
    """Every target a registered kind accepts, each once, in registration order."""
    out: dict[str, None] = {}
    for k in kinds():
        out.update(dict.fromkeys(k.targets))
    return tuple(out)


def kind_of(name: Any, file: str | Path | None = None, key: str | None = None) -> Kind:
    """The registered kind of this name.

    Parameters
    ----------
    name : str
        ``kind`` of a measurement.
    file : str or Path, optional
        File of the value, for the error.
    key : str, optional
        TOML key of the value, for the error.

    Returns
    -------
    Kind

    Raises
    ------
    VolcalInputError
        An unknown kind; the message lists the registered ones.
    """
    _load_builtins()
    k = _REGISTRY.get(name) if isinstance(name, str) else None
    if k is None:
        raise VolcalInputError(f"unknown kind {name!r}: expected one of "
                               f"{', '.join(_REGISTRY)}", file, None, key)
    return k


def hooks_of(present: list[str], method: str) -> list[Callable[..., Any]]:
    """Distinct bound hooks ``method`` of the kinds in ``present``, in registry order.

    Two kinds sharing one implementation (the straightness and angular optics share the
    report's optics section) give it once.

    Parameters
    ----------
    present : list of str
        Kind names (those of a session's measurements).
    method : str
        A method of :class:`Kind`.

    Returns
    -------
    list of callable
    """
    seen: set[Any] = set()
    out = []
    for k in kinds():
        if k.name not in present:
            continue
        fn = getattr(k, method)
        key = getattr(fn, "__func__", fn)
        if key in seen or key is getattr(Kind, method):
            continue
        seen.add(key)
        out.append(fn)
    return out
