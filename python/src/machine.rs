//! `RsMachine`: a machine and its error model (`mtcal_machine::load_machine`, then
//! `MachineModel`), evaluated over rows of axis positions: the loop over rows is here, one
//! `Workspace` for all of them, so Python makes one call for N poses.

use crate::errors::{Kind, other, raise};
use mtcal_kinematics::{MachineModel, Rigid, Workspace};
use mtcal_machine::LoadedMachine;
use mtcal_machine::topology::Reading;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use std::path::Path;

/// A loaded machine: its kinematics and error model (immutable).
#[pyclass(module = "mtcal._mtcal", frozen)]
#[derive(Debug)]
pub struct RsMachine {
    loaded: LoadedMachine,
    model: MachineModel,
}

impl RsMachine {
    pub(crate) fn from_loaded(loaded: LoadedMachine) -> PyResult<Self> {
        let model = MachineModel::new(loaded.machine.clone(), &loaded.config)
            .map_err(|e| other(Kind::Machine, format!("{}: {e}", loaded.config_source)))?;
        Ok(Self { loaded, model })
    }

    /// The rows of `q` checked against the machine's axes.
    fn rows<'a>(&self, q: &'a PyReadonlyArray2<'_, f64>) -> PyResult<(usize, &'a [f64])> {
        let n_axes = self.model.machine().n_axes();
        let shape = q.shape();
        if shape[1] != n_axes {
            return Err(other(
                Kind::Mtcal,
                format!(
                    "axis positions: expected {} columns (axes {}), found {}",
                    n_axes,
                    self.model.machine().letters(),
                    shape[1]
                ),
            ));
        }
        let values = q.as_slice().map_err(|_| {
            other(
                Kind::Mtcal,
                "axis positions: expected a C-contiguous float64 array",
            )
        })?;
        Ok((shape[0], values))
    }

    /// The coefficient vector `coeffs` checked against the model.
    fn coeffs<'a>(&self, coeffs: &'a PyReadonlyArray1<'_, f64>) -> PyResult<&'a [f64]> {
        let values = coeffs.as_slice().map_err(|_| {
            other(
                Kind::Mtcal,
                "coefficients: expected a contiguous float64 array",
            )
        })?;
        if values.len() != self.model.n_coeffs() {
            return Err(other(
                Kind::Mtcal,
                format!(
                    "coefficients: expected {} (the error model's), found {}",
                    self.model.n_coeffs(),
                    values.len()
                ),
            ));
        }
        Ok(values)
    }
}

