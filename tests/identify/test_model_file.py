"""Model file ``volcal-model/3``: a small JSON and a binary ``.npz`` bound by its sha256.

Checked with independent readers: ``hashlib`` for the digest, plain ``numpy.load`` and
``zipfile`` for the sidecar, ``json`` for the document, and the sparse Jacobian of
:func:`volcal.model.kinematics.pose_jacobian` for the numpy-only prediction.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from timing import scaled_timeout
from volcal.errors import VolcalInputError
from volcal.identify import load_model
from volcal.identify.modelfile import ModelFileWarning, binary_path, write_model
from volcal.model.kinematics import pose_jacobian
from volcal.model.names import AXES, COMPONENTS
from volcal_cli_helpers import volcal_process

DATA = Path(__file__).parent / "data"
UNITS = ("um", "um", "um", "urad", "urad", "urad")


def volcal(*args):
    """``volcal *args`` in-process (VOLCAL_TEST_SUBPROCESS=1: in a process of its own)."""
    return volcal_process(*args, timeout=scaled_timeout(180))


@pytest.fixture(scope="module")
def v2():
    """The stored format-2 model (written by the format-2 writer, before format 3)."""
    return load_model(DATA / "model_v2.json")


@pytest.fixture()
def v3(v2, tmp_path):
    """That model written as format 3."""
    return write_model(v2, tmp_path / "model.json")


def test_v2_file_still_loads_and_its_factor_gives_its_own_u_values(v2):
    doc = json.loads((DATA / "model_v2.json").read_text())
    assert v2.format == doc["format"] == "volcal-model/2"
    assert v2.session.name == "LEGACY-2" and v2.fit.n_readings == 162
    assert v2.cov_factor.shape == (69, 69) and v2.has_uncertainty
    # the factor (rows of L) and the per-node u values were written independently (both
    # rounded to 7 digits): the norm of each function's rows must give the stored u
    for ax in AXES:
        f = doc["functions"][ax]
        q = np.array(f["position_mm"])
        for c in range(6):
            name = f"{COMPONENTS[c]}{ax}"
            np.testing.assert_allclose(v2.function_std(name, q), f[f"u_{name}_{UNITS[c]}"],
                                       rtol=2e-6, atol=1e-6)
    assert set(v2.fitted) == set(doc["readings"]) and len(v2.fitted) == 17


def test_v1_file_still_loads_with_uncertainty():
    m = load_model(DATA / "model_v1.json")
    assert m.format == "volcal-model/1" and m.has_uncertainty
    e, u = m.predict([[150.0, 100.0, 50.0]])
    assert np.all(np.isfinite(e)) and np.all(u > 0)


def test_v3_layout_read_by_independent_readers(v2, v3):
    doc = json.loads(v3.read_text())
    npz = binary_path(v3)
    assert npz == v3.with_suffix(".npz") and npz.is_file()
    assert doc["format"] == "volcal-model/3"
    block = doc["arrays"]
    assert block["file"] == "model.npz"
    assert block["sha256"] == hashlib.sha256(npz.read_bytes()).hexdigest()
    assert block["bytes"] == npz.stat().st_size
    assert doc["covariance"] == {"free_index": [int(i) for i in v2.free],
                                 "parts": {"noise": "noise_factor"}}
    assert "factor" not in doc["covariance"]
    with zipfile.ZipFile(npz) as zf:  # plain uncompressed zip of .npy members
        assert {i.filename for i in zf.infolist()} == {"noise_factor.npy", "fitted_um.npy",
                                                        "residual_um.npy"}
        assert all(i.compress_type == zipfile.ZIP_STORED for i in zf.infolist())
    with np.load(npz) as z:
        assert z["noise_factor"].dtype == np.float64
        np.testing.assert_array_equal(z["noise_factor"], v2.cov_factor)
        assert block["members"]["noise_factor"] == {"shape": [69, 69], "dtype": "<f8"}
        index = doc["readings"]["measurements"]
        assert list(index) == list(v2.fitted)
        first, count = index["diag-ppp"]
        np.testing.assert_array_equal(z["fitted_um"][first:first + count],
                                      v2.fitted["diag-ppp"])
        np.testing.assert_array_equal(z["residual_um"][first:first + count],
                                      v2.residuals["diag-ppp"])
        assert z["fitted_um"].size == sum(c for _, c in index.values()) == 162
    # readable: the functions and their u in the JSON, one line per array
    assert '"EXX_um": [0.0, ' in v3.read_text()
    assert v3.stat().st_size < 20_000


def test_v3_round_trip_is_exact_and_deterministic(v2, v3, tmp_path):
    m = load_model(v3)
    assert m.format == "volcal-model/3" and m.has_uncertainty and m.uncertainty_missing is None
    q = np.random.default_rng(3).uniform([0, 0, 0], [300, 200, 100], (50, 3))
    for a, b in zip(v2.predict(q, [0, 0, 80]), m.predict(q, [0, 0, 80]), strict=True):
        np.testing.assert_array_equal(a, b)
    for mid in v2.fitted:
        np.testing.assert_array_equal(m.residuals[mid], v2.residuals[mid])
    again = write_model(m, tmp_path / "again.json")
    assert binary_path(again).read_bytes() == binary_path(v3).read_bytes()


def test_numpy_prediction_equals_the_sparse_jacobian(v2):
    q = np.random.default_rng(1).uniform([-10, 0, 0], [310, 200, 100], (400, 3))
    t = np.array([20.0, -30.0, 120.0])
    e, u = v2.predict(q, t, chunk=37)
    Je, _ = pose_jacobian(v2.errors.chain_obj.order, v2.layout.nodes, q, t)
    np.testing.assert_allclose(e, (Je @ v2.theta).reshape(-1, 3), rtol=0, atol=1e-12)
    G = np.asarray(Je[:, v2.free] @ v2.cov_factor)
    np.testing.assert_allclose(u, np.sqrt((G**2).sum(1)).reshape(-1, 3), rtol=1e-12)
    assert u.max() > 1.0  # the roll's lever arms at 120 mm: a real test of the levers


def _flip_a_bit(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 1  # in the covariance factor: still a readable .npz
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage, reason", [
    (lambda p: p.unlink(), "its binary part .*model.npz is missing"),
    (lambda p: _flip_a_bit(p), "does not match it \\(sha256"),
])
def test_missing_or_foreign_binary_part_loads_without_uncertainty(v3, damage, reason):
    damage(binary_path(v3))
    with pytest.warns(ModelFileWarning, match=reason):
        m = load_model(v3)
    assert not m.has_uncertainty and m.cov_factor is None
    assert np.all(np.isnan(m.std[0])) and np.all(np.isnan(m.squareness_std))
    assert m.fitted == {} and m.residuals == {}
    ref = json.loads(v3.read_text())["functions"]["X"]["EXX_um"]
    np.testing.assert_allclose(m.errors.values[0][:, 0], ref)  # the functions are there
    assert any("no uncertainty" in n for n in m.fit.notes)
    with pytest.raises(VolcalInputError, match="predict needs the model's uncertainty"):
        m.predict([[1.0, 2.0, 3.0]])
    with pytest.raises(VolcalInputError, match="needs the model's uncertainty"):
        m.function_std("EXX", [1.0])
    with pytest.raises(VolcalInputError, match="writing the model file needs"):
        m.to_json(v3.parent / "copy.json")


def test_a_json_that_names_no_binary_part_loads_without_uncertainty(v3):
    doc = json.loads(v3.read_text())
    del doc["arrays"]
    v3.write_text(json.dumps(doc))
    with pytest.warns(ModelFileWarning, match="names no binary part"):
        m = load_model(v3)
    assert not m.has_uncertainty
    assert "names no binary part" in m.summary()


def test_the_binary_part_is_written_first_and_both_atomically(v2, v3, monkeypatch):
    """The binary part replaces its file first (the JSON names its digest); a failure (a
    full disk, Ctrl-C) at either replacement leaves the old model whole: both files or
    neither (volcal.io.atomic.write_together)."""
    import os

    old_json, old_npz = v3.read_bytes(), binary_path(v3).read_bytes()
    v2.residuals = {k: v + 1.0 for k, v in v2.residuals.items()}  # another model
    real = os.replace
    for nth in (1, 2):  # the binary part's replacement fails, then the JSON's
        calls: list[str] = []

        def flaky(src, dst, calls=calls, nth=nth):
            calls.append(str(dst))
            if len(calls) == nth:
                raise OSError("disk full")
            real(src, dst)

        monkeypatch.setattr(os, "replace", flaky)
        with pytest.raises(OSError):
            write_model(v2, v3)
        monkeypatch.undo()
        assert Path(calls[0]).suffix == ".npz"
        assert v3.read_bytes() == old_json and binary_path(v3).read_bytes() == old_npz
    assert load_model(v3).has_uncertainty  # the old model, whole
    assert [p.name for p in v3.parent.iterdir() if p.name.startswith(".")] == []


def test_npz_is_not_a_model_name(v2, tmp_path):
    with pytest.raises(VolcalInputError, match="binary part"):
        write_model(v2, tmp_path / "model.npz")


@pytest.fixture(scope="module")
def session_and_model(tmp_path_factory):
    """A small measured session and its format-3 model (written by `volcal identify`)."""
    root = tmp_path_factory.mktemp("mf")
    r = volcal("plan", "-o", root / "S", "--travel", "0:300,0:200,0:100", "--steps", "3",
               "--runs", "2")
    assert r.returncode == 0, r.stderr
    assert volcal("simulate", root / "S").returncode == 0
    r = volcal("identify", root / "S", "-o", root / "m.json", "--max-nodes", "5")
    assert r.returncode == 0, r.stderr
    assert "m.npz" in r.stdout
    (root / "p.csv").write_text("x_mm,y_mm,z_mm\n10,20,30\n150,100,50\n")
    return root


def test_cli_without_the_binary_part(session_and_model, tmp_path):
    root = session_and_model
    d = tmp_path / "copy"
    d.mkdir()
    shutil.copy(root / "m.json", d / "m.json")  # the JSON only
    out = volcal("predict", d / "m.json", "--points", root / "p.csv", "-o", tmp_path / "e.csv")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    err = " ".join(out.stderr.split())
    assert "warning:" in err and "loaded without uncertainty" in err
    assert "volcal predict (its columns ux_um, uy_um, uz_um) needs the model's uncertainty" \
        in err and "m.npz is missing" in err
    assert not (tmp_path / "e.csv").exists()
    out = volcal("report", root / "S", "--model", d / "m.json", "-o", tmp_path / "rep")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "the report (the uncertainty bands" in " ".join(out.stderr.split())
    assert not (tmp_path / "rep").exists()
    # what needs no uncertainty still works from the functions, with the warning
    out = volcal("compensate", d / "m.json", "--format", "csv", "-o", tmp_path / "comp")
    assert out.returncode == 0, out.stderr
    assert "loaded without uncertainty" in " ".join(out.stderr.split())
    # with the binary part copied beside it, predict works again
    shutil.copy(root / "m.npz", d / "m.npz")
    out = volcal("predict", d / "m.json", "--points", root / "p.csv", "-o", tmp_path / "e.csv")
    assert out.returncode == 0, out.stderr
    rows = (tmp_path / "e.csv").read_text().splitlines()
    assert rows[0] == "x_mm,y_mm,z_mm,ex_um,ey_um,ez_um,ux_um,uy_um,uz_um" and len(rows) == 3
    m = load_model(root / "m.json")
    e, u = m.predict([[150.0, 100.0, 50.0]])
    np.testing.assert_allclose([float(v) for v in rows[2].split(",")[3:]],
                               np.concatenate([e[0], u[0]]), atol=6e-5)


def test_identify_refuses_outputs_it_cannot_write_before_working(session_and_model, tmp_path):
    root = session_and_model
    (tmp_path / "m.npz").mkdir()  # where the binary part would go
    out = volcal("identify", root / "S", "-o", tmp_path / "m.json")
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "m.npz: is a folder" in " ".join(out.stderr.split())
    assert not (tmp_path / "m.json").exists()
    out = volcal("identify", root / "S", "-o", tmp_path / "x.npz")
    assert out.returncode == 2
    assert ".npz is the name of its binary part" in " ".join(out.stderr.split())


def test_nugget_is_a_hyperparameter_of_the_file_and_enters_u_between_nodes(v2, tmp_path):
    """The short-wavelength (nugget) scale of the positioning prior is stored as
    ``fit.hyperparameters.positioning_nugget_um`` (no layout change) and adds ``2 w (1 - w)
    n^2`` to the variance of the positioning errors between their nodes (``w`` the
    interpolation weight): zero at the nodes, ``n^2 / 2`` half way; ``predict`` carries it
    into the volumetric error's component of that axis."""
    import copy

    m0 = copy.deepcopy(v2)
    m0.fit.hyperparameters["positioning_nugget_um"] = 0.8
    m = load_model(write_model(m0, tmp_path / "nugget.json"))
    assert json.loads((tmp_path / "nugget.json").read_text())["fit"]["hyperparameters"][
        "positioning_nugget_um"] == 0.8
    x = m.layout.nodes[0]
    mid = (x[1:] + x[:-1]) / 2
    base = v2.function_std("EXX", mid)
    np.testing.assert_allclose(m.function_std("EXX", mid), np.sqrt(base**2 + 0.32), rtol=1e-12)
    np.testing.assert_allclose(m.function_std("EXX", x), v2.function_std("EXX", x), rtol=1e-12)
    np.testing.assert_allclose(m.function_std("EYX", mid), v2.function_std("EYX", mid))
    q = np.random.default_rng(2).uniform([0, 0, 0], [300, 200, 100], (60, 3))
    (_, u0), (_, u1) = v2.predict(q), m.predict(q)
    extra = np.zeros_like(u0)
    for k in range(3):
        nodes = m.layout.nodes[k]
        i = np.clip(np.searchsorted(nodes, q[:, k]) - 1, 0, nodes.size - 2)
        w = (q[:, k] - nodes[i]) / (nodes[i + 1] - nodes[i])
        extra[:, k] = 2 * 0.64 * w * (1 - w)
    np.testing.assert_allclose(u1**2, u0**2 + extra, rtol=1e-10, atol=1e-12)
    assert extra.max() > 0.2  # points between nodes: a real test
    # with the rigid-body motion removed: the projector R applied to the independent
    # short-wavelength values, diag(R diag(v) R') added
    from volcal.identify.identifiability import rigid_projector

    (_, r0), (_, r1) = v2.predict(q, rigid_removed=True), m.predict(q, rigid_removed=True)
    R = rigid_projector(q)
    np.testing.assert_allclose(r1.ravel()**2, r0.ravel()**2 + R**2 @ extra.ravel(),
                               rtol=1e-10, atol=1e-12)
