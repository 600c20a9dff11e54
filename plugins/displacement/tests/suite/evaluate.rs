//! The ISO 230-3-style evaluation: each sensor's drift over a run.

use mtcal_displacement::{drift, evaluate};
use mtcal_instrument::{Evaluation, Unit};

fn machine() -> mtcal_kinematics::Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../machines/mcv754-zfyx.urdf"
    );
    mtcal_machine::load_machine(path, Default::default())
        .expect("shipped machine")
        .machine
}

#[test]
fn drift_is_the_range_of_each_sensor_over_the_run() {
    let m = machine();
    // Written out of order: channels are b (sorted first), then z.
    let setup: toml::Table = toml::from_str("[sensors]\nz = \"Z\"\nb = {}\n").expect("toml");
    // Rows: (d_b, d_z) in metres.
    let readings = [0.0, 1e-6, 2e-6, -3e-6, f64::NAN, 4e-6, -1e-6, 0.0];
    let q = vec![0.0; 4 * 3];
    let t = [0.0, 1.0, 2.0, 3.0];
    let loaded_0 =
        mtcal_displacement::load_setup(&setup, &mtcal_instrument::SetupContext { machine: &m })
            .unwrap();
    let metrics = evaluate(&Evaluation {
        machine: &m,
        setup: &*loaded_0,
        q: &q,
        readings: &readings,
        t: &t,
        labels: &[],
    });
    let names: Vec<&str> = metrics.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "thermal drift d_b (ISO 230-3)",
            "thermal drift d_z (ISO 230-3)"
        ]
    );
    // d_b: 0, 2, NaN (left out), −1 µm → 3 µm; d_z: 1, −3, 4, 0 µm → 7 µm.
    assert!((metrics[0].value - 3e-6).abs() < 1e-18, "{metrics:?}");
    assert!((metrics[1].value - 7e-6).abs() < 1e-18, "{metrics:?}");
    assert!(metrics.iter().all(|x| x.unit == Unit::Um));

    // Readings that do not match the channels: nothing.
    let odd = &readings[..7];
    assert!(
        evaluate(&Evaluation {
            machine: &m,
            setup: &*loaded_0,
            q: &q,
            readings: odd,
            t: &t,
            labels: &[],
        })
        .is_empty()
    );
    assert_eq!(drift(&[f64::NAN, 1.0], 2), [None, Some(0.0)]);
}
