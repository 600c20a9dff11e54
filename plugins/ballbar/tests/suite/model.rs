//! The measurement model against analytic first-order signatures of classic errors, and its
//! derivatives against finite differences.

use mtcal_ballbar::{BallbarConfig, BallbarSetup, circular_deviation, nuis};
use mtcal_instrument::{At, Setup};
use mtcal_kinematics::Rigid;
use mtcal_kinematics::rigid::exp_so3;
use nalgebra::{Matrix3, Vector3};

const L: f64 = 0.15;

fn setup() -> BallbarSetup {
    let t: toml::Table = toml::from_str("pivot = [100.0, 50.0, 200.0]\nlength = 150.0").unwrap();
    BallbarSetup::new(BallbarConfig::from_table(&t).unwrap())
}

fn pivot() -> Vector3<f64> {
    Vector3::new(0.1, 0.05, 0.2)
}

/// 360 commanded angles, one per degree.
fn angles() -> Vec<f64> {
    (0..360).map(|k| (k as f64).to_radians()).collect()
}

/// The prediction for a tool ball at `ball` (tool axis +Z) and nuisance values `n`.
fn dr(s: &BallbarSetup, ball: Vector3<f64>, r: Matrix3<f64>, n: &[f64]) -> f64 {
    let pose = Rigid::new(r, ball);
    let q = [0.0; 3];
    let at = At {
        q: &q,
        t: 0.0,
        w_t_t: &pose,
        label: 0,
    };
    let mut out = [0.0];
    s.predict(&at, n, &mut out);
    out[0]
}

/// Readings for a tool ball whose position relative to the pivot is `rel(φ)` on each angle.
fn readings(rel: impl Fn(f64) -> Vector3<f64>, n: &[f64]) -> Vec<f64> {
    let s = setup();
    angles()
        .into_iter()
        .map(|phi| dr(&s, pivot() + rel(phi), Matrix3::identity(), n))
        .collect()
}

/// Asserts `got ≈ expected` to `rel` of the signature's amplitude `scale`.
fn assert_signature(got: &[f64], expected: impl Fn(f64) -> f64, scale: f64, rel: f64) {
    for (phi, g) in angles().into_iter().zip(got) {
        let e = expected(phi);
        assert!(
            (g - e).abs() <= rel * scale,
            "at {:.1}°: got {g:e}, expected {e:e}",
            phi.to_degrees()
        );
    }
}

#[test]
fn squareness_gives_a_two_lobed_signature() {
    // EC0Y = S: moving Y by y moves the tool by −S·y along X. About the pivot the ball sits at
    // L·(cos φ − S sin φ, sin φ), so |d| = L·√(1 − S sin 2φ + S² sin² φ) ≈ L − (L/2)·S·sin 2φ.
    let s = 50e-6;
    let got = readings(
        |phi| Vector3::new(L * (phi.cos() - s * phi.sin()), L * phi.sin(), 0.0),
        &[0.0; 5],
    );
    assert_signature(
        &got,
        |phi| -0.5 * L * s * (2.0 * phi).sin(),
        0.5 * L * s,
        1e-3,
    );
    // The signature's peak to valley is the circular deviation: L·S, no centre offset.
    let cd = circular_deviation(&angles(), &got);
    assert!((cd.g - L * s).abs() < 1e-3 * L * s, "{cd:?}");
    assert!(cd.centre_a.abs() < 1e-3 * L * s && cd.centre_b.abs() < 1e-3 * L * s);
}

#[test]
fn scale_errors_change_the_radius() {
    let eps = 20e-6;
    // The same scale on X and Y: the circle grows by L·ε at every angle (exactly).
    let both = readings(
        |phi| Vector3::new(phi.cos(), phi.sin(), 0.0) * L * (1.0 + eps),
        &[0.0; 5],
    );
    assert_signature(&both, |_| L * eps, L * eps, 1e-9);
    let cd = circular_deviation(&angles(), &both);
    assert!(
        cd.g < 1e-12 && (cd.radius_offset - L * eps).abs() < 1e-12,
        "{cd:?}"
    );
    // X alone: dr ≈ L·ε·cos² φ = (L ε / 2)(1 + cos 2φ): half the radius change plus an ellipse.
    let x_only = readings(
        |phi| Vector3::new(L * (1.0 + eps) * phi.cos(), L * phi.sin(), 0.0),
        &[0.0; 5],
    );
    assert_signature(
        &x_only,
        |phi| 0.5 * L * eps * (1.0 + (2.0 * phi).cos()),
        L * eps,
        1e-3,
    );
    let cd = circular_deviation(&angles(), &x_only);
    assert!((cd.g - L * eps).abs() < 1e-3 * L * eps, "{cd:?}");
    assert!(
        (cd.radius_offset - 0.5 * L * eps).abs() < 1e-3 * L * eps,
        "{cd:?}"
    );
}

