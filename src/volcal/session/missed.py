"""A missed capture in a measurement file: its marker and the refusal of a missed first row.

``volcal capture`` writes ``missed`` where it took no reading (``docs/capture.md``); the
session readers of the linear kinds (:mod:`volcal.session.format`) and of the rotary test
(:mod:`volcal.session.rotary`) read it, and refuse it in the first row, the reference of
the others.
"""

from __future__ import annotations

__all__ = ["FIRST_ROW_MISSED", "MISSED"]

MISSED = "missed"
"""The deviation cell (or ``status``) of a reading the capture missed."""

FIRST_ROW_MISSED = ("the first row is the reference of the readings (deviation 0 by "
                    "definition): it cannot be a missed capture; capture the measurement "
                    "again (volcal capture SESSION --measurement ID --again, docs/capture.md)")
"""The session readers' refusal of a file whose first reading was missed."""
