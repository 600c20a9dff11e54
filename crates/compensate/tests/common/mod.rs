//! What the compensation tests share: the shipped machines and a seeded generator.

#![allow(dead_code)]

use mtcal_kinematics::MachineModel;
use mtcal_machine::topology::Reading;
use std::path::Path;

/// The 0.1 µm round-trip tolerance of the issue.
pub const TOL_UM: f64 = 0.1;

/// A shipped machine (`machines/<name>`) with its error model.
pub fn load(name: &str) -> MachineModel {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../machines")
        .join(name);
    let m = mtcal_machine::load_machine(path.to_str().unwrap(), Reading::FromWorkpiece).unwrap();
    MachineModel::new(m.machine, &m.config).unwrap()
}

/// splitmix64: a seeded, dependency-free generator of uniform numbers in [-1, 1).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}
