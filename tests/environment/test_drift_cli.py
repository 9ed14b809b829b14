from volcal_cli_helpers import volcal_process


def _volcal(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args)


def test_drift_cli_reports_span_and_rate(tmp_path):
    # start point revisited every 30 min with +0.4 um each time: 0.8 um/h, span 1.2 um
    rows = ["x_mm,y_mm,z_mm,deviation_um,time_s"]
    for k in range(4):
        rows.append(f"0,0,0,{0.4 * k:.1f},{1800 * k}")
        rows.append(f"400,0,0,3.0,{1800 * k + 60}")
    f = tmp_path / "m.csv"
    f.write_text("\n".join(rows) + "\n")
    ok = _volcal("env", "drift", str(f), "--limit-um", "1.5")
    assert ok.returncode == 0, ok.stderr
    assert "4 readings at the start point: span 1.200 um" in ok.stdout
    assert "rate 0.800 um/h" in ok.stdout and "OK" in ok.stdout
    bad = _volcal("env", "drift", str(f), "--limit-um", "1.0")
    assert bad.returncode == 1 and "EXCEEDED" in bad.stdout
