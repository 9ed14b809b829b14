"""The calibration flow as a small library object.

:class:`Calibration` chains plan -> simulate (or measure) -> identify -> evaluate ->
compensate -> report on one session, each step one method, so that the whole flow is a
few lines of Python (``docs/python.md``). The command line and the demo call the same
functions. Heavy modules (the estimator, matplotlib) are imported only by the steps
that need them.

Examples
--------
>>> from volcal import Calibration                              # doctest: +SKIP
>>> cal = Calibration.plan([[0, 800], [0, 600], [0, 500]], chain="XYFZ")  # doctest: +SKIP
>>> cal.simulate(seed=3).save("S")                              # doctest: +SKIP
>>> cal.identify().to_json("model.json")                        # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from numpy.typing import ArrayLike

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
        Set by :meth:`identify`.
    evaluation : SessionEvaluation or None
        Set by :meth:`evaluate`.
    compensation : Path or None
        Folder written by :meth:`compensate`.
    """

    def __init__(self, session: Any, truth: Any = None) -> None:
        self.session = session
        self.truth = truth
        self.result: Any = None
        self.evaluation: Any = None
        self.compensation: Path | None = None
        self._setups: Any = None
        self._sim: Any = None

    def __repr__(self) -> str:
        """Short description."""
        s = self.session
        n = sum(m.deviation is not None for m in s.measurements)
        return (f"Calibration({s.name!r}, chain={s.chain!r}, {len(s.measurements)} "
                f"measurements, {n} with readings, identified={self.result is not None})")

    # ------------------------------------------------------------------ build
    @classmethod
    def plan(cls, travel: ArrayLike, chain: str = "XYFZ", steps: int = 10,
             tests: Sequence[str] = ("step-diagonal", "diagonal", "linear"), runs: int = 5,
             name: str = "VMC-1", **options: Any) -> Calibration:
        """Plan the tests of a machine (no readings yet).

        Parameters
        ----------
        travel : array_like, shape (3, 2)
            Travel limits [mm].
        chain : str
            Kinematic chain code (``'XYFZ'``...).
        steps : int
            Increments per test.
        tests : sequence of str
            ``'step-diagonal'``, ``'diagonal'``, ``'linear'``, ``'face-diagonal'``...
        runs : int
            Bidirectional runs per linear test (ISO 230-2).
        name : str
            Machine name.
        **options
            Other keywords of :func:`volcal.plan.planner.plan_session`.

        Returns
        -------
        Calibration
        """
        from volcal.plan.planner import plan_session

        return cls(plan_session(travel, chain, steps, tuple(tests), runs, name=name,
                                **options))

    @classmethod
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

        s = read_session(folder)
        return cls(s, read_truth(s))

    # ------------------------------------------------------------------ steps
    def simulate(self, machine: Any = None, seed: int = 0, noise_um: float = 0.5,
                 mirror_misalignment_urad: float = 20.0) -> Calibration:
        """Fill the readings from a virtual machine (in memory; :meth:`save` writes them).

        Parameters
        ----------
        machine : MachineErrors, optional
            The virtual machine; a random realistic one (seeded) when omitted.
        seed : int
            Seed of the random machine and of the noise.
        noise_um : float
            Reading noise, standard deviation [um].
        mirror_misalignment_urad : float
            Set-up misalignment of the optics, standard deviation [urad].

        Returns
        -------
        Calibration
            ``self``, for chaining.
        """
        from volcal.measure.simulate import SimulationOptions, simulate_session
        from volcal.measure.virtual import random_machine

        s = self.session
        if machine is None:
            machine = random_machine(s.travel, s.chain, seed, name=f"virtual {s.name}")
        self._sim = SimulationOptions(noise_um=noise_um,
                                      mirror_misalignment_urad=mirror_misalignment_urad,
                                      seed=seed)
        self._setups = simulate_session(s, machine, self._sim)
        self.truth = machine
        self.result = self.evaluation = None
        return self

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
        """
        from volcal.session.format import read_session, write_session

        extra = None
        if self._setups is not None:
            from volcal.measure.simulate import truth_files

            extra = truth_files(self.truth, self._setups, self._sim)
        path = write_session(self.session, folder, extra)
        has = any(m.deviation is not None for m in self.session.measurements)
        self.session = read_session(path, require_deviation=has)
        return self

    def identify(self, **options: Any) -> Any:
        """Identify the 21 errors with uncertainties.

        Parameters
        ----------
        **options
            Fields of :class:`volcal.identify.IdentifyOptions` (``prior``, ``noise_um``
            [um], ``roll``, ``known``...).

        Returns
        -------
        IdentificationResult
            Also kept as :attr:`result`; it carries the session's identity.
        """
        from volcal.identify import IdentifyOptions, identify

        self.result = identify(self.session, IdentifyOptions(**options))
        self.evaluation = None
        return self.result

    def load_model(self, path: str | Path, force: bool = False) -> Any:
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

    def evaluate(self, edition: str = "2014") -> Any:
        """Evaluate to ISO 230-2, ISO 230-6 and the volumetric indices (with the model).

        Parameters
        ----------
        edition : str
            ISO 230-2 edition.

        Returns
        -------
        SessionEvaluation
            Also kept as :attr:`evaluation`.
        """
        from volcal.standards.session import evaluate_session

        self.evaluation = evaluate_session(self.session, self.result, edition)
        return self.evaluation

    def compensate(self, folder: str | Path, format: str = "grid", sign: str = "error",
                   spacing: float = 50.0, **options: Any) -> list[str]:
        """Write controller compensation tables of the identified model.

        Parameters
        ----------
        folder : str or Path
            Output folder.
        format : str
            ``'fanuc'``, ``'siemens'``, ``'heidenhain'``, ``'csv'``, ``'isg'``, ``'grid'``.
        sign : str
            ``'error'`` (actual - commanded) or ``'correction'`` (= -error).
        spacing : float
            Distance between compensation points [mm].
        **options
            Other fields of :class:`volcal.compensate.formats.CompensationOptions`.

        Returns
        -------
        list of str
            Files written.
        """
        from volcal.compensate.formats import CompensationOptions, write_compensation

        result = self._need_result()
        files = write_compensation(result.errors, format.lower(), folder,
                                   CompensationOptions(sign, spacing=spacing, **options),
                                   "model")
        self.compensation = Path(folder)
        return files

    def report(self, folder: str | Path, title: str | None = None, edition: str = "2014"
               ) -> Any:
        """Write the HTML and PDF report.

        Parameters
        ----------
        folder : str or Path
            Report folder.
        title : str, optional
            Report title.
        edition : str
            ISO 230-2 edition.

        Returns
        -------
        ReportFiles
        """
        from volcal.report.pipeline import collect_inputs
        from volcal.report.sections import build_report
        from volcal.report.writer import write_report

        inputs = collect_inputs(self.session, self._need_result(), self.truth, edition,
                                self.compensation)
        return write_report(build_report(inputs, title), folder)

    def _need_result(self) -> Any:
        if self.result is None:
            self.identify()
        return self.result
