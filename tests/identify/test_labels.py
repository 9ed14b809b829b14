"""Every plain-word label of the identifiability report, and ``--roll zero``, against the
ISO 230-1 table (``volcal.model.names``): the roll of an axis is its rotation about its own
direction (EAX, EBY, ECZ), never the first-two-letter reading (EAY, EAZ)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from identify_helpers import TRAVEL, assert_labels_match_table, exact_fill, seeds_session

from volcal.identify import IdentifyOptions, advise, identify
from volcal.identify.identifiability import IdentifiabilityReport, _messages
from volcal.measure.virtual import random_machine
from volcal.model.names import COMPONENT_NAMES, ERROR_TABLE, ROLL_NAMES, TILT_NAMES, info


def test_report_messages_label_every_function_as_the_table_does():
    """A report where all 21 functions are undetermined: each is named once with its
    table meaning, the roll explanation goes to EAX, EBY, ECZ only, the tilt explanation
    to the six tilts, and the "Roll:" line lists exactly the three rolls."""
    frac = dict.fromkeys(ERROR_TABLE, 0.1)
    rep = IdentifiabilityReport(10, 5, 5, frac, 1.0, 0.5)
    _messages(rep, SimpleNamespace(measurements=[]))
    text = "\n".join(rep.messages)
    assert assert_labels_match_table(text) == 21
    for n in ERROR_TABLE:
        msg = next(m for m in rep.messages if m.startswith(f"{n} ("))
        assert ("Roll acts only through lever arms" in msg) == (n in ROLL_NAMES), n
        assert ("This rotation has (almost) no lever arm" in msg) == (n in TILT_NAMES), n
    roll_line = next(m for m in rep.messages if m.startswith("Roll: "))
    assert roll_line.startswith("Roll: EAX, EBY, ECZ not measured")
    # the old first-two-letter reading is gone
    for wrong in ("EXY (positioning", "EAY (roll", "EAZ (roll", "ECZ (yaw", "EYY (straight"):
        assert wrong not in text


def test_advise_on_the_seeds_plan_uses_the_table_labels():
    rep = advise(seeds_session("XYFZ"))
    assert assert_labels_match_table(" ".join(rep.messages)) >= 3
    assert "EAX (roll of X) is not determined" in " ".join(rep.messages)


def test_roll_zero_holds_exactly_the_three_rolls():
    """``roll='zero'`` fixes EAX, EBY, ECZ (values and uncertainty identically zero);
    the tilts EAY, EAZ, ... stay free and are estimated (the truth has them)."""
    s = seeds_session("XYFZ", steps=5)
    truth = random_machine(TRAVEL, "XYFZ", seed=3)
    exact_fill(s, truth, seed=1)
    r = identify(s, IdentifyOptions(roll="zero", suggest=False))
    for j, name in enumerate(COMPONENT_NAMES):
        if info(name).unit != "urad":
            continue
        k, c = divmod(j, 6)
        v, u = r.errors.values[k][:, c], r.std[k][:, c]
        if name in ROLL_NAMES:
            assert np.all(v == 0) and np.all(u == 0), name
        else:
            # a free tilt: estimated with an uncertainty, and it follows the truth
            t = truth.function(name, r.errors.nodes[k])
            assert u[1:].min() > 0, name
            assert np.abs(v).max() > 0.3 * np.abs(t).max() > 0, name
    assert "EAX, EBY, ECZ" in " ".join(r.report.messages)
