"""`volcal simulate --budget`: the drawn systematic errors are in the readings and in
truth/systematic.toml, as documented (scale errors of the length readings)."""

import sys
import tomllib

import numpy as np
import pytest

from volcal.cli import main
from volcal.session.format import read_session
from volcal.uncertainty.budget import TEMPLATE


def run(monkeypatch, capsys, *args):
    monkeypatch.setattr(sys, "argv", ["volcal", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = exc.code or 0
    out = capsys.readouterr()
    return code, out.out, out.err


def test_drawn_errors_are_applied_and_recorded(tmp_path, monkeypatch, capsys):
    b = tmp_path / "b.toml"
    b.write_text(TEMPLATE.replace("temperature_c = 20.0\n# Typical material",
                                  "temperature_c = 23.0\n# Typical material"), "utf-8")
    for name in ("a", "b"):
        assert run(monkeypatch, capsys, "plan", "-o", str(tmp_path / name), "--steps",
                   "4")[0] == 0
    assert run(monkeypatch, capsys, "simulate", str(tmp_path / "a"), "--seed", "4")[0] == 0
    code, out, err = run(monkeypatch, capsys, "simulate", str(tmp_path / "b"), "--seed", "4",
                         "--budget", str(b))
    assert code == 0, err
    assert "systematic errors drawn" in out
    t = tomllib.loads((tmp_path / "b" / "truth" / "systematic.toml").read_text("utf-8"))
    sa, sb = read_session(tmp_path / "a"), read_session(tmp_path / "b")
    for ma, mb in zip(sa.measurements, sb.measurements, strict=True):
        d = ma.positions - ma.positions[0]
        n = ma.beam_direction
        eps = (t["wavelength_ppm"] + t["air_ppm"][ma.id]) * 1e-6
        want = eps * (d @ n) * 1e3 + sum(t["material_ppm"][a] * 1e-6 * d[:, k] * n[k] * 1e3
                                         for k, a in enumerate("XYZ"))
        assert mb.deviation - ma.deviation == pytest.approx(want, abs=1e-3)
    # material at 23 C with u(t) 0.06 K and u(alpha) 0.58 ppm/K: a few ppm at most
    assert all(abs(v) < 10 for v in t["material_ppm"].values())
    assert np.any(np.abs(list(t["material_ppm"].values())) > 0.01)
