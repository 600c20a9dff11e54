//! The Monte Carlo against ground truth: zero tolerances give zero error, a scale tolerance
//! gives its closed-form P90, sensitivities of an ineffective and of a doubled tolerance,
//! determinism, and source 001's qualitative findings on the shipped ZFYX machine.

use mtcal_kinematics::Machine;
use mtcal_machine::topology::Reading;
use mtcal_tolerance::{Analysis, Options, Report, parse_spec};
use std::path::Path;

fn zfyx() -> Machine {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/three-axis/machine/zfyx.urdf"
    );
    mtcal_machine::load_machine(path, Reading::FromTool)
        .unwrap()
        .machine
}

const GUIDES: &str = r#"
[axis.X]
normal = "+Z"
rail_spacing_mm = 300
block_pitch_mm = 250
[axis.Y]
normal = "+Z"
rail_spacing_mm = 500
block_pitch_mm = 350
stiffness_n_per_um = [300, 500, 400, 600]
[axis.Z]
normal = "-Y"
rail_spacing_mm = 400
block_pitch_mm = 350
"#;

fn report(spec: &str, counts: [usize; 3], samples: usize, seed: u64, threads: usize) -> Report {
    let machine = zfyx();
    let text = format!("{GUIDES}\n{spec}");
    let spec = parse_spec(&text, Path::new("test.toml"), &machine).unwrap();
    let analysis = Analysis::new(&machine, &spec, &counts).unwrap();
    analysis
        .run(&Options {
            samples,
            seed,
            threads,
            bootstrap: 20,
            ..Options::default()
        })
        .unwrap()
}

fn tolerance(kind: &str, body: &str) -> String {
    format!("[[tolerance]]\nkind = \"{kind}\"\n{body}\n")
}

#[test]
fn zero_tolerances_give_exactly_zero_error() {
    // Every kind at zero, with loads on unequal blocks of Y in the guides: the loads' constant
    // tilt stays, so compare against a spec without tolerances at all, which must agree and
    // whose errors come from the loads only; with equal stiffness (X, Z) nothing at all.
    let all_zero: String = [
        tolerance(
            "rail",
            "axis = \"X\"\ndirection = \"vertical\"\ntolerance_um = 0",
        ),
        tolerance(
            "rail",
            "axis = \"Z\"\ndirection = \"horizontal\"\ntolerance_um = 0",
        ),
        tolerance("pads", "axis = \"X\"\ntolerance_um = 0"),
        tolerance(
            "component",
            "name = \"EBZ\"\nshape = \"bow\"\ntolerance_urad = 0",
        ),
        tolerance("component", "name = \"EA0Z\"\ntolerance_urad = 0"),
    ]
    .concat();
    let machine = zfyx();
    let spec = parse_spec(
        &format!("{GUIDES}\n{all_zero}"),
        Path::new("t.toml"),
        &machine,
    )
    .unwrap();
    let analysis = Analysis::new(&machine, &spec, &[4, 3, 5]).unwrap();
    let maxima = analysis
        .sample_maxima(&Options {
            samples: 20,
            ..Options::default()
        })
        .unwrap();
    assert!(maxima.iter().all(|&m| m == 0.0), "{maxima:?}");
    // With a load on Y's unequal blocks: a constant tilt, the same for every sample and run.
    let loaded = GUIDES.replace(
        "[300, 500, 400, 600]",
        "[300, 500, 400, 600]\nload_n = 5000",
    );
    let spec = parse_spec(
        &format!("{loaded}\n{all_zero}"),
        Path::new("t.toml"),
        &machine,
    )
    .unwrap();
    let r = Analysis::new(&machine, &spec, &[4, 3, 5])
        .unwrap()
        .run(&Options {
            samples: 20,
            bootstrap: 5,
            ..Options::default()
        })
        .unwrap();
    assert!(r.baseline.max_um > 0.0 && r.baseline.min_um == r.baseline.max_um);
    for s in &r.sensitivities {
        assert_eq!(s.delta_p90_um, Some(0.0));
        assert_eq!(s.slope, None, "a zero tolerance has no slope");
    }
}

#[test]
fn a_uniform_scale_tolerance_has_its_closed_form_p90() {
    // EXX = X·t·(x − lo)/(hi − lo), X ~ U(−1, 1), pinned at the stroke's start: the maximum
    // over the grid is |X|·t with |X| ~ U(0, 1), so P90 = 0.9 t, P50 = 0.5 t, mean 0.5 t.
    let t = 10.0;
    let spec = tolerance(
        "component",
        &format!("name = \"EXX\"\nshape = \"linear\"\ntolerance_um = {t}"),
    );
    let n = 4000;
    let r = report(&spec, [5, 3, 3], n, 3, 0);
    let b = &r.baseline;
    // Standard error of the sample P90: sqrt(p(1−p)/n)/f = 0.3/sqrt(n)·t.
    let se = 0.3 / (n as f64).sqrt() * t;
    assert!(
        (b.p90_um - 0.9 * t).abs() < 4.0 * se,
        "P90 {} vs {}",
        b.p90_um,
        0.9 * t
    );
    assert!(
        b.p90_ci_um[0] <= 0.9 * t && 0.9 * t <= b.p90_ci_um[1],
        "{:?}",
        b.p90_ci_um
    );
    assert!((b.p50_um - 0.5 * t).abs() < 4.0 * 0.5 / (n as f64).sqrt() * t);
    assert!((b.mean_um - 0.5 * t).abs() < 4.0 * t / (12.0 * n as f64).sqrt());
    assert!(b.max_um <= t + 1e-9);
    // Alone, the tolerance's maximum is linear in it: slope = P90/t, without it 0.
    let s = &r.sensitivities[0];
    assert_eq!(s.p90_without_um, Some(0.0));
    assert!((s.slope.unwrap() - b.p90_um / t).abs() < 1e-9);

    // Normal with t = 2σ: |X| is half-normal, P90 = 1.6449·σ.
    let spec = spec.replace("tolerance_um", "distribution = \"normal\"\ntolerance_um");
    let r = report(&spec, [5, 3, 3], n, 4, 0);
    let sigma = t / 2.0;
    let want = 1.644_853_6 * sigma;
    // f(P90) of the half-normal: 2φ(1.645)/σ = 0.2063/σ·… → se = sqrt(.09/n)/(0.2063/σ).
    let se = (0.09 / n as f64).sqrt() / (2.0 * 0.103_136 / sigma);
    assert!(
        (r.baseline.p90_um - want).abs() < 4.0 * se,
        "{} vs {want}",
        r.baseline.p90_um
    );
}