#[test]
fn pivot_offset_gives_the_first_harmonic() {
    // The actual pivot off by c: |L u − c| ≈ L − c·u, so dr ≈ −(c_x cos φ + c_y sin φ); the
    // least-squares centre of the measured path relative to the pivot is −c.
    let (cx, cy) = (8e-6, -5e-6);
    let mut n = [0.0; 5];
    n[nuis::PIVOT_X] = cx;
    n[nuis::PIVOT_Y] = cy;
    n[nuis::PIVOT_Z] = 3e-6; // along the plane normal: second order only
    let got = readings(|phi| Vector3::new(phi.cos(), phi.sin(), 0.0) * L, &n);
    let amp = cx.hypot(cy);
    assert_signature(&got, |phi| -(cx * phi.cos() + cy * phi.sin()), amp, 1e-3);
    let cd = circular_deviation(&angles(), &got);
    assert!((cd.centre_a + cx).abs() < 1e-3 * amp && (cd.centre_b + cy).abs() < 1e-3 * amp);
    assert!(cd.g < 1e-3 * amp, "{cd:?}");
}

#[test]
fn bar_length_error_is_a_constant() {
    let mut n = [0.0; 5];
    n[nuis::LENGTH] = 4e-6;
    let got = readings(|phi| Vector3::new(phi.cos(), phi.sin(), 0.0) * L, &n);
    assert_signature(&got, |_| -4e-6, 4e-6, 1e-9);
}

#[test]
fn tool_length_moves_the_ball_along_the_tool_axis() {
    // Tool tilted so its axis has a component along the bar: a longer tool (δℓ) puts the ball
    // δℓ back along −ẑ_tool, which shortens the bar by δℓ·(n·ẑ_tool) to first order.
    let s = setup();
    let r = exp_so3(&Vector3::new(0.0, 0.4, 0.0));
    let ball = pivot() + Vector3::new(L, 0.0, 0.0);
    let mut n = [0.0; 5];
    n[nuis::TOOL_LENGTH] = 10e-6;
    let got = dr(&s, ball, r, &n);
    let expected = -10e-6 * r[(0, 2)];
    assert!(
        (got - expected).abs() < 1e-3 * expected.abs(),
        "{got:e} vs {expected:e}"
    );
}

#[test]
fn derivatives_match_finite_differences() {
    let s = setup();
    let n0 = [3e-6, -2e-6, 5e-6, 1e-6, 20e-3];
    for k in 0..12 {
        let phi = k as f64 * 0.7;
        let r = exp_so3(&Vector3::new(0.3 * phi.sin(), 0.5, 0.2 * phi.cos()));
        let pose = Rigid::new(r, pivot() + Vector3::new(phi.cos(), phi.sin(), 0.3) * 0.12);
        let q = [0.0; 3];
        let at = At {
            q: &q,
            t: 0.0,
            w_t_t: &pose,
            label: 0,
        };
        let (mut dp, mut dn) = ([0.0; 6], [0.0; 5]);
        assert!(s.derivatives(&at, &n0, &mut dp, &mut dn));
        let h = 1e-7;
        for j in 0..6 {
            let mut d = [0.0; 6];
            d[j] = h;
            let f = |sign: f64| {
                let dt = Vector3::new(d[0], d[1], d[2]) * sign;
                let dth = Vector3::new(d[3], d[4], d[5]) * sign;
                dr(&s, pose.t + dt, exp_so3(&dth) * pose.r, &n0)
            };
            let fd = (f(1.0) - f(-1.0)) / (2.0 * h);
            assert!((fd - dp[j]).abs() < 1e-7, "pose {j}: {fd} vs {}", dp[j]);
        }
        for j in 0..5 {
            let f = |sign: f64| {
                let mut n = n0;
                n[j] += sign * h;
                dr(&s, pose.t, pose.r, &n)
            };
            let fd = (f(1.0) - f(-1.0)) / (2.0 * h);
            assert!((fd - dn[j]).abs() < 1e-7, "nuisance {j}: {fd} vs {}", dn[j]);
        }
    }
}
