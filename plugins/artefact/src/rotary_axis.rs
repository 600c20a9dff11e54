//! A rotary axis' line from points measured on arcs: a target (ball, reflector, probed feature)
//! fixed to the body the axis turns traces a circle in a plane perpendicular to the axis, centred
//! on it. Fitting plane + circle to each target's arc gives the axis direction (the plane's
//! normal) and a point on it (the centre); several targets give the same line, which checks the
//! data. Against the nominal axis this is the location errors of ISO 230-1: for a C axis
//! (nominally along +Z through `(x₀, y₀)`) `EX0C, EY0C` where the line crosses the nominal
//! plane, `EA0C, EB0C` its tilts about X and Y ([`location_errors_z`]).
//!
//! # Method
//! [`fit_circle`]: the plane through the points' centroid with the normal of their smallest
//! singular value, the circle in that plane by the algebraic (Kåsa) fit, then Gauss–Newton on
//! the geometric residuals — per point the distance from the plane and the in-plane distance
//! from the circle — over centre (3), normal (2 angles) and radius. Noise-free points on an arc
//! are recovered exactly (to rounding). The covariance is `σ̂²·(JᵀJ)⁻¹` with
//! `σ̂² = SS / (2N − 6)` (the residual scatter), `J` by central differences. At least 4 points
//! (3 fix a circle; the fourth gives the scatter).
//!
//! [`combine`]: the line through several circles' centres along their (sign-aligned,
//! inverse-variance weighted) mean normal, with the spread of the normals and the centres'
//! distances from the line.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

/// A fitted circle in space.
#[derive(Clone, Debug)]
pub struct Circle {
    pub centre: Vector3<f64>,
    /// Unit normal of the circle's plane (sign: right-handed with the points' order).
    pub normal: Vector3<f64>,
    pub radius: f64,
    /// RMS of the geometric residuals (both kinds), from `SS / (2N − 6)`.
    pub sigma: f64,
    /// Covariance of the centre (3 × 3).
    pub centre_cov: Matrix3<f64>,
    /// Covariance of the normal's tilt (rad²) about two axes across it (2 × 2, as a 3 × 3 in
    /// space: `normal_cov · v` for a direction v across the normal).
    pub normal_cov: Matrix3<f64>,
    pub radius_sigma: f64,
    /// Largest geometric residual.
    pub max_residual: f64,
}

impl Circle {
    /// Standard uncertainty of the normal's direction (rad, RMS of the two tilts).
    pub fn normal_sigma(&self) -> f64 {
        (0.5 * self.normal_cov.trace()).sqrt()
    }
}

fn basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&a).normalize();
    let v = n.cross(&u);
    (u, v)
}

/// Residuals of points against (centre, normal, radius): per point the signed distance from
/// the plane and the in-plane distance from the circle.
fn residuals(points: &[Vector3<f64>], c: &Vector3<f64>, n: &Vector3<f64>, r: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(2 * points.len());
    for p in points {
        let d = p - c;
        let h = n.dot(&d);
        let inplane = (d - n * h).norm();
        out.push(h);
        out.push(inplane - r);
    }
    out
}

/// Parameters: centre (3), tilts (2) of the normal about the basis (u, v) of `n0`, radius.
fn unpack(
    x: &[f64],
    n0: &Vector3<f64>,
    u: &Vector3<f64>,
    v: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>, f64) {
    let c = Vector3::new(x[0], x[1], x[2]);
    let n = (n0 + u * x[3] + v * x[4]).normalize();
    (c, n, x[5])
}

