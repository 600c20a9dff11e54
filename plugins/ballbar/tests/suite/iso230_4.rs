//! ISO 230-4 evaluation (circular deviation, centre removal, bidirectional) and the set-up
//! table's contract (keys, defaults, round trip, registration).

use mtcal_ballbar::{
    BallbarConfig, BallbarSetup, bidirectional_circular_deviation, circular_deviation,
    circular_deviation_uncertainty,
};
use mtcal_instrument::{Setup, SetupFormat, Unit};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// `n` evenly spaced angles over one revolution, without repeating the start.
fn angles(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| std::f64::consts::TAU * k as f64 / n as f64)
        .collect()
}

#[test]
fn ellipse_peak_to_valley_is_g() {
    // The ball on an exact ellipse with semi-axes L + e1 (along the plane's first axis) and
    // L + e2: the bar reads √((L+e1)² cos² φ + (L+e2)² sin² φ) − L, e1 at 0°, e2 at 90°,
    // monotonic in between, symmetric: no centre, G = |e1 − e2|.
    let (l, e1, e2) = (0.1, 7e-6, -2e-6);
    let phi = angles(360);
    let dr: Vec<f64> = phi
        .iter()
        .map(|p| ((l + e1) * p.cos()).hypot((l + e2) * p.sin()) - l)
        .collect();
    let cd = circular_deviation(&phi, &dr);
    assert!((cd.g - (e1 - e2)).abs() < 1e-15, "{cd:?}");
    assert!(
        cd.centre_a.abs() < 1e-16 && cd.centre_b.abs() < 1e-16,
        "{cd:?}"
    );
    let mean: f64 = dr.iter().sum::<f64>() / dr.len() as f64;
    assert!((cd.radius_offset - mean).abs() < 1e-16);
}

#[test]
fn centre_and_radius_are_removed_exactly() {
    let phi = angles(72);
    let shape = |p: f64| 2e-6 * (3.0 * p).sin() - 1e-6 * (2.0 * p + 0.3).cos();
    let bare: Vec<f64> = phi.iter().map(|&p| shape(p)).collect();
    let shifted: Vec<f64> = phi
        .iter()
        .map(|&p| shape(p) + 12e-6 * p.cos() - 30e-6 * p.sin() + 5e-6)
        .collect();
    let a = circular_deviation(&phi, &bare);
    let b = circular_deviation(&phi, &shifted);
    assert!((b.centre_a - 12e-6).abs() < 1e-17, "{b:?}");
    assert!((b.centre_b + 30e-6).abs() < 1e-17, "{b:?}");
    assert!((b.radius_offset - 5e-6).abs() < 1e-17, "{b:?}");
    assert!((a.g - b.g).abs() < 1e-17);
    // The peak to valley of the shape itself, by brute force on a fine grid, bounds G.
    let fine: Vec<f64> = angles(100_000).into_iter().map(shape).collect();
    let p2v = fine.iter().copied().fold(f64::MIN, f64::max)
        - fine.iter().copied().fold(f64::MAX, f64::min);
    assert!(a.g <= p2v + 1e-15 && a.g > 0.95 * p2v, "{} vs {p2v}", a.g);
}

/// A circle with one reading 5 µm out and the opposite one 5 µm in: the extremes of the
/// residuals are those two, whatever 0.5 µm of noise does to the others.
fn two_spikes(n: usize) -> (Vec<f64>, Vec<f64>) {
    let phi = angles(n);
    let mut dr = vec![0.0; n];
    dr[0] = 5e-6;
    dr[n / 2] = -5e-6;
    (phi, dr)
}

