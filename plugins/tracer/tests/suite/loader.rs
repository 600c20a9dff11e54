//! The set-up loader: defaults, validation and what `to_toml` writes.

use mtcal_instrument::{Setup, SetupContext, SetupFormat, Unit};
use mtcal_kinematics::Machine;
use mtcal_machine::topology::Reading;
use std::path::Path;

fn machine() -> Machine {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../machines/mcv754-zfyx.urdf");
    mtcal_machine::load_machine(p.to_str().unwrap(), Reading::default())
        .unwrap()
        .machine
}

fn load(text: &str) -> Result<mtcal_tracer::TracerSetup, mtcal_instrument::SetupError> {
    let m = machine();
    mtcal_tracer::load(
        &toml::from_str(text).unwrap(),
        &SetupContext { machine: &m },
    )
}

#[test]
fn defaults_free_station_and_dead_path_without_priors() {
    let s = load("station = [420, 320, 0]").unwrap();
    let names: Vec<&str> = s.nuisance().iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["station_x", "station_y", "station_z", "dead_path"]);
    assert!(
        s.nuisance()
            .iter()
            .all(|n| n.free && n.prior_sigma.is_none())
    );
    assert!(s.nuisance().iter().all(|n| n.unit == Unit::Um));
    assert_eq!(s.channels().len(), 1);
    assert_eq!(s.channels()[0].name, "d");
    let t = s.to_toml();
    assert_eq!(t["reflector"], toml::Value::Array(vec![0.0.into(); 3]));
    assert_eq!(
        t["sigma_um"],
        toml::Value::Float(mtcal_tracer::DEFAULT_SIGMA_UM)
    );
    assert!(!t.contains_key("station_u_mm"));
}

#[test]
fn flags_and_a_station_prior() {
    let s = load("station = [0, 0, 0]\nstation_u_mm = 2.0\ndead_path_free = false").unwrap();
    let n = s.nuisance();
    assert!(n[..3].iter().all(|n| n.free && n.prior_sigma == Some(2e-3)));
    assert!(!n[3].free);
    let s = load("station = [0, 0, 0]\nstation_free = false").unwrap();
    assert!(s.nuisance()[..3].iter().all(|n| !n.free));
}

#[test]
fn bad_values_are_rejected_naming_the_key() {
    let key = |text: &str| load(text).unwrap_err().key;
    assert_eq!(key("reflector = [0, 0, 0]"), "station");
    assert_eq!(key("station = [0, 0]"), "station");
    assert_eq!(key("station = [0, 0, 0]\nsigma_um = 0"), "sigma_um");
    assert_eq!(
        key("station = [0, 0, 0]\nsigma_um_per_m = -0.1"),
        "sigma_um_per_m"
    );
    assert_eq!(
        key("station = [0, 0, 0]\nstation_u_mm = -1"),
        "station_u_mm"
    );
    assert_eq!(
        key("station = [0, 0, 0]\nstation_free = false\nstation_u_mm = 1"),
        "station_u_mm"
    );
    assert_eq!(key("station = [0, 0, 0]\nreflector = \"Z\""), "reflector");
    assert_eq!(
        key("station = [0, 0, 0]\nstation_fre = true"),
        "station_fre"
    );
}
