"""Pass/fail verdict of a tolerance: moved to :mod:`volcal.standards.verdict`.

The verdict is computed in ``standards`` from the session's one evaluation
(:func:`volcal.standards.session.evaluate_session`); the report only formats it. The
names stay importable from here.
"""

from __future__ import annotations

from volcal.standards.tolerance import Verdict
from volcal.standards.verdict import compensated_deviation, verdicts, work_zone_grid

__all__ = ["Verdict", "compensated_deviation", "verdicts", "work_zone_grid"]
