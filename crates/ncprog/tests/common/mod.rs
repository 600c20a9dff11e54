//! What the NC-program tests share: the shipped machines' models. Their random errors come from
//! `mtcal_testkit::random::uniform`.

use mtcal_kinematics::MachineModel;

/// The shipped machine `machines/<name>` with its error model.
pub fn model(name: &str) -> MachineModel {
    let path = mtcal_testkit::machine_file(name);
    let loaded =
        mtcal_machine::load_machine(path.to_str().unwrap(), Default::default()).expect("machine");
    MachineModel::new(loaded.machine, &loaded.config).expect("model")
}
