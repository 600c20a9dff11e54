"""Machines: loading (URDF, topology codes, errors located) and poses and pose errors for
arrays of positions, against Rust computing them without the binding (python/refcheck)."""

from __future__ import annotations

import numpy as np
import pytest

import mtcal
from conftest import EXAMPLES, REPO

FIVE_AXIS = EXAMPLES / "five-axis" / "session" / "machine.urdf"
THREE_AXIS = EXAMPLES / "three-axis" / "session" / "machine.urdf"


def positions(machine: mtcal.Machine, n: int, seed: int) -> np.ndarray:
    """`n` rows of positions inside the axes' limits (±1 rad on a rotary axis without)."""
    rng = np.random.default_rng(seed)
    cols = []
    for lim in machine.limits:
        lo, hi = lim if lim is not None else (-1.0, 1.0)
        cols.append(rng.uniform(lo, hi, n))
    return np.column_stack(cols)


def test_a_urdf_loads_with_its_error_model():
    m = mtcal.Machine(FIVE_AXIS)
    assert m.axes == "XYZAC"
    assert m.n_axes == 5
    assert m.name == "mcu630-cafyxz"
    assert m.model_source.endswith("machine.errors.toml")
    assert "EC0Y" in m.parameters and "EXX" in m.parameters and "TOOL_DZ" in m.parameters
    assert m.n_coeffs == len(m.coefficient_labels) > len(m.parameters)
    assert m.topology_code == "wCAFYXZt"  # w: workpiece side, t: tool side
    t = mtcal.Machine(THREE_AXIS)
    assert t.axes == "XYZ"


def test_topology_codes_load_with_the_full_iso_model():
    m = mtcal.Machine("CAFYXZ")
    assert m.axes == "XYZAC"
    assert m.model_source == "full ISO model"
    assert m.source == "topology code wCAFYXZt"
    z = mtcal.Machine("ZFYX")
    assert z.axes == "XYZ"
    # 3 axes × 6 component errors + 3 squareness errors, at least.
    assert len(z.parameters) >= 21
    with pytest.raises(mtcal.MachineError):
        mtcal.Machine("ZFYX", reading="sideways")


def test_a_wrong_path_raises_an_error_naming_the_file(tmp_path):
    missing = tmp_path / "nowhere" / "machine.urdf"
    with pytest.raises(mtcal.MachineError) as e:
        mtcal.Machine(missing)
    assert isinstance(e.value, mtcal.MtcalError)
    assert e.value.file == str(missing)
    assert e.value.line is None and e.value.column is None
    assert str(missing) in str(e.value)


def test_a_broken_urdf_is_located(tmp_path):
    bad = tmp_path / "bad.urdf"
    text = FIVE_AXIS.read_text().replace("<joint", "<joint <", 1)
    bad.write_text(text)
    with pytest.raises(mtcal.MachineError) as e:
        mtcal.Machine(bad)
    assert e.value.file == str(bad)
    line = next(i for i, l in enumerate(text.splitlines(), 1) if "<joint <" in l)
    assert e.value.line == line, str(e.value)
    assert e.value.column is not None


@pytest.mark.parametrize("arg", [str(FIVE_AXIS), str(THREE_AXIS), "ZFYX", "CAFYXZ"])
def test_vectorised_poses_match_rust_to_1e_12(arg, refcheck, tmp_path):
    m = mtcal.Machine(arg)
    rng = np.random.default_rng(1)
    # Errors of a few µm and µrad in every coefficient, through a parameter file that both
    # sides read.
    params = tmp_path / "p.params.toml"
    params.write_text(m.params_text(rng.normal(0.0, 5e-6, m.n_coeffs)))
    coeffs = m.read_params(params)
    assert np.count_nonzero(coeffs) == m.n_coeffs
    q = positions(m, 200, seed=2)
    ref = refcheck({"machine": arg, "params": str(params), "q": q.tolist()})
    np.testing.assert_array_equal(coeffs, np.array(ref["coeffs"]))
    nominal, actual, error = m.nominal_pose(q), m.pose(q, coeffs), m.pose_error(q, coeffs)
    assert nominal.shape == actual.shape == (200, 4, 4)
    assert error.shape == (200, 6)
    np.testing.assert_allclose(nominal, np.array(ref["nominal"]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(actual, np.array(ref["actual"]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(error, np.array(ref["error"]), rtol=0, atol=1e-12)
    # The errors are µm and µrad: a comparison at 1e-12 of them is one of a millionth.
    assert np.abs(error).max() > 1e-6
    # Nominal machine: no error.
    assert np.abs(m.pose_error(q)).max() < 1e-15


def test_vectorised_equals_one_call_per_point():
    m = mtcal.Machine(FIVE_AXIS)
    coeffs = np.random.default_rng(3).normal(0.0, 1e-5, m.n_coeffs)
    q = positions(m, 50, seed=4)
    many = m.pose_error(q, coeffs)
    one_by_one = np.array([m.pose_error(row, coeffs) for row in q])
    np.testing.assert_array_equal(many, one_by_one)
    np.testing.assert_array_equal(m.pose(q, coeffs)[7], m.pose(q[7], coeffs))
    np.testing.assert_array_equal(m.nominal_pose(q)[7], m.nominal_pose(list(q[7])))
    # Non-contiguous and integer input is taken as float64 rows.
    np.testing.assert_array_equal(m.pose_error(np.asfortranarray(q), coeffs), many)
    # First order agrees with the exact error to second order in the error size.
    first = m.pose_error(q, coeffs, first_order=True)
    assert np.abs(first - many).max() < 1e-3 * np.abs(many).max()
    assert not np.array_equal(first, many)


def test_wrong_shapes_are_refused():
    m = mtcal.Machine(FIVE_AXIS)
    with pytest.raises(mtcal.MtcalError, match="expected 5 columns"):
        m.pose_error(np.zeros((3, 4)))
    with pytest.raises(mtcal.MtcalError, match="coefficients"):
        m.pose_error(np.zeros((3, 5)), np.zeros(3))
    with pytest.raises(ValueError):
        m.pose_error(np.zeros((2, 3, 5)))


def test_a_broken_parameter_file_is_located(tmp_path):
    m = mtcal.Machine(FIVE_AXIS)
    p = tmp_path / "bad.params.toml"
    p.write_text('schema = "mtcal.params/1"\n\n[values]\nEC0Y = 12.0\nEQQQ = 1.0\n')
    with pytest.raises(mtcal.MachineError) as e:
        m.read_params(p)
    assert (e.value.file, e.value.line, e.value.column) == (str(p), 5, 1), str(e.value)


def test_an_unknown_coefficient_name_is_an_mtcal_error():
    m = mtcal.Machine(FIVE_AXIS)
    with pytest.raises(mtcal.MachineError) as e:
        m.coefficients({"EQQ": 1.0})
    assert e.value.file is None and e.value.line is None and e.value.column is None
    c = m.coefficients({"EC0Y": 1e-5})
    assert c[m.coefficient_labels.index("EC0Y")] == 1e-5 and np.count_nonzero(c) == 1
