//! The built-in control formats, one module each (`isg` and `etalon`, one file type in two
//! syntaxes, share one), each registering itself ([`crate::Registered`]); the modules without
//! a registration are what two formats share.
//! A new built-in format is a module here and its `mod` line.

mod csv;
mod error_parameters;
mod fanuc;
mod heidenhain_com;
mod heidenhain_files;
mod heidenhain_kinematicscomp;
mod linuxcnc;
mod linuxcnc_trt;
mod parameter_files;
mod pitch_table;
mod siemens_carr;
mod siemens_cec;
mod siemens_eec;

/// Refuses an `--axis` for a file of the whole machine (`name` writes `what`): the axis would
/// be silently ignored otherwise.
fn no_axis(name: &str, what: &str, axis: Option<char>) -> Result<(), crate::CompensateError> {
    match axis {
        Some(axis) => Err(crate::CompensateError::AxisUse(format!(
            "--format {name} writes {what}; drop --axis {axis}"
        ))),
        None => Ok(()),
    }
}