#[test]
fn the_uncertainty_of_g_is_that_of_two_residuals_of_the_circle_fit() {
    // Evenly spaced over the circle, XᵀX = diag(n, n/2, n/2), so h_ab = (1 + 2 cos(φa − φb))/n:
    // h = 3/n on the diagonal and −1/n for opposite readings; Var G = σ² (2 − 6/n − 2/n).
    let n = 36;
    let (phi, dr) = two_spikes(n);
    let sigma = 0.5e-6;
    let want = 2.0 * sigma * (2.0 - 8.0 / n as f64).sqrt();
    let got = circular_deviation_uncertainty(&phi, &dr, sigma);
    assert!((got - want).abs() < 1e-15, "{got} vs {want}");
    // No readings, no uncertainty; without noise, none either.
    assert_eq!(circular_deviation_uncertainty(&[], &[], sigma), 0.0);
    assert_eq!(circular_deviation_uncertainty(&phi, &dr, 0.0), 0.0);
}

#[test]
fn the_uncertainty_of_g_matches_the_spread_of_repeated_circles() {
    let n = 36;
    let (phi, truth) = two_spikes(n);
    let sigma = 0.5e-6;
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2304);
    let (mut g, mut half_u) = (Vec::new(), Vec::new());
    for _ in 0..3000 {
        let dr: Vec<f64> = truth.iter().map(|t| t + noise.sample(&mut rng)).collect();
        g.push(circular_deviation(&phi, &dr).g);
        half_u.push(circular_deviation_uncertainty(&phi, &dr, sigma) / 2.0);
    }
    let mean = g.iter().sum::<f64>() / g.len() as f64;
    let spread = (g.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (g.len() - 1) as f64).sqrt();
    let ratio = half_u.iter().sum::<f64>() / half_u.len() as f64 / spread;
    assert!(
        (0.95..=1.05).contains(&ratio),
        "U/2 over the spread of G: {ratio}"
    );
}

#[test]
fn partial_arcs_and_degenerate_input() {
    // A 90° arc still fixes the centre.
    let phi: Vec<f64> = (0..=90).map(|k| (k as f64).to_radians()).collect();
    let dr: Vec<f64> = phi
        .iter()
        .map(|p| 4e-6 * p.cos() + 1e-6 * p.sin())
        .collect();
    let cd = circular_deviation(&phi, &dr);
    assert!(
        (cd.centre_a - 4e-6).abs() < 1e-15 && (cd.centre_b - 1e-6).abs() < 1e-15,
        "{cd:?}"
    );
    assert!(cd.g < 1e-15);
    // All at one angle: no centre, G is the spread.
    let cd = circular_deviation(&[0.3, 0.3, 0.3], &[1e-6, 3e-6, 2e-6]);
    assert_eq!((cd.centre_a, cd.centre_b), (0.0, 0.0));
    assert!((cd.g - 2e-6).abs() < 1e-18 && (cd.radius_offset - 2e-6).abs() < 1e-18);
    assert_eq!(circular_deviation(&[], &[]).g, 0.0);
}

#[test]
fn bidirectional_uses_the_common_centre() {
    // Both directions see the same 2e ellipse; a reversal error adds +h going ccw and −h going
    // cw, and each run has its own centre offset (servo lag shifts the centre each way).
    let (e, h) = (3e-6, 1.5e-6);
    let phi = angles(360);
    let mut cw_phi = phi.clone();
    cw_phi.reverse();
    let ccw: Vec<f64> = phi
        .iter()
        .map(|p| e * (2.0 * p).cos() + h + 2.0 * e * p.cos())
        .collect();
    let cw: Vec<f64> = cw_phi
        .iter()
        .map(|p| e * (2.0 * p).cos() - h - 2.0 * e * p.cos())
        .collect();
    let b = bidirectional_circular_deviation((&phi, &ccw), (&cw_phi, &cw));
    // Each run alone: its own centre removed, G = 2e.
    assert!(
        (b.ccw.g - 2.0 * e).abs() < 1e-15 && (b.cw.g - 2.0 * e).abs() < 1e-15,
        "{b:?}"
    );
    assert!((b.ccw.centre_a - 2.0 * e).abs() < 1e-16 && (b.cw.centre_a + 2.0 * e).abs() < 1e-16);
    // Together: the common centre is the mean (0), the common radius 0, so what remains is the
    // data. With c = cos φ, ccw reads e(2c² − 1) + 2ec + h, largest at c = 1: 3e + h; cw reads
    // e(2c² − 1) − 2ec − h, smallest where 4ec = 2e, c = 1/2 (φ = 60°, sampled): −3e/2 − h.
    assert!(
        b.both.centre_a.abs() < 1e-16 && b.both.radius_offset.abs() < 1e-16,
        "{b:?}"
    );
    assert!((b.both.g - (4.5 * e + 2.0 * h)).abs() < 1e-15, "{b:?}");
}