/// Fits plane + circle to points on an arc (module docs). `None` with fewer than 4 points or
/// collinear ones.
pub fn fit_circle(points: &[Vector3<f64>]) -> Option<Circle> {
    let np = points.len();
    if np < 4 {
        return None;
    }
    let mean = points.iter().sum::<Vector3<f64>>() / np as f64;
    let mut m = DMatrix::zeros(np, 3);
    for (k, p) in points.iter().enumerate() {
        let d = p - mean;
        for c in 0..3 {
            m[(k, c)] = d[c];
        }
    }
    let svd = m.svd(false, true);
    let vt = svd.v_t?;
    let (imin, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let mut n0 = Vector3::new(vt[(imin, 0)], vt[(imin, 1)], vt[(imin, 2)]).normalize();
    // Orient the normal right-handed with the points' order.
    let turn: Vector3<f64> = points
        .windows(2)
        .map(|w| (w[0] - mean).cross(&(w[1] - mean)))
        .sum();
    if turn.dot(&n0) < 0.0 {
        n0 = -n0;
    }
    let (u, v) = basis(&n0);
    // Kåsa: x² + y² + D x + E y + F = 0 in the plane.
    let mut a = DMatrix::zeros(np, 3);
    let mut b = DVector::zeros(np);
    for (k, p) in points.iter().enumerate() {
        let d = p - mean;
        let (x, y) = (d.dot(&u), d.dot(&v));
        a[(k, 0)] = x;
        a[(k, 1)] = y;
        a[(k, 2)] = 1.0;
        b[k] = -(x * x + y * y);
    }
    let sol = a.svd(true, true).solve(&b, 1e-14).ok()?;
    let (cx, cy) = (-sol[0] / 2.0, -sol[1] / 2.0);
    let r0 = (cx * cx + cy * cy - sol[2]).max(0.0).sqrt();
    if !(r0.is_finite() && r0 > 0.0) {
        return None;
    }
    let c0 = mean + u * cx + v * cy;
    let mut x = vec![c0.x, c0.y, c0.z, 0.0, 0.0, r0];
    let scale = r0.max(1e-9);
    let jac = |x: &[f64]| {
        let mut j = DMatrix::zeros(2 * np, 6);
        for col in 0..6 {
            let h = if col == 3 || col == 4 {
                1e-7
            } else {
                1e-7 * scale
            };
            let mut xp = x.to_vec();
            let mut xm = x.to_vec();
            xp[col] += h;
            xm[col] -= h;
            let (cp, npl, rp) = unpack(&xp, &n0, &u, &v);
            let (cm, nm, rm) = unpack(&xm, &n0, &u, &v);
            let fp = residuals(points, &cp, &npl, rp);
            let fm = residuals(points, &cm, &nm, rm);
            for row in 0..2 * np {
                j[(row, col)] = (fp[row] - fm[row]) / (2.0 * h);
            }
        }
        j
    };
    for _ in 0..20 {
        let (c, n, r) = unpack(&x, &n0, &u, &v);
        let f = DVector::from_vec(residuals(points, &c, &n, r));
        let j = jac(&x);
        let step = j.svd(true, true).solve(&(-&f), 1e-14).ok()?;
        for (xi, s) in x.iter_mut().zip(step.iter()) {
            *xi += s;
        }
        if step.norm() < 1e-15 * scale {
            break;
        }
    }
    let (c, n, r) = unpack(&x, &n0, &u, &v);
    let f = residuals(points, &c, &n, r);
    let ss: f64 = f.iter().map(|e| e * e).sum();
    let dof = (2 * np).saturating_sub(6).max(1);
    let s2 = ss / dof as f64;
    let j = jac(&x);
    let cov = (j.transpose() * &j)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::from_element(6, 6, f64::NAN))
        * s2;
    let centre_cov = Matrix3::from_fn(|a, b| cov[(a, b)]);
    // The tilt components along u and v map to the normal's change u·t₃ + v·t₄.
    let mut normal_cov = Matrix3::zeros();
    for (i, ei) in [u, v].iter().enumerate() {
        for (k, ek) in [u, v].iter().enumerate() {
            normal_cov += ei * ek.transpose() * cov[(3 + i, 3 + k)];
        }
    }
    Some(Circle {
        centre: c,
        normal: n,
        radius: r,
        sigma: s2.sqrt(),
        centre_cov,
        normal_cov,
        radius_sigma: cov[(5, 5)].sqrt(),
        max_residual: f.iter().fold(0.0, |m, e| m.max(e.abs())),
    })
}

