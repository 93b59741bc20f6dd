"""spherefit.sphere on numpy arrays: the documents of `spherefit sphere ...`, number for number."""

import json

import numpy as np
import pytest

import spherefit
from conftest import FIXTURES, run_cli

WAVY = FIXTURES / "sphere_wavy_points.json"
QUATERNIONS = FIXTURES / "imu_ngimu_quaternions.json"


def points(path):
    doc = json.loads(path.read_text())
    return np.array(doc["points"] if isinstance(doc, dict) else doc, dtype=float)


def test_fit_equals_cli():
    p = points(WAVY)
    assert spherefit.sphere.fit(p) == run_cli("sphere", "fit", WAVY)
    opts = ["-n", "8", "--degree", "2", "--knots", "uniform", "--iterations", "12", "--solver", "gauss-newton"]
    got = spherefit.sphere.fit(p, control_points=8, degree=2, knots="uniform", iterations=12, solver="gauss-newton")
    assert got == run_cli("sphere", "fit", *opts, WAVY)


def test_fit_on_s3_with_parameters_equals_cli(tmp_path):
    q = points(QUATERNIONS)
    times = json.loads((FIXTURES / "imu_ngimu_quaternions.times.json").read_text())
    doc = tmp_path / "q.json"
    doc.write_text(json.dumps({"points": q.tolist(), "parameters": times}))
    got = spherefit.sphere.fit(q, times, control_points=60)
    assert got == run_cli("sphere", "fit", "-n", "60", doc)
    assert len(got["spline"]["control_points"][0]) == 4


@pytest.mark.parametrize("method", ["jupp-kent", "samir", "cbc", "bcc"])
def test_compared_methods_equal_cli(method):
    p = points(WAVY)
    got = spherefit.sphere.fit(p, method=method, control_points=12, iterations=40)
    assert got == run_cli("sphere", "fit", "--method", method, "-n", "12", "--iterations", "40", WAVY)
    assert got["method"] == method
    assert len(got["fitted_points"]) == len(p)
    with pytest.raises(spherefit.SpherefitError, match="knots"):
        spherefit.sphere.fit(p, method=method, knots="uniform")


def test_fit_to_tolerance_equals_cli():
    got = spherefit.sphere.fit(points(WAVY), tolerance_rad=1e-4)
    assert got == run_cli("sphere", "fit", "--tolerance-rad", "1e-4", WAVY)
    assert got["tolerance"]["tolerance_met"] and got["metrics"]["max_error_rad"] <= 1e-4


def test_fit_bad_input():
    p = points(WAVY)
    bad = p.copy()
    bad[3] *= 2
    with pytest.raises(spherefit.SpherefitError, match="^/points/3: ") as e:
        spherefit.sphere.fit(bad)
    assert e.value.pointer == "/points/3" and e.value.index is None
    bad = p.copy()
    bad[5, 1] = np.nan
    with pytest.raises(spherefit.SpherefitError, match="^/points/5/1: "):
        spherefit.sphere.fit(bad)
    with pytest.raises(spherefit.SpherefitError, match="^degree: "):
        spherefit.sphere.fit(p, degree=9)
    with pytest.raises(spherefit.SpherefitError, match="shape \\(3,\\)"):
        spherefit.sphere.fit([1.0, 0.0, 0.0])
    with pytest.raises(spherefit.SpherefitError, match="^/points/0: "):
        spherefit.sphere.fit(np.zeros((5, 0)))
    with pytest.raises(spherefit.SpherefitError, match="array of numbers"):
        spherefit.sphere.fit([["a", "b"]])
    with pytest.raises(spherefit.SpherefitError, match="^parameters: "):
        spherefit.sphere.fit(p, parameters=[0.0] * 3)
    with pytest.raises(spherefit.SpherefitError, match="^step: "):
        spherefit.sphere.fit(p, step="huge")


def test_interpolate_equals_cli():
    p = points(WAVY)[:20]
    assert spherefit.sphere.interpolate(p) == run_cli("sphere", "interpolate", stdin=json.dumps(p.tolist()))
    got = spherefit.sphere.interpolate(p, beta1=2.0, beta2=[1.0] * 20)
    want = run_cli("sphere", "interpolate", "--beta1", "2", "--beta2", ",".join(["1"] * 20), stdin=json.dumps(p.tolist()))
    assert got == want


def test_interpolate_bad_input():
    p = points(WAVY)[:10]
    p[4] = p[3]
    with pytest.raises(spherefit.SpherefitError, match="^/points/4: "):
        spherefit.sphere.interpolate(p)
    with pytest.raises(spherefit.SpherefitError, match="beta1"):
        spherefit.sphere.interpolate(points(WAVY)[:10], beta1=-1)


def test_evaluate_equals_cli():
    spline = FIXTURES / "sphere_cubic_spline.json"
    doc = json.loads(spline.read_text())
    ts, pts = spherefit.sphere.evaluate(doc, samples=17)
    cli = run_cli("sphere", "evaluate", "--samples", "17", spline)
    assert ts.tolist() == cli["parameters"] and pts.tolist() == cli["points"]
    assert pts.shape == (17, 3)
    ts, pts = spherefit.sphere.evaluate(json.dumps(doc), at=[0.0, 0.25, 2.0])
    cli = run_cli("sphere", "evaluate", "--at", "0,0.25,2", spline)
    assert pts.tolist() == cli["points"]
    fitted = spherefit.sphere.fit(points(WAVY))
    interp = spherefit.sphere.interpolate(points(WAVY)[:12])
    assert spherefit.sphere.evaluate(fitted)[1].shape == (101, 3)
    _, on_curve = spherefit.sphere.evaluate(interp, at=list(range(12)))
    assert np.abs(on_curve - points(WAVY)[:12]).max() < 1e-6


def test_evaluate_bad_input():
    with pytest.raises(spherefit.SpherefitError, match="^samples: 0 points"):
        spherefit.sphere.evaluate(FIXTURES.joinpath("sphere_cubic_spline.json").read_text(), samples=0)
    with pytest.raises(spherefit.SpherefitError, match="not valid JSON"):
        spherefit.sphere.evaluate("{")
    with pytest.raises(spherefit.SpherefitError, match="/knots") as e:
        spherefit.sphere.evaluate({"degree": 1, "knots": [0, 1], "control_points": [[1, 0, 0], [0, 1, 0]]})
    assert e.value.problem == "invalid-spline"
    with pytest.raises(spherefit.SpherefitError, match="^at: value 1"):
        spherefit.sphere.evaluate(FIXTURES.joinpath("sphere_cubic_spline.json").read_text(), at=[0, float("nan")])