fn table(s: &str) -> toml::Table {
    toml::from_str(s).unwrap()
}

#[test]
fn setup_defaults_nuisance_and_round_trip() {
    let c = BallbarConfig::from_table(&table("pivot = [1, 2.5, 3]\nlength = 150")).unwrap();
    let s = BallbarSetup::new(c.clone());
    assert_eq!(s.channels().len(), 1);
    assert_eq!(s.channels()[0].name, "dr");
    assert_eq!(s.channels()[0].unit, Unit::Um);
    assert!((s.channels()[0].sigma - 1e-6).abs() < 1e-20);
    let names: Vec<_> = s.nuisance().iter().map(|n| n.name.as_str()).collect();
    assert_eq!(
        names,
        ["pivot_x", "pivot_y", "pivot_z", "length", "tool_length"]
    );
    let free: Vec<_> = s.nuisance().iter().map(|n| n.free).collect();
    assert_eq!(free, [true, true, true, false, true]);
    assert!(s.nuisance().iter().all(|n| n.unit == Unit::Um));
    let again = BallbarConfig::from_table(&s.to_toml()).unwrap();
    assert_eq!(again, c);

    let t = table(
        "pivot = [0.1, 0.2, 0.3]\nlength = 99.9\nsigma_um = 0.3\nlength_free = true\n\
         length_u_um = 1.5\npivot_free = false\ntool_length_free = false",
    );
    let c = BallbarConfig::from_table(&t).unwrap();
    let s = BallbarSetup::new(c.clone());
    let free: Vec<_> = s.nuisance().iter().map(|n| n.free).collect();
    assert_eq!(free, [false, false, false, true, false]);
    assert_eq!(s.nuisance()[3].prior_sigma, Some(1.5e-6));
    assert_eq!(BallbarConfig::from_table(&s.to_toml()).unwrap(), c);
    assert_eq!(s.to_toml(), t);
}

#[test]
fn setup_errors_name_the_key() {
    let check = |s: &str, key: &str| {
        let e = BallbarConfig::from_table(&table(s)).unwrap_err();
        assert_eq!(e.key, key, "{s}: {e}");
    };
    check("length = 100", "pivot");
    check("pivot = [0, 0, 0]", "length");
    check("pivot = [0, 0, 0]\nlength = -1", "length");
    check("pivot = [0, 0]\nlength = 100", "pivot");
    check("pivot = [0, 0, 0]\nlength = 100\nsigma_um = 0", "sigma_um");
    check(
        "pivot = [0, 0, 0]\nlength = 100\nlength_u_um = 1",
        "length_u_um",
    );
    check(
        "pivot = [0, 0, 0]\nlength = 100\nlength_free = true\nlength_u_um = -1",
        "length_u_um",
    );
    check(
        "pivot = [0, 0, 0]\nlength = 100\npivot_free = 1",
        "pivot_free",
    );
    check("pivot = [0, 0, 0]\nlength = 100\nball = [0, 0, 0]", "ball");
}

#[test]
fn registered_under_its_name() {
    let p = mtcal_instrument::find("ballbar").expect("registered");
    assert!(p.evaluate.is_some());
    let m = mtcal_machine::load_machine("ZFYX", mtcal_machine::topology::Reading::FromTool)
        .unwrap()
        .machine;
    let f = (p.fixture)(&m, 0).expect("a fixture on a three-axis machine");
    let ctx = mtcal_instrument::SetupContext { machine: &m };
    let s = (p.load_setup)(&f.setup, &ctx).unwrap();
    assert_eq!(s.nuisance().len(), 5);
}
