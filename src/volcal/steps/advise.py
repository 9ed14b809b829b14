"""Step ``advise``: before measuring, what the planned tests will determine."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from volcal import defaults as D

if TYPE_CHECKING:
    from volcal.identify.identifiability import IdentifiabilityReport
    from volcal.session.format import Session

__all__ = ["Advice", "advise"]


@dataclass(frozen=True)
class Advice:
    """What :func:`advise` found.

    Attributes
    ----------
    report : IdentifiabilityReport
        ``.messages`` in plain words, ``.suggestions``, ``.ambiguity_um`` [um].
    """

    report: IdentifiabilityReport

    @property
    def messages(self) -> list[str]:
        """The report's messages, in plain words."""
        return list(self.report.messages)


def advise(session: Session | str | Path, *, roll: str = D.ROLL, **options: Any) -> Advice:
    """What the planned tests will and will not determine (the readings are not used).

    Parameters
    ----------
    session : Session, str or Path
        A planned (or measured) session, or its folder; every measurement counts, those
        without readings included.
    roll : str
        ``'estimate'`` or ``'zero'`` (the rolls EAX, EBY, ECZ fixed to zero).
    **options
        Other fields of :class:`volcal.identify.IdentifyOptions` (``known`` as a dict
        or a path, with ``known_u``...), checked as by :func:`volcal.steps.identify.identify`.

    Returns
    -------
    Advice
    """
    from volcal.identify import advise as run
    from volcal.steps.identify import _read_known, identify_options

    opts, known_file = identify_options(("known_u",), roll=roll, **options)
    if isinstance(session, str | Path):
        from volcal.session.format import read_session

        session = read_session(session, require_deviation=False)
    if known_file is not None:
        opts = _read_known(opts, known_file, options.get("known_u"))
    return Advice(run(session, opts))