/// A rotary axis' line.
#[derive(Clone, Debug)]
pub struct AxisLine {
    /// A point on the line: the weighted mean of the circles' centres, moved along the direction
    /// so that it is the point of the line closest to the first circle's centre.
    pub point: Vector3<f64>,
    /// Unit direction (sign of the first circle's normal).
    pub direction: Vector3<f64>,
    /// Standard uncertainty of the direction (rad).
    pub direction_sigma: f64,
    /// Standard uncertainty of the line's position across it (RMS of the two components).
    pub point_sigma: f64,
    /// Largest angle between a circle's normal and the direction (rad).
    pub max_normal_angle: f64,
    /// Largest distance of a circle's centre from the line.
    pub max_centre_distance: f64,
}

impl AxisLine {
    /// Distance of point `p` from the line.
    pub fn distance(&self, p: &Vector3<f64>) -> f64 {
        let d = p - self.point;
        (d - self.direction * self.direction.dot(&d)).norm()
    }
    /// Angle (rad) between this line's direction and `other`'s, in [0, π/2] (sign-free).
    pub fn angle_to(&self, dir: &Vector3<f64>) -> f64 {
        let c = self.direction.dot(&dir.normalize()).abs().min(1.0);
        c.acos()
    }
    /// Shortest distance between this line and another (∞-safe for parallel lines).
    pub fn line_distance(&self, other: &AxisLine) -> f64 {
        let w = other.point - self.point;
        let n = self.direction.cross(&other.direction);
        if n.norm() < 1e-9 {
            self.distance(&other.point)
        } else {
            w.dot(&n).abs() / n.norm()
        }
    }
}

/// The axis line from several circles traced about it (module docs).
pub fn combine(circles: &[Circle]) -> Option<AxisLine> {
    let first = circles.first()?;
    let mut dir = Vector3::zeros();
    let mut wsum = 0.0;
    for c in circles {
        let w = 1.0 / c.normal_sigma().powi(2).max(1e-30);
        let n = if c.normal.dot(&first.normal) < 0.0 {
            -c.normal
        } else {
            c.normal
        };
        dir += n * w;
        wsum += w;
    }
    let dir = dir.normalize();
    let direction_sigma = (1.0 / wsum).sqrt();
    // Centres projected on the plane across the line; inverse-variance weights.
    let mut p = Vector3::zeros();
    let mut psum = 0.0;
    for c in circles {
        let w = 1.0 / (c.centre_cov.trace() / 3.0).max(1e-30);
        let d = c.centre - first.centre;
        p += (first.centre + d - dir * dir.dot(&d)) * w;
        psum += w;
    }
    let point = p / psum;
    let line = AxisLine {
        point,
        direction: dir,
        direction_sigma,
        point_sigma: (1.0 / psum).sqrt(),
        max_normal_angle: 0.0,
        max_centre_distance: 0.0,
    };
    let max_normal_angle = circles
        .iter()
        .map(|c| line.angle_to(&c.normal))
        .fold(0.0, f64::max);
    let max_centre_distance = circles
        .iter()
        .map(|c| line.distance(&c.centre))
        .fold(0.0, f64::max);
    Some(AxisLine {
        max_normal_angle,
        max_centre_distance,
        ..line
    })
}