#[test]
fn ineffective_and_doubled_tolerances() {
    // A constant straightness of X is a set-up offset in mtcal's conventions: it cannot change
    // any map, so its sensitivity is exactly zero (common random numbers).
    let spec = [
        tolerance(
            "rail",
            "axis = \"X\"\ndirection = \"vertical\"\ntolerance_um = 30",
        ),
        tolerance(
            "component",
            "name = \"EYX\"\nshape = \"constant\"\ntolerance_um = 50",
        ),
        "[sensitivity]\nlevels = [0, 2]\n".to_string(),
    ]
    .concat();
    let r = report(&spec, [5, 4, 3], 200, 9, 2);
    let offset = &r.sensitivities[1];
    assert_eq!(offset.delta_p90_um, Some(0.0));
    assert_eq!(offset.slope, Some(0.0));
    assert!(offset.levels.iter().all(|l| l.p90_um == r.baseline.p90_um));
    // The rail tolerance is the only effective one, so doubling it doubles the P90 exactly and
    // zeroing it leaves nothing.
    let rail = &r.sensitivities[0];
    let at = |scale: f64| {
        rail.levels
            .iter()
            .find(|l| l.scale == scale)
            .unwrap()
            .p90_um
    };
    assert!(at(1.0) > 1.0, "the rails matter: {}", at(1.0));
    assert!((at(2.0) - 2.0 * at(1.0)).abs() < 1e-9 * at(1.0));
    assert_eq!(at(0.0), 0.0);
    assert!((rail.slope.unwrap() - at(1.0) / 30.0).abs() < 1e-9);
}

#[test]
fn results_depend_on_the_seed_only() {
    let spec = [
        tolerance("rail", "axis = \"Y\"\ndirection = \"vertical\"\ntolerance_um = 20"),
        tolerance("rail", "axis = \"Z\"\ndirection = \"horizontal\"\ntolerance_um = 20\ndistribution = \"uniform\""),
        tolerance("pads", "axis = \"Y\"\ntolerance_um = 10\ndistribution = \"normal\""),
        tolerance("component", "name = \"EC0Y\"\ntolerance_urad = 15"),
        "[sensitivity]\nlevels = [0, 2]\n".to_string(),
    ]
    .concat();
    let a = report(&spec, [4, 4, 4], 37, 5, 1);
    let b = report(&spec, [4, 4, 4], 37, 5, 3);
    assert_eq!(a, b, "one thread or three");
    assert_eq!(a.to_json(), b.to_json());
    let c = report(&spec, [4, 4, 4], 37, 6, 1);
    assert_ne!(a.baseline.p90_um, c.baseline.p90_um);
}

#[test]
fn vertical_straightness_dominates_on_the_zfyx_machine() {
    // Source 001, Table 1: the vertical straightness tolerances of the rail mounting surfaces
    // have about ten times the influence of the horizontal ones. A qualitative check with the
    // example's assumed geometry and few samples (common random numbers keep it stable).
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/three-axis/tolerances.toml"
    );
    let machine = zfyx();
    let spec = mtcal_tolerance::load_spec(Path::new(path), &machine).unwrap();
    let analysis = Analysis::new(&machine, &spec, &[5, 5, 5]).unwrap();
    let r = analysis
        .run(&Options {
            samples: 150,
            bootstrap: 0,
            ..Options::default()
        })
        .unwrap();
    let slope = |label: &str| {
        r.sensitivities
            .iter()
            .find(|s| s.label == label)
            .unwrap()
            .slope
            .unwrap()
    };
    let mut vertical = 0.0f64;
    let mut horizontal = 0.0f64;
    for axis in ["X", "Y", "Z"] {
        let v = slope(&format!("{axis} rails vertical straightness"));
        let h = slope(&format!("{axis} rails horizontal straightness"));
        vertical += v;
        horizontal += h;
        eprintln!("{axis}: vertical {v:.3}, horizontal {h:.3} µm/µm");
    }
    assert!(vertical > 2.0 * horizontal, "{vertical} vs {horizontal}");
    assert!(r.baseline.p90_um > 0.0);
}

/// The shipped example at full size:
/// `cargo test --release -p mtcal-tolerance --test monte_carlo -- --ignored --nocapture`
#[test]
#[ignore = "slow in debug; run in release"]
fn shipped_example() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/three-axis/tolerances.toml"
    );
    let machine = zfyx();
    let spec = mtcal_tolerance::load_spec(Path::new(path), &machine).unwrap();
    let analysis = Analysis::new(&machine, &spec, &[11, 11, 11]).unwrap();
    let t0 = std::time::Instant::now();
    let r = analysis.run(&Options::default()).unwrap();
    println!("{r}\n{:.2} s", t0.elapsed().as_secs_f64());
}
