//! The plan's machine: the loaded one with its tool point moved down the tool axis to the
//! instrument's ball or probe centre.

use mtcal_kinematics::Machine;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

/// `m` with the tool point moved `length` (m) down the tool axis.
pub fn tooled_machine(m: &Machine, length: f64) -> Result<Machine, String> {
    let mut spec = m.to_spec();
    spec.tool.end *= Isometry3::from_parts(
        Translation3::new(0.0, 0.0, -length),
        UnitQuaternion::identity(),
    );
    Machine::try_new(&spec).map_err(|e| e.to_string())
}