/// `pose` as a 4 × 4 homogeneous matrix into `out` (16 values, row-major).
fn put_pose(pose: &Rigid, out: &mut [f64]) {
    for i in 0..3 {
        for j in 0..3 {
            out[4 * i + j] = pose.r[(i, j)];
        }
        out[4 * i + 3] = pose.t[i];
    }
    out[12..16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
}

#[pymethods]
impl RsMachine {
    /// Loads a URDF path (with its `<stem>.errors.toml` if there is one) or a topology code
    /// (`reading`: "workpiece", the default, or "tool").
    #[new]
    #[pyo3(signature = (arg, reading = "workpiece"))]
    fn new(arg: &str, reading: &str) -> PyResult<Self> {
        let reading = match reading {
            "workpiece" => Reading::FromWorkpiece,
            "tool" => Reading::FromTool,
            other_reading => {
                return Err(other(
                    Kind::Machine,
                    format!(
                        "reading: expected \"workpiece\" or \"tool\", found \"{other_reading}\""
                    ),
                ));
            }
        };
        let loaded =
            mtcal_machine::load_machine(arg, reading).map_err(|e| other(Kind::Machine, e))?;
        Self::from_loaded(loaded)
    }

    #[getter]
    fn name(&self) -> String {
        self.model.machine().name().to_string()
    }

    /// The axis letters in canonical order (X Y Z U V W A B C), the columns of positions.
    #[getter]
    fn axes(&self) -> String {
        self.model.machine().letters()
    }

    /// Where the machine came from: a file path or `topology code …`.
    #[getter]
    fn source(&self) -> String {
        self.loaded.source.clone()
    }

    /// Where the error model came from.
    #[getter]
    fn model_source(&self) -> String {
        self.loaded.config_source.clone()
    }

    #[getter]
    fn topology_code(&self) -> String {
        self.model.machine().topology_code()
    }

    /// Each axis' limits `(low, high)` in m or rad, `None` where it has none.
    #[getter]
    fn limits(&self) -> Vec<Option<(f64, f64)>> {
        self.model
            .machine()
            .axes()
            .iter()
            .map(|a| a.limits())
            .collect()
    }

    /// A label per coefficient: `EXX` for one-coefficient parameters, `EXX.P2` otherwise.
    #[getter]
    fn coefficient_labels(&self) -> Vec<String> {
        self.model.errors().coefficient_labels()
    }

    /// The ISO 230-1 names of the model's parameters.
    #[getter]
    fn parameters(&self) -> Vec<String> {
        self.model
            .errors()
            .params()
            .iter()
            .map(|p| p.name.to_string())
            .collect()
    }

    #[getter]
    fn n_coeffs(&self) -> usize {
        self.model.n_coeffs()
    }

    /// A parameter file (`mtcal.params/1`, or an identify JSON) as the coefficient vector (SI).
    fn read_params<'py>(
        &self,
        py: Python<'py>,
        path: &str,
    ) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
        let path = Path::new(path);
        let coeffs = mtcal_machine::params::load_params(path, self.model.errors())
            .map_err(|e| raise(Kind::Machine, e.to_string(), e.position()))?;
        Ok(coeffs.into_pyarray(py))
    }

    /// The coefficient vector as a parameter file's text.
    fn params_text(&self, coeffs: PyReadonlyArray1<'_, f64>) -> PyResult<String> {
        let coeffs = self.coeffs(&coeffs)?;
        Ok(mtcal_machine::params::write_params(
            self.model.errors(),
            coeffs,
        ))
    }

    /// Nominal tool poses in the workpiece frame, `(N, 4, 4)`, for `(N, n_axes)` positions.
    fn nominal_pose<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let (n, values) = self.rows(&q)?;
        let k = self.model.machine().n_axes();
        let mut out = vec![0.0; n * 16];
        for (row, o) in values.chunks_exact(k.max(1)).zip(out.chunks_exact_mut(16)) {
            put_pose(&self.model.machine().tool_in_workpiece(row), o);
        }
        to_poses(py, n, out)
    }

    /// Actual tool poses in the workpiece frame with every error of `coeffs`, `(N, 4, 4)`.
    fn pose<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        coeffs: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let (n, values) = self.rows(&q)?;
        let coeffs = self.coeffs(&coeffs)?;
        let k = self.model.machine().n_axes();
        let mut ws: Workspace = self.model.workspace();
        let mut out = vec![0.0; n * 16];
        for (row, o) in values.chunks_exact(k.max(1)).zip(out.chunks_exact_mut(16)) {
            put_pose(&self.model.tool_pose(row, coeffs, &mut ws), o);
        }
        to_poses(py, n, out)
    }

    /// Pose errors `(N, 6)`: `[dx, dy, dz, ea, eb, ec]` in m and rad, in the workpiece frame;
    /// exact, or to first order.
    #[pyo3(signature = (q, coeffs, first_order = false))]
    fn pose_error<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        coeffs: PyReadonlyArray1<'py, f64>,
        first_order: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (n, values) = self.rows(&q)?;
        let coeffs = self.coeffs(&coeffs)?;
        let k = self.model.machine().n_axes();
        let mut ws = self.model.workspace();
        let mut out = vec![0.0; n * 6];
        for (row, o) in values.chunks_exact(k.max(1)).zip(out.chunks_exact_mut(6)) {
            let e = if first_order {
                self.model.pose_error_first_order(row, coeffs, &mut ws)
            } else {
                self.model.pose_error(row, coeffs, &mut ws)
            };
            o.copy_from_slice(&e.to_array());
        }
        let array = Array2::from_shape_vec((n, 6), out).expect("n × 6 values");
        Ok(array.into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "Machine({:?}: {}, axes {}, {} coefficients)",
            self.model.machine().name(),
            self.loaded.source,
            self.model.machine().letters(),
            self.model.n_coeffs()
        )
    }
}

fn to_poses(py: Python<'_>, n: usize, out: Vec<f64>) -> PyResult<Bound<'_, PyArray3<f64>>> {
    let array = Array3::from_shape_vec((n, 4, 4), out).expect("n × 4 × 4 values");
    Ok(array.into_pyarray(py))
}
