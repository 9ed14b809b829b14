"""``volcal compensate --session``: forward and reverse tables from the ISO 230-2 runs."""

import json
import sys

import numpy as np

from volcal.cli import main


def _run(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, out.err


def test_linuxcnc_reversal_equals_the_iso230_2_means(tmp_path, monkeypatch, capsys):
    s, model = tmp_path / "s", tmp_path / "model.json"
    assert _run(monkeypatch, capsys, "plan", "-o", str(s), "--steps", "4")[0] == 0
    assert _run(monkeypatch, capsys, "simulate", str(s))[0] == 0
    code, out, err = _run(monkeypatch, capsys, "identify", str(s), "-o", str(model))
    assert code == 0, err
    code, out, _ = _run(monkeypatch, capsys, "evaluate", "session", str(s), "--json")
    first = {}
    for v in json.loads(out)["measurements"].values():
        first.setdefault(v["axis"], v["targets"])
    code, out, err = _run(monkeypatch, capsys, "compensate", str(model), "--format",
                          "linuxcnc", "--session", str(s), "--spacing", "25", "-o",
                          str(tmp_path / "c"))
    assert code == 0, err
    for ax, rows in first.items():
        t = np.loadtxt(tmp_path / "c" / f"{ax}.comp")
        x = np.array([r["target_mm"] for r in rows])
        r = np.array([r["mean_down"] for r in rows]) - np.array([r["mean_up"] for r in rows])
        assert np.max(np.abs(r)) > 0.1  # the simulated machine has a reversal
        o = np.argsort(x)
        # trims are corrections: reverse trim - forward trim = -(reverse - forward error)
        np.testing.assert_allclose(1000 * (t[:, 2] - t[:, 1]),
                                   -np.interp(t[:, 0], x[o], r[o]), atol=0.002)
