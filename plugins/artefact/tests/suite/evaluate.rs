//! The plate's own evaluation on hand-made runs: a shear and an X scale error of the measured
//! centres come out as the affine fit's apparent squareness and scale difference; a pure
//! similarity (offset, turn, common scale) leaves no deviation.

use mtcal_artefact::{evaluate, load};
use mtcal_instrument::{Evaluation, Metric, SetupContext};
use mtcal_kinematics::Machine;

fn machine() -> Machine {
    mtcal_machine::load_machine(
        &format!(
            "{}/../../machines/mcv754-zfyx.urdf",
            env!("CARGO_MANIFEST_DIR")
        ),
        mtcal_machine::topology::Reading::default(),
    )
    .expect("shipped machine")
    .machine
}

/// A 4 × 4 plate at one placement; every feature probed once.
fn table() -> toml::Table {
    let mut text = String::from("origin = [20.0, -10.0, -300.0]\n[features]\n");
    for i in 0..4 {
        for j in 0..4 {
            text += &format!(
                "h{i}{j} = [{}, {}]\n",
                -75.0 + 50.0 * i as f64,
                -60.0 + 40.0 * j as f64
            );
        }
    }
    toml::from_str(&text).unwrap()
}

/// Metrics of a run whose measured centres are the nominal ones moved by `moved(x, y)` (m, in
/// the plate's plane relative to its origin).
fn metrics(moved: impl Fn(f64, f64) -> [f64; 2]) -> Vec<Metric> {
    let m = machine();
    let t = table();
    let setup = load(&t, &SetupContext { machine: &m }).unwrap();
    let (xyz, _) = mtcal_artefact::frame_of(&m).unwrap();
    let (mut q, mut readings, mut labels) = (Vec::new(), Vec::new(), Vec::new());
    let origin = setup.nominal_xyz(0, 0) - nalgebra::Vector3::new(-0.075, -0.06, 0.0);
    for k in 0..setup.features().len() {
        let p = setup.nominal_xyz(0, k);
        let mut qk = vec![0.0; m.n_axes()];
        for (a, &ix) in xyz.iter().enumerate() {
            qk[ix] = p[a];
        }
        let d = moved(p.x - origin.x, p.y - origin.y);
        q.extend(qk);
        readings.extend([d[0], d[1]]);
        labels.push(setup.label(0, k));
    }
    let ts: Vec<f64> = (0..labels.len()).map(|i| i as f64).collect();
    let loaded_0 =
        mtcal_artefact::load_setup(&t, &mtcal_instrument::SetupContext { machine: &m }).unwrap();
    evaluate(&Evaluation {
        machine: &m,
        setup: &*loaded_0,
        q: &q,
        readings: &readings,
        t: &ts,
        labels: &labels,
    })
}

fn get(ms: &[Metric], name: &str) -> f64 {
    ms.iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("{name} not in {ms:?}"))
        .value
}

#[test]
fn a_shear_and_an_x_scale_are_the_apparent_squareness_and_scale_difference() {
    let (e, sx) = (15e-6, 8e-6);
    // EC0Y = e moves by −e·y along X; an X scale error sx by sx·x.
    let ms = metrics(|x, y| [sx * x - e * y, 0.0]);
    assert!(
        (get(&ms, "apparent EC0Y (affine fit)") - e).abs() < 1e-9,
        "{ms:?}"
    );
    assert!(
        (get(&ms, "EXX − EYY slope (affine fit)") - sx).abs() < 1e-9,
        "{ms:?}"
    );
    assert!(get(&ms, "similarity-fit RMS deviation") > 1e-7);
}

#[test]
fn a_similarity_leaves_no_deviation() {
    let (s, th) = (5e-6, 20e-6);
    let ms = metrics(|x, y| [3e-6 + s * x - th * y, -2e-6 + s * y + th * x]);
    assert!(get(&ms, "similarity-fit RMS deviation") < 1e-10, "{ms:?}");
    assert!(get(&ms, "largest deviation after similarity fit") < 1e-10);
    assert!((get(&ms, "scale (similarity fit)") - s).abs() < 1e-9);
    assert!(get(&ms, "apparent EC0Y (affine fit)").abs() < 1e-9);
}
