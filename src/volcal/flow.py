"""The calibration flow as a small library object.

:class:`Calibration` chains plan -> advise -> program -> simulate (or measure, or
import) -> identify -> evaluate -> compensate -> report on one session, each step one
method, so that the whole flow is a few lines of Python (``docs/python.md``). The
command line and the demo call the same functions, and the defaults of both come from
:mod:`volcal.defaults` (``tests/test_defaults_parity.py`` compares them). Heavy modules
(the estimator, matplotlib) are imported only by the steps that need them.

Every mistake in a call (an unknown keyword, a value of the wrong shape or kind) is a
:class:`~volcal.errors.VolcalInputError` naming the valid choices, as on the command line.

Examples
--------
>>> from volcal import Calibration                              # doctest: +SKIP
>>> cal = Calibration.plan([[0, 800], [0, 600], [0, 500]], chain="XYFZ")  # doctest: +SKIP
>>> cal.simulate(seed=3).save("S")                              # doctest: +SKIP
>>> cal.identify().to_json("model.json")                        # doctest: +SKIP
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from numpy.typing import ArrayLike

from volcal import defaults as D
from volcal import flowargs as A
from volcal.errors import VolcalInputError

if TYPE_CHECKING:
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.identify.result import IdentificationResult
    from volcal.importer.laser_csv import ImportResult
    from volcal.model.errorfunctions import MachineErrors
    from volcal.report.certificate_files import CertificateFiles
    from volcal.report.verdict import Verdict
    from volcal.report.writer import ReportFiles
    from volcal.session.format import Session
    from volcal.standards.iso230_2_uncertainty import Iso2302Uncertainty
    from volcal.standards.session import SessionEvaluation
    from volcal.steps.compensate import Compensated
    from volcal.steps.locate import Located
    from volcal.steps.predict import Prediction
    from volcal.steps.simulate import Simulated
    from volcal.uncertainty.budget import Budget

__all__ = ["Calibration"]

class Calibration:
    """One calibration: a session, its model and its evaluation.

    Parameters
    ----------
    session : Session
        Planned, simulated or measured session.
    truth : MachineErrors, optional
        The simulated machine (set by :meth:`simulate`).

    Attributes
    ----------
    session : Session
    truth : MachineErrors or None
    result : IdentificationResult or None
        Set by :meth:`identify` (or :meth:`load_model`).
    evaluation : SessionEvaluation or None
        Set by :meth:`evaluate`.
    compensation : Path or None
        Folder written by :meth:`compensate`.
    compensated : Compensated or None
        What :meth:`compensate` wrote: files, sign and, with ``session=``, the line checks
        (ISO 230-2 A of each measured line before and after the tables).
    imported : ImportResult or None
        What :meth:`import_` read (notes on units and columns).
    uncertainties : dict of str to Iso2302Uncertainty, or None
        Set by :meth:`evaluate` with a ``budget``: per linear test, the expanded
        uncertainty ``U`` [um] of every ISO 230-2 parameter (``.parameters['A'].U``) and
        target (``.targets[i].U``), as ``volcal evaluate session --budget``.
    certificate : CertificateFiles or None
        Set by :meth:`report` when it issues a certificate: ``.pdf``, ``.html``,
        ``.json`` in the report folder, ``.pdf_pages``.
    """

    def __init__(self, session: Session, truth: MachineErrors | None = None) -> None:
        self.session = session
        self.truth = truth
        self.result: IdentificationResult | None = None
        self.evaluation: SessionEvaluation | None = None
        self.compensation: Path | None = None
        self.compensated: Compensated | None = None
        self.imported: ImportResult | None = None
        self.uncertainties: dict[str, Iso2302Uncertainty] | None = None
        self.certificate: CertificateFiles | None = None
        self._simulated: Simulated | None = None

    def __repr__(self) -> str:
        """Short description."""
        s = self.session
        n = sum(m.deviation is not None for m in s.measurements)
        return (f"Calibration({s.name!r}, chain={s.chain!r}, {len(s.measurements)} "
                f"measurements, {n} with readings, identified={self.result is not None})")

    # ------------------------------------------------------------------ build
    @classmethod
    @A.checked
    def plan(cls, travel: ArrayLike | str, chain: str = D.CHAIN, steps: int = D.PLAN_STEPS,
             tests: str | Sequence[str] = D.PLAN_TESTS, runs: int = D.PLAN_RUNS,
             name: str = D.PLAN_NAME, step_orders: str | Sequence[str] = D.PLAN_STEP_ORDERS,
             tool_offset: ArrayLike | str = D.PLAN_TOOL_OFFSET_MM,
             iso_spacing: bool = True, step_target: str = D.PLAN_STEP_TARGET,
             overrun_mm: float = D.PROG_OVERRUN_MM,
             abbe_offset_mm: float = D.PLAN_ABBE_OFFSET_MM,
             multilateration: Mapping[str, ArrayLike | float] | None = None,
             targets: str | Sequence[float] | None = None,
             rotary_axes: str | None = None) -> Calibration:
        """Plan the tests of a machine (no readings yet), like ``volcal plan``.

        Calls :func:`volcal.steps.plan.plan`; :meth:`save` writes the session.

        Parameters
        ----------
        travel : array_like, shape (3, 2), or str
            Travel limits [mm]: ``[[0, 800], [0, 600], [0, 500]]`` or
            ``'0:800,0:600,0:500'``.
        chain : str
            Kinematic chain code (``'XYFZ'``...).
        steps : int
            Increments per test.
        tests : sequence of str, or str
            ``'step-diagonal'``, ``'diagonal'``, ``'linear'``, ``'face-diagonal'``,
            ``'face-step-diagonal'``, ``'multilateration'``.
        runs : int
            Bidirectional runs per linear test (ISO 230-2).
        name : str
            Machine name.
        step_orders : sequence of str, or str
            Axis orders of the step diagonals (``'xyz'``, ``'yxz'``...).
        tool_offset : array_like, shape (3,), or str
            Target point on the tool [mm].
        iso_spacing : bool
            Unequally spaced linear-test targets (ISO 230-2:2014, 5.2).
        step_target : str
            ``'flat_mirror'``, ``'retroreflector'`` or ``'retroreflector_mirror'``.
        overrun_mm : float
            Linear-test targets kept this far inside the travel [mm].
        abbe_offset_mm : float
            Target offset from the spindle of the Abbe lines [mm].
        multilateration : dict, optional
            ``grid``, ``n_stations`` or ``stations`` [mm], ``tool_offsets`` [mm],
            ``station_u_mm`` of a multilateration plan
            (:func:`volcal.plan.multilateration.multilateration_tests`); the keys not
            given take the command line's defaults (``--grid 9,7,6 --stations 4
            --tool-offsets '0,0,-100;100,100,-100'``).
        targets : str or sequence of float, optional
            Target angles of the rotary tests [deg] (``tests=['rotary:c']``).
        rotary_axes : str, optional
            The machine's rotary axes, ``'c:0:360:modulo,a:-120:30:limited'`` [deg].

        Returns
        -------
        Calibration
        """
        from volcal.steps.plan import plan

        return cls(plan(A.travel_mm(travel), chain=chain, steps=steps, tests=tests, runs=runs,
                        name=name, step_orders=step_orders,
                        tool_offset=A.vector_mm(tool_offset, "tool_offset"),
                        iso_spacing=iso_spacing, step_target=step_target,
                        overrun_mm=overrun_mm, abbe_offset_mm=abbe_offset_mm,
                        multilateration=multilateration, targets=targets,
                        rotary_axes=rotary_axes).session)

    @classmethod
    @A.checked
    def open(cls, folder: str | Path) -> Calibration:
        """Open a session folder (``session.toml`` and its CSVs).

        Parameters
        ----------
        folder : str or Path
            Session folder; a simulated session's ``truth/machine.csv`` is read too.

        Returns
        -------
        Calibration
        """
        from volcal.report.pipeline import read_truth
        from volcal.session.format import read_session

        try:  # measured: notes, missed captures and plausibility warnings as in the CLI
            s = read_session(folder)
        except VolcalInputError as exc:
            if not exc.message.startswith("no readings yet"):
                raise
            s = read_session(folder, require_deviation=False)  # planned, no reading yet
        return cls(s, read_truth(s))

    @classmethod
    @A.checked
    def import_(cls, csv_file: str | Path, map: str | Mapping[str, str] | None = None,
                session: str | Path | None = None, axis: str | None = None,
                id: str | None = None,
                measurement: str | None = None,
                line_mm: ArrayLike | str = D.TOOL_OFFSET_MM, units: str = D.IMPORT_UNITS,
                deviation_units: str = D.IMPORT_DEVIATION_UNITS,
                optics: str = D.IMPORT_OPTICS, tool_offset: ArrayLike | str = D.TOOL_OFFSET_MM,
                travel: ArrayLike | str | None = None, chain: str = D.IMPORT_CHAIN,
                name: str = D.IMPORT_NAME, replace: bool = False, sign: str = D.IMPORT_SIGN,
                slope_removed: bool = False, dwell_s: float = D.IMPORT_DWELL_S) -> Calibration:
        """Add a laser's CSV export to a session folder, like ``volcal import``.

        Calls :func:`volcal.steps.importer.import_` (the text of ``travel``, ``line_mm``
        and ``tool_offset`` accepted as on the command line).

        Either a new linear measurement (``axis`` and ``id``; the session is created
        with ``travel`` if it does not exist) or the readings of a planned measurement
        (``measurement``). The folder is written atomically, then opened.

        Parameters
        ----------
        csv_file : str or Path
            The laser's export.
        map : str or dict
            Column mapping, ``'target=Pos,deviation=Error'`` or ``{'target': 'Pos',
            'deviation': 'Error'}`` (keys of ``volcal import --map``, docs/formats.md);
            required for a CSV export, not given for a Renishaw dynamic capture
            (``.rtx``, :mod:`volcal.importer.rtx_import`).
        session : str or Path
            Session folder (required).
        axis : str, optional
            Measured axis ``'X'``, ``'Y'`` or ``'Z'`` of a new linear measurement.
        id : str, optional
            Id of the new measurement.
        measurement : str, optional
            Id of a planned measurement to fill.
        line_mm : array_like, shape (3,), or str
            Machine position of the line [mm].
        units, deviation_units : str
            Units of the target/reading and deviation columns (``'auto'``: the header).
        optics : str
            ``'retroreflector'`` or ``'flat_mirror'``.
        tool_offset : array_like, shape (3,), or str
            Target on the tool [mm].
        travel : array_like, shape (3, 2), or str, optional
            Travel of a NEW session [mm].
        chain, name : str
            Chain and machine name of a new session.
        replace : bool
            Replace a measurement with this id (or the readings of ``measurement``).
        sign : str
            Direct optics (``measurement``): ``'+'`` (the instrument reads the tool side
            relative to the workpiece side, volcal's sign) or ``'-'`` (the other side).
        slope_removed : bool
            Direct optics: the vendor took the slope out of the straightness readings.
        dwell_s : float
            ``.rtx``: the part program's dwell at each target [s].

        Returns
        -------
        Calibration
            The session as written; :attr:`imported` holds the notes of the import.
        """
        from volcal.steps.importer import import_

        r = import_(csv_file, session=session, map=map, axis=axis, id=id,
                    measurement=measurement, line_mm=A.vector_mm(line_mm, "line_mm"),
                    units=units, deviation_units=deviation_units, optics=optics,
                    tool_offset=A.vector_mm(tool_offset, "tool_offset"),
                    travel=None if travel is None else A.travel_mm(travel), chain=chain,
                    name=name, replace=replace, sign=sign, slope_removed=slope_removed,
                    dwell_s=dwell_s)
        cal = cls.open(r.result.session)
        cal.imported = r.result
        return cal

    # ------------------------------------------------------------------ steps
    @A.checked
    def advise(self, roll: str = D.ROLL, candidates: str | Path | None = None,
               top: int = D.ADVISE_TOP, **options: object) -> IdentifiabilityReport:
        """Before measuring: what the planned tests will and will not determine.

        Like ``volcal advise`` (:func:`volcal.steps.advise.advise`); the readings are not
        used.

        Parameters
        ----------
        roll : str
            ``'estimate'`` or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero).
        candidates : str or Path, optional
            With probe_sphere tests: a CSV of candidate poses and sphere positions to
            rank (default a generated set); the ranking ends ``.messages``.
        top : int
            With probe_sphere tests: how many ranked candidates per chain.
        **options
            Other fields of :class:`volcal.identify.IdentifyOptions` (``known``...).

        Returns
        -------
        IdentifiabilityReport
            ``.messages`` in plain words, ``.suggestions``, ``.ambiguity_um`` [um].
        """
        from volcal.steps.advise import advise

        return advise(self._planned(), roll=roll, candidates=candidates, top=top,
                      **cast("dict[str, Any]", options)).report

    @A.checked
    def program(self, folder: str | Path, dialect: str, dwell_s: float = D.PROG_DWELL_S,
                feed: float = D.PROG_FEED, overrun_mm: float = D.PROG_OVERRUN_MM,
                decimals: int = D.PROG_DECIMALS, safe_z_mm: float = D.PROG_SAFE_Z_MM,
                first_number: int = D.PROG_FIRST_NUMBER, *,
                replace: bool = False) -> tuple[Path, list[str]]:
        """Write one measuring part program per measurement, like ``volcal program``.

        Calls :func:`volcal.steps.program.program`; only a new, empty or earlier program
        folder is replaced.

        Parameters
        ----------
        folder : str or Path
            Folder for the programs (written atomically).
        dialect : str
            ``'fanuc'``, ``'linuxcnc'``, ``'siemens'`` or ``'heidenhain'``.
        dwell_s : float
            Dwell at each reading pose [s].
        feed : float
            Feed of every move [mm/min].
        overrun_mm : float
            ISO 230-2 overrun before reversals [mm].
        decimals : int
            Decimals of the coordinates [mm].
        safe_z_mm : float
            Z of the first retract in machine coordinates [mm].
        first_number : int
            Fanuc program number (O word) of the first program.
        replace : bool
            The folder holds files volcal did not write there: move them into its
            ``backup/<UTC time>/`` instead of refusing, as ``--replace``.

        Returns
        -------
        folder : Path
            The program folder.
        notes : list of str
            What the user should know (the command line prints them as notes).
        """
        from volcal.steps.program import program

        r = program(self._planned(), dialect=dialect, output=folder, dwell_s=dwell_s,
                    feed=feed, overrun_mm=overrun_mm, decimals=decimals, safe_z_mm=safe_z_mm,
                    first_number=first_number, replace=replace)
        return r.folder, list(r.notes)

    @A.checked
    def simulate(self, machine: MachineErrors | str | Path | None = None,
                 seed: int = D.SIM_SEED,
                 noise_um: float = D.SIM_NOISE_UM,
                 mirror_misalignment_urad: float = D.SIM_MIRROR_URAD,
                 drift_um_per_h: float = D.SIM_DRIFT_UM_PER_H,
                 reversal_um: float = D.SIM_REVERSAL_UM, *,
                 budget: str | Path | Budget | None = None,
                 compensation: str | Path | None = None, force: bool = False) -> Calibration:
        """Fill the readings from a virtual machine (in memory; :meth:`save` writes them).

        Calls :func:`volcal.steps.simulate.simulate`.

        Parameters
        ----------
        machine : MachineErrors, str or Path, optional
            The virtual machine, or its error table (``ERRORS.csv``, as ``--machine``); a
            random realistic one (seeded) when omitted.
        seed : int
            Seed of the random machine and of the noise.
        noise_um : float
            Reading noise, standard deviation [um].
        mirror_misalignment_urad : float
            Set-up misalignment of the optics, standard deviation [urad]
            (``--mirror-urad``).
        drift_um_per_h : float
            Linear drift of the readings [um/h].
        reversal_um : float
            Largest reversal of a random machine's axes [um] (not used with ``machine``).
        budget : str, Path or Budget, optional
            Uncertainty budget (``volcal budget --template``): its systematic errors
            (wavelength, air sensors per measurement, material per axis, the scale of
            each direct optic) are drawn once
            from their distributions (seeded by ``seed``) and applied to the readings, as
            ``volcal simulate --budget``; :meth:`save` records the draw in
            ``truth/systematic.toml`` (:mod:`volcal.measure.systematic`).
        compensation : str or Path, optional
            Folder written by :meth:`compensate` (or ``volcal compensate``): the machine
            runs with these tables active, the as-left measurement of the virtual machine
            (``machine`` or ``seed`` the machine as found), as ``volcal simulate
            --compensation``; :attr:`truth` is then the machine with the tables active
            (None with a 3-D grid: the machine as found with its commanded positions
            shifted, which no error table holds).
        force : bool
            With ``compensation``: apply tables written for another machine.

        Returns
        -------
        Calibration
            ``self``, for chaining.
        """
        from volcal.steps.simulate import simulate

        # overwrite: in memory; save() refuses to replace measured readings on disk
        r = simulate(self.session, machine=machine, seed=seed, noise_um=noise_um,
                     mirror_misalignment_urad=mirror_misalignment_urad,
                     drift_um_per_h=drift_um_per_h, reversal_um=reversal_um, budget=budget,
                     overwrite=True, compensation=compensation, force=force)
        self._simulated = r
        self.truth = None if (r.compensation or {}).get("grid") else r.machine
        self.result = self.evaluation = None
        return self

    @A.checked
    def save(self, folder: str | Path) -> Calibration:
        """Write the session folder (with ``truth/`` after :meth:`simulate`), then read it back.

        Parameters
        ----------
        folder : str or Path
            Session folder to write.

        Returns
        -------
        Calibration
            ``self``, now tied to the written folder.

        Raises
        ------
        VolcalInputError
            ``folder`` is a file or a folder of another kind, or a session folder whose
            measured readings (not written by a simulation) differ from this session's:
            measured data are never overwritten. The other files of an existing session
            folder are kept, as by the command line.
        """
        from copy import copy

        from volcal.io.paths import check_output_folder
        from volcal.session.format import write_session

        folder = Path(folder)
        check_output_folder(folder, "session", lambda p: (p / "session.toml").is_file())
        full = self.session
        if full.unmeasured:  # measurements without readings yet are written too
            full = copy(full)
            full.measurements = [*full.measurements, *full.unmeasured]
            full.unmeasured = []
        if (folder / "session.toml").is_file():
            self._check_not_measured(folder, full)
        extra = None if self._simulated is None else self._simulated.truth_files()
        path = write_session(full, folder, extra, keep_existing=True)
        self.session = Calibration.open(path).session
        return self

    @staticmethod
    def _check_not_measured(folder: Path, new: Session) -> None:
        """Refuse to replace measured readings of an existing session folder."""
        from volcal.session.format import read_session
        from volcal.session.provenance import measured_ids, readings_digest

        old = read_session(folder, require_deviation=False)
        measured = measured_ids(old)
        if measured and readings_digest(old) != readings_digest(new):
            shown = ", ".join(measured[:6]) + (f" and {len(measured) - 6} more"
                                               if len(measured) > 6 else "")
            raise VolcalInputError(f"Calibration.save: holds measured readings ({shown}) "
                                   "that this session would replace; nothing was changed. "
                                   "Save to another folder", folder / "session.toml")

    @A.checked
    def identify(self, *, budget: str | Path | Budget | None = None,
                 **options: object) -> IdentificationResult:
        """Identify the 21 errors with uncertainties, like ``volcal identify``.

        Calls :func:`volcal.steps.identify.identify`.

        Parameters
        ----------
        budget : str, Path or Budget, optional
            Uncertainty budget (as ``--budget``): its systematic inputs (wavelength, air
            per set-up, material per axis, the scale of each direct optic) propagated
            through the fit and kept apart
            (:func:`volcal.identify.systematic.attach_systematic`);
            ``result.predict(q, systematic=False)`` gives the noise and prior part only.
        **options
            Fields of :class:`volcal.identify.IdentifyOptions` (``prior``, ``noise_um``
            [um], ``roll``, ``known``, ``drift``, ``max_nodes``, ``robust``...); the
            command line's names: ``measurements`` (``measurement_ids`` too),
            ``monte_carlo``; ``known`` may be the path of a CSV of errors measured
            separately (as ``--known``), with ``known_u`` [um or urad] to use them as
            priors; ``settings`` an :class:`~volcal.identify.EstimatorSettings` or the
            path of an estimator settings file (TOML, as ``--estimator-settings``).

        Returns
        -------
        IdentificationResult
            Also kept as :attr:`result`; it carries the session's identity.
        """
        from volcal.steps.identify import identify

        self.result = identify(self.session, budget=budget,
                               **cast("dict[str, Any]", options)).result
        self.evaluation = None
        return self.result

    @A.checked
    def predict(self, points: str | Path | ArrayLike,
                tool_offset: ArrayLike | str = D.TOOL_OFFSET_MM) -> Prediction:
        """The volumetric error and its uncertainty at points, like ``volcal predict``.

        Calls :func:`volcal.steps.predict.predict` with this calibration's model
        (:meth:`identify` or :meth:`load_model`).

        Parameters
        ----------
        points : str, Path or array_like, shape (n, 3)
            A CSV with ``x_mm,y_mm,z_mm`` or the points [mm], inside the travel.
        tool_offset : array_like, shape (3,), or str
            Tool offset x, y, z [mm].

        Returns
        -------
        Prediction
            ``.error_um``, ``.u_um`` (n, 3) [um]; ``.to_csv()`` is the command's file.
        """
        from volcal.steps.predict import predict

        return predict(self._need_result(), points,
                       tool_offset=A.vector_mm(tool_offset, "tool_offset"))

    @A.checked
    def locate(self, model: str | Path | MachineErrors | IdentificationResult | None = None,
               measurements: list[str] | None = None,
               prior_u: float | None = None) -> Located:
        """The rotary axes' location errors from probe_sphere and r_test tests (volcal locate).

        Calls :func:`volcal.steps.locate.locate` on this calibration's session.

        Parameters
        ----------
        model : str, Path, IdentificationResult or MachineErrors, optional
            The linear axes' errors (a model file or model, with its covariance as a prior;
            an error table or the errors, taken as known); None: this calibration's
            identified model, with its covariance, if there is one, else perfect linear
            axes.
        measurements : list of str, optional
            Ids of the probe_sphere and r_test tests to use (default all).
        prior_u : float, optional
            Standard deviation of a zero-mean prior on each determined error [um, urad].

        Returns
        -------
        Located
            ``.result`` (estimate, u, identifiability), ``.to_json()``, ``.to_text()``.
        """
        from volcal.steps.locate import locate

        if model is None and self.result is not None:
            model = self.result
        return locate(self.session, model=model, measurements=measurements, prior_u=prior_u)

    @A.checked
    def load_model(self, path: str | Path, force: bool = False) -> IdentificationResult:
        """Use a model file identified earlier from this session.

        Parameters
        ----------
        path : str or Path
            ``MODEL.json``.
        force : bool
            Accept a model of another session (name, chain, travel or readings differ).

        Returns
        -------
        IdentificationResult
        """
        from volcal.identify.modelfile import check_model_session, load_model

        model = load_model(path)
        check_model_session(model, self.session, force, path)
        self.result = model
        return model

    @A.checked
    def evaluate(self, edition: str = D.EDITION, *,
                 budget: str | Path | Budget | None = None) -> SessionEvaluation:
        """Evaluate to ISO 230-2, ISO 230-6 and the volumetric indices (with the model).

        Parameters
        ----------
        edition : str
            ISO 230-2 edition (``'2014'``, ``'2006'``, ``'1997'``, ``'1988'``).
        budget : str, Path or Budget, optional
            Uncertainty budget (as ``volcal evaluate session --budget``): every linear
            test's readings are evaluated (the same values as without it) with the
            expanded uncertainty U of every ISO 230-2 parameter and target
            (:func:`volcal.standards.iso230_2_uncertainty.evaluate_with_budget`), kept
            in :attr:`uncertainties`.

        Returns
        -------
        SessionEvaluation
            Also kept as :attr:`evaluation`; ``to_rows(table)`` / ``to_dataframe(table)``.
        """
        from volcal.standards.iso230_2 import EDITIONS
        from volcal.steps.evaluate import evaluate

        if str(edition) not in EDITIONS:
            raise VolcalInputError(f"Calibration.evaluate: edition {edition!r}: expected one "
                                   f"of {A.names(list(EDITIONS))}")
        b = None if budget is None else A.budget_file(budget, "Calibration.evaluate")[0]
        ev = evaluate(self.session, model=self.result, edition=str(edition),
                      budget=b).evaluation
        self.uncertainties = None if b is None else dict(ev.uncertainties)
        self.evaluation = ev
        return self.evaluation

    @A.checked
    def verdict(self, tolerance_um: float | str | Mapping[str, float],
                compensation: str | Path | None = None, edition: str = D.EDITION,
                force: bool = False, *, decision_rule: str = D.DECISION_RULE,
                guard_band_um: float | None = None,
                budget: str | Path | Budget | None = None) -> list[Verdict]:
        """Pass/fail against a tolerance, before and after compensation.

        Like ``volcal evaluate session --tolerance-um ... [--model] [--compensation]``:
        the model is this calibration's (:meth:`identify` or :meth:`load_model`).

        Parameters
        ----------
        tolerance_um : float, str or dict
            A number (largest volumetric error of the model), ``{'X': 10, 'Y': 10,
            'Z': 8}`` or ``'X=10,Y=10,Z=8'`` (ISO 230-2 accuracy A per axis), or both
            (``V`` key) [um].
        compensation : str or Path, optional
            Folder written by :meth:`compensate` from this model: the verdict after.
        edition : str
            ISO 230-2 edition.
        force : bool
            Use tables whose manifest names another machine (as ``--force``).
        decision_rule : str
            ``'simple'`` (pass when the value is at most the tolerance) or ``'guarded'``
            (pass at or below T - w, conditional up to T, fail above; ILAC-G8:09/2019,
            ISO 14253-1), as ``--decision-rule``.
        guard_band_um : float, optional
            Guard band w of the guarded rule [um] (default: U of each parameter, from
            ``budget``); as ``--guard-band-um``.
        budget : str, Path or Budget, optional
            Uncertainty budget (as ``--budget``): U (never a changed value)
            of the toleranced ISO 230-2 parameters, the guard band of the guarded rule.

        Returns
        -------
        list of Verdict
            ``quantity``, ``tolerance_um``, ``before_um``, ``before``, ``after_um``,
            ``after`` (``'pass'``, ``'FAIL'``, ``'conditional'`` or ``'-'``), ``rule``,
            ``U_before_um``, ``U_after_um``; ``to_dict()`` is an entry of ``volcal
            evaluate session --json``'s ``verdict``.
        """
        from volcal.standards.tolerance import parse_tolerance
        from volcal.steps.evaluate import evaluate

        where = "Calibration.verdict"
        tol = A.acceptance(where, parse_tolerance(A.tolerance_text(tolerance_um)),
                           decision_rule, guard_band_um, budget)
        assert tol is not None
        if compensation is not None and self.result is None:
            raise VolcalInputError("Calibration.verdict: compensation= needs the model "
                                   "the tables were written from: identify() or "
                                   "load_model() first")
        with A.python_names(where):
            done = evaluate(self.session, model=self.result, edition=str(edition),
                            budget=tol.budget, tolerance=tol, compensation=compensation,
                            force=force, model_label="this calibration's model")
        import warnings as _w

        for w in done.warnings:
            _w.warn(A.python_text(w), UserWarning, stacklevel=3)
        assert done.verdicts is not None
        return list(done.verdicts)

    @A.checked
    def compensate(self, folder: str | Path, format: str, sign: str | None = D.COMP_SIGN,
                   spacing: float = D.COMP_SPACING_MM, max_points: int | None = None,
                   reference_mm: ArrayLike | str | None = None,
                   unit_um: float = D.COMP_UNIT_UM, magnification: int = D.COMP_MAGNIFICATION,
                   max_increment: int = D.COMP_MAX_INCREMENT,
                   fanuc_series: str = D.COMP_FANUC_SERIES,
                   linuxcnc_type: int = D.COMP_LINUXCNC_TYPE,
                   squareness: bool = D.COMP_SQUARENESS,
                   tool_offset: ArrayLike | str = D.TOOL_OFFSET_MM, *,
                   replace: bool = False,
                   session: str | Path | Session | None = None,
                   rotary_spacing: float = D.COMP_ROTARY_SPACING_DEG) -> list[str]:
        """Write controller compensation tables of the identified model.

        Calls :func:`volcal.steps.compensate.compensate` with this calibration's model and
        its session's machine identity (``volcal compensate --session`` checks are the
        command's). A session with nothing to identify (rotary tests only) has no linear
        model: its rotary tables alone are written, as ``volcal compensate --session S``
        without a model.

        Like ``volcal compensate``: the format is always named, and the tables are
        written in the controller's own sign unless ``sign`` overrides it (with a
        warning: a table in the wrong sign doubles the machine's error).

        Parameters
        ----------
        folder : str or Path
            Output folder.
        format : str
            ``'fanuc'``, ``'siemens'``, ``'heidenhain'``, ``'linuxcnc'``, ``'csv'``,
            ``'isg'``, ``'grid'``.
        sign : str, optional
            Override: ``'error'`` (actual - commanded) or ``'correction'`` (= -error).
            Default: the controller's convention (Fanuc, LinuxCNC: correction).
        spacing : float
            Distance between compensation points [mm].
        max_points : int, optional
            Controller's point limit.
        reference_mm : array_like, shape (3,), or str, optional
            Fanuc reference position [mm] (default: start of travel).
        unit_um : float
            Fanuc detection unit [um].
        magnification : int
            Fanuc magnification (3623).
        max_increment : int
            Fanuc largest value per point.
        fanuc_series : str
            ``'30i'`` or ``'16i'``.
        linuxcnc_type : int
            LinuxCNC ``COMP_FILE_TYPE``, 1 (trims) or 0.
        squareness : bool
            Siemens CEC: add squareness terms.
        tool_offset : array_like, shape (3,), or str
            3-D grid: target on the tool [mm].
        replace : bool
            The folder holds files volcal did not write there: move them into its
            ``backup/<UTC time>/`` instead of refusing, as ``--replace``.
        session : str, Path or Session, optional
            As ``volcal compensate --session``: the session (this calibration's
            :attr:`session`, or a folder) whose bidirectional ISO 230-2 linear tests give
            forward and reverse tables (LinuxCNC, Fanuc, Heidenhain ``BACKLASH``), the
            model checked against it; None (default): one table per axis, as the
            command without ``--session``. The line checks before and after are in
            :attr:`compensated`.
        rotary_spacing : float
            Distance between the points of the rotary tests' Siemens and Fanuc tables
            [deg] (a divisor of 360 on a full-circle axis), as ``--rotary-spacing``.

        Returns
        -------
        list of str
            Files written.
        """
        from volcal.errors import spell
        from volcal.session.identity import MachineIdentity
        from volcal.steps.compensate import compensate

        # a session with nothing to identify (rotary tests only): its rotary tables alone
        rotary_only = self.result is None and not self._identifiable()
        result = None if rotary_only else self._need_result()
        # the manifest names this session's machine (serial, make...), so that the tables
        # are refused on another machine (docs/compensation.md)
        r = compensate(result, format=format, output=folder, sign=sign, spacing=spacing,
                       max_points=max_points, reference_mm=None if reference_mm is None
                       else A.vector_mm(reference_mm, "reference_mm"), unit_um=unit_um,
                       magnification=magnification, max_increment=max_increment,
                       fanuc_series=fanuc_series, linuxcnc_type=linuxcnc_type,
                       squareness=squareness, rotary_spacing=rotary_spacing,
                       tool_offset=A.vector_mm(tool_offset, "tool_offset"),
                       machine=MachineIdentity.of(self.session), replace=replace,
                       session=session if session is not None
                       else self.session if rotary_only else None)
        if r.sign_note is not None:
            warnings.warn(spell(r.sign_note, {}), UserWarning, stacklevel=3)
        if r.rotary_only:  # as the command line's note
            warnings.warn("Calibration.compensate: no linear model (the session has rotary "
                          "tests only): only the rotary tables were written", UserWarning,
                          stacklevel=3)
        files = list(r.files)
        self.compensation = Path(folder)
        self.compensated = r
        return files

    @A.checked
    def report(self, folder: str | Path, title: str | None = None, edition: str = D.EDITION,
               tolerance_um: float | str | Mapping[str, float] | None = None,
               compensation: str | Path | None = None, history: str | None = None, *,
               force: bool = False,
               certificate: bool = False, as_left: str | Path | Calibration | None = None,
               tables: str | Path | None = None, strict: bool = False,
               decision_rule: str = D.DECISION_RULE, guard_band_um: float | None = None,
               budget: str | Path | Budget | None = None,
               replace: bool = False, angle_units: str = "urad",
               rotary_tolerance_urad: str | Mapping[str, float] | None = None,
               location_tolerance_um: float | None = None
               ) -> ReportFiles:
        """Write the HTML and PDF report (and the certificate), like ``volcal report``.

        Parameters
        ----------
        folder : str or Path
            Report folder.
        title : str, optional
            Report title.
        edition : str
            ISO 230-2 edition.
        tolerance_um : float, str or dict, optional
            Tolerance for a pass/fail verdict before and after compensation [um]: a
            number (largest volumetric error), ``{'X': 10, 'Y': 10, 'Z': 8}`` or
            ``'X=10,Y=10,Z=8'`` (ISO 230-2 accuracy A per axis), or both (``V`` key);
            the certificate also judges ``X.straightness_um`` [um] and
            ``EC0Y.squareness_urad`` [urad] limits of the direct optics.
        compensation : str or Path, optional
            Folder written by :meth:`compensate` (or ``volcal compensate``) from the same
            model, summarised in the report; none by default, as on the command line.
        history : str, optional
            Calibration history (URL or SQLite file, as ``volcal history --db``): adds
            the section "Previous calibration" (the machine's previous stored calibration
            and the change test against this one, ``docs/history.md``), as
            ``volcal report --history``.
        force : bool
            Use ``compensation`` tables written for another machine (a warning instead of
            an error), as ``--force``.
        certificate : bool
            Also write the calibration certificate (``certificate.pdf``, ``.html``,
            ``.json``, kept in :attr:`certificate`); automatic when session.toml has
            ``[calibration]`` keys or ``[[equipment]]``, or with ``as_left``.
        as_left : str, Path or Calibration, optional
            Session measured after the compensation tables were loaded (its folder or its
            Calibration): the certificate pairs its results with this session's
            (as-found). It must be the same machine.
        tables : str or Path, optional
            Compensation folder loaded between this session and ``as_left``, named on the
            certificate by its manifest (not applied).
        strict : bool
            Refuse to issue a certificate with equipment whose calibration was due before
            the date of measurement.
        decision_rule : str
            ``'simple'`` or ``'guarded'``, of the tolerance verdict and the certificate's
            statement of conformity (see :meth:`verdict`).
        guard_band_um : float, optional
            Guard band w of the guarded rule [um].
        budget : str, Path or Budget, optional
            Uncertainty budget: U of the toleranced ISO 230-2 parameters, and of every
            linear test and every direct optic's result on the certificate. With a
            certificate, the model must carry the budget's systematic part
            (:func:`volcal.report.certificate_inputs.certificate_model`).
        replace : bool
            The folder holds files volcal did not write there: move them into its
            ``backup/<UTC time>/`` instead of refusing, as ``--replace``.
        angle_units : str
            ``'urad'`` or ``'arcsec'``: the rotary axes' angles, as ``--angle-units``.
        rotary_tolerance_urad : str or dict, optional
            Tolerance of the accuracy A per rotary axis [urad], ``'C=25'`` or ``{'C': 25}``:
            the rotary verdict, as ``--rotary-tolerance-urad``.
        location_tolerance_um : float, optional
            With probe_sphere tests: tolerance of the largest range of the sphere
            centre's deviation per path [um], judged by ``decision_rule``, as
            ``--location-tolerance-um``.

        Returns
        -------
        ReportFiles
            ``.html``, ``.pdf``, ``.figures``, ``.pdf_pages``.

        Warns
        -----
        UserWarning
            Equipment overdue for calibration (without ``strict``), compensation tables
            of another machine used with ``force``.
        """
        from volcal.standards.tolerance import parse_tolerance
        from volcal.steps.report import check_report_inputs
        from volcal.steps.report import report as report_step

        where = "Calibration.report"
        tol = None if tolerance_um is None else parse_tolerance(A.tolerance_text(tolerance_um))
        from volcal.identify.location_evaluation import location_tolerance

        if tol is None and location_tolerance_um is not None:  # the rule judges it alone
            from volcal.standards.decision import check_acceptance

            with A.python_names(where):
                check_acceptance(decision_rule, guard_band_um)
        else:
            tol = A.acceptance(where, tol, decision_rule, guard_band_um, budget)
        loc_tol = location_tolerance(location_tolerance_um, decision_rule, guard_band_um)
        if compensation is not None and not Path(compensation).is_dir():
            raise VolcalInputError(f"{where}: compensation= is not a folder written by "
                                   "compensate", compensation)
        s2 = None
        if isinstance(as_left, Calibration):
            s2 = as_left.session
        elif as_left is not None:  # measured, as --as-left (a planned session is refused)
            from volcal.session.format import read_session

            s2 = read_session(as_left)
        b, b_name = (None, None) if budget is None else A.budget_file(budget, where)
        bud = tol.budget if tol is not None and getattr(tol, "budget", None) is not None \
            else b
        from volcal.report.rotary import parse_rotary_tolerance
        from volcal.standards.iso230_2_rotary import check_units

        check_units(angle_units)
        rot_tol = (parse_rotary_tolerance(rotary_tolerance_urad)
                   if isinstance(rotary_tolerance_urad, str | type(None))
                   else {str(k).upper(): float(v) for k, v in rotary_tolerance_urad.items()})
        with A.python_names(where):  # the command line's checks, the keywords named
            from volcal.report.certificate_inputs import certificate_wanted

            certificate_wanted(self.session, s2, tables, certificate, strict)
            # as `volcal report`: only a new, empty or earlier report folder is replaced
            check_report_inputs(folder, history=history, replace=replace,
                                option="replace=True")
            done = report_step(self.session, output=folder,
                               model=(None if self.result is None and not self._identifiable()
                                      else self._need_result()),
                               truth=self.truth, title=title, edition=str(edition),
                               tolerance=tol, compensation=compensation, history=history,
                               force=force, certificate=certificate, as_left=s2,
                               tables=tables, strict=strict, budget=bud, budget_file=b_name,
                               identify_hint=f"Calibration.identify(budget={b_name!r})",
                               angle_units=angle_units, rotary_tolerance_urad=rot_tol,
                               location_tolerance=loc_tol)
        for w in done.warnings:
            warnings.warn(A.python_text(w), UserWarning, stacklevel=3)
        self.certificate = done.certificate
        return done.files

    # ------------------------------------------------------------------ helpers
    def _planned(self) -> Session:
        """The session with every measurement, those without readings yet included."""
        from copy import copy

        s = self.session
        if not s.unmeasured:
            return s
        if s.path is not None:  # the planned order of the folder
            from volcal.session.format import read_session

            return read_session(s.path, require_deviation=False)
        out = copy(s)
        out.measurements = [*s.measurements, *s.unmeasured]
        out.unmeasured = []
        return out

    def _identifiable(self) -> bool:
        """The session has a test identify reads (not only rotary tests, say)."""
        from volcal.session.kinds import kind_of

        return any(kind_of(m.kind).in_design for m in self.session.measurements)

    def _need_result(self) -> IdentificationResult:
        if self.result is None:
            self.identify()
        assert self.result is not None
        return self.result
