//! What the compensation tests share: the shipped machines and the tolerance. Their random
//! errors come from `mtcal_testkit::random::SplitMix64`.

#![allow(dead_code)]

use mtcal_kinematics::MachineModel;
use mtcal_machine::topology::Reading;

/// The 0.1 µm round-trip tolerance of the issue.
pub const TOL_UM: f64 = 0.1;

/// A shipped machine (`machines/<name>`) with its error model.
pub fn load(name: &str) -> MachineModel {
    let path = mtcal_testkit::machine_file(name);
    let m = mtcal_machine::load_machine(path.to_str().unwrap(), Reading::FromWorkpiece).unwrap();
    MachineModel::new(m.machine, &m.config).unwrap()
}
