//! `mtcal._mtcal`: the compiled core of the Python package `mtcal` (python/mtcal/__init__.py
//! wraps it). Every call goes to the workspace's library crates: machines through
//! `mtcal_machine::load_machine` and `mtcal_kinematics::MachineModel`, sessions through
//! `mtcal_identify::Study`, the identification through `mtcal_identify::pipeline` (as `mtcal
//! identify` runs it), simulations through `mtcal_simulate`. Nothing numeric is computed here:
//! this crate moves numbers between numpy arrays and those calls, loops over rows in Rust, and
//! turns mtcal's located errors into Python exceptions with `file`, `line` and `column`.

mod errors;
mod machine;
mod session;

use pyo3::prelude::*;

#[pymodule]
fn _mtcal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<machine::RsMachine>()?;
    m.add_class::<session::RsSession>()?;
    m.add_class::<session::RsOutcome>()?;
    m.add_function(wrap_pyfunction!(session::identify, m)?)?;
    m.add_function(wrap_pyfunction!(session::simulate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