/// Location errors of an axis nominally along +Z through `(x₀, y₀, z₀)`:
/// `[EX0C, EY0C, EA0C, EB0C]` — where the actual line crosses the plane `z = z₀` minus
/// `(x₀, y₀)`, and its tilts about X (`EA0C = −d_y/d_z`: a rotation about +X turns +Z towards
/// −Y) and about Y (`EB0C = d_x/d_z`). For an axis nominally along +X or +Y rotate the
/// coordinates first (A: `(y, z, x)`, B: `(z, x, y)`).
pub fn location_errors_z(line: &AxisLine, nominal: &Vector3<f64>) -> [f64; 4] {
    let d = if line.direction.z < 0.0 {
        -line.direction
    } else {
        line.direction
    };
    let s = (nominal.z - line.point.z) / d.z;
    let p = line.point + d * s;
    [p.x - nominal.x, p.y - nominal.y, -d.y / d.z, d.x / d.z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::rigid::axis_rotation;

    fn arc(
        centre: Vector3<f64>,
        axis: Vector3<f64>,
        radius: f64,
        start: Vector3<f64>,
        angles_deg: &[f64],
    ) -> Vec<Vector3<f64>> {
        let a = axis.normalize();
        let s = (start - a * a.dot(&start)).normalize() * radius + a * 0.013;
        angles_deg
            .iter()
            .map(|t| centre + axis_rotation(&a, t.to_radians()) * s)
            .collect()
    }

    #[test]
    fn noise_free_arcs_give_the_axis_exactly() {
        let axis = Vector3::new(0.01, -0.02, 1.0).normalize();
        let c = Vector3::new(0.3, -0.1, 0.5);
        let angles = [-60.0, -35.0, -10.0, 20.0, 45.0, 70.0];
        let mut circles = Vec::new();
        for (r, start) in [
            (0.2, Vector3::x()),
            (0.35, Vector3::new(0.3, 1.0, 0.2)),
            (0.1, -Vector3::y()),
        ] {
            let pts = arc(c, axis, r, start, &angles);
            let circ = fit_circle(&pts).expect("fit");
            assert!((circ.radius - r).abs() < 1e-12, "{}", circ.radius);
            assert!(circ.normal.cross(&axis).norm() < 1e-12);
            circles.push(circ);
        }
        let line = combine(&circles).unwrap();
        assert!(line.angle_to(&axis) < 1e-12);
        assert!(line.distance(&c) < 1e-12);
        let e = location_errors_z(&line, &Vector3::new(0.3, -0.1, 0.0));
        // Through (0.3, −0.1, 0.5) along (0.01, −0.02, 1): at z = 0 it is 0.5·(−0.01, 0.02) off.
        assert!(
            (e[0] + 0.005).abs() < 1e-12 && (e[1] - 0.01).abs() < 1e-12,
            "{e:?}"
        );
        assert!(
            (e[2] - 0.02).abs() < 1e-12 && (e[3] - 0.01).abs() < 1e-12,
            "{e:?}"
        );
    }

    #[test]
    fn noisy_arcs_lie_within_their_intervals() {
        // SplitMix-driven Gaussian noise; over many trials the centre's error must lie within
        // 2σ about 95 % of the time and the direction's within 2.5σ mostly.
        let mut state = 12345u64;
        let mut unif = || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let axis = Vector3::new(0.0, 0.05, 1.0).normalize();
        let c = Vector3::new(0.1, 0.2, 0.3);
        let angles: Vec<f64> = (0..12).map(|k| -80.0 + 15.0 * k as f64).collect();
        let sigma = 1e-5;
        let (mut inside_c, mut inside_n, trials) = (0, 0, 200);
        for _ in 0..trials {
            let mut pts = arc(c, axis, 0.25, Vector3::x(), &angles);
            for p in &mut pts {
                for k in 0..3 {
                    let (u1, u2) = (unif().max(1e-300), unif());
                    p[k] +=
                        sigma * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos();
                }
            }
            let circ = fit_circle(&pts).unwrap();
            // The arcs sit 13 mm up the axis from `c` (see `arc`).
            let d = circ.centre - (c + axis * 0.013);
            // Mahalanobis distance of the centre error (3 dof): χ²₃ 95 % = 7.81.
            let m = d.dot(&(circ.centre_cov.try_inverse().unwrap() * d));
            if m < 7.81 {
                inside_c += 1;
            }
            let ang = circ.normal.cross(&axis).norm();
            if ang < 2.45 * circ.normal_sigma() {
                inside_n += 1;
            }
        }
        let rate_c = inside_c as f64 / trials as f64;
        let rate_n = inside_n as f64 / trials as f64;
        assert!((0.85..=1.0).contains(&rate_c), "centre coverage {rate_c}");
        assert!((0.85..=1.0).contains(&rate_n), "normal coverage {rate_n}");
    }
}
