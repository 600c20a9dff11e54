//! ISO 230-4 evaluation of circular tests: least-squares centre removal and circular deviation.

use crate::path::Plane;
use crate::setup::{BallbarConfig, BallbarSetup};
use mtcal_instrument::{Evaluation, Metric, PolarView, Unit};
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::TAU;

/// The result of [`circular_deviation`]; all values in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CircularDeviation {
    /// Circular deviation G (ISO 230-4): max − min of the radial deviations after the
    /// least-squares centre and radius are removed.
    pub g: f64,
    /// Centre of the least-squares circle of the measured path relative to the pivot, along the
    /// plane's first axis (`cos φ` component of the readings).
    pub centre_a: f64,
    /// The same along the plane's second axis (`sin φ` component).
    pub centre_b: f64,
    /// Mean radius of the least-squares circle minus the nominal bar length.
    pub radius_offset: f64,
}

/// ISO 230-4 circular deviation of one run: `dr_m[i]` (m) is the bar length minus its nominal
/// length at commanded angle `angles_rad[i]`, so the radial deviation is `r_i = L + dr_i`. Fits
/// `dr_i ≈ R + a·cos φ_i + b·sin φ_i` by least squares (the linearised least-squares circle,
/// exact to first order in the deviations over the bar length), removes it and returns the
/// peak-to-valley `G` of what remains with the fitted `a`, `b`, `R`.
///
/// With fewer than three samples, or angles that do not fix a centre (all equal or opposite),
/// the centre is not fitted (`a = b = 0`) and `R` is the mean.
///
/// # Panics
/// If the slices differ in length.
pub fn circular_deviation(angles_rad: &[f64], dr_m: &[f64]) -> CircularDeviation {
    assert_eq!(angles_rad.len(), dr_m.len(), "one reading per angle");
    if angles_rad.is_empty() {
        return CircularDeviation {
            g: 0.0,
            centre_a: 0.0,
            centre_b: 0.0,
            radius_offset: 0.0,
        };
    }
    let circle = LeastSquaresCircle::fit(angles_rad, dr_m);
    let (lo, hi) = circle.extremes(angles_rad, dr_m);
    CircularDeviation {
        g: hi.1 - lo.1,
        centre_a: circle.fit[1],
        centre_b: circle.fit[2],
        radius_offset: circle.fit[0],
    }
}

/// The expanded uncertainty (k = 2) of the circular deviation G of [`circular_deviation`],
/// each reading having the independent noise `sigma_m` (m; the set-up's `sigma_um`).
///
/// G is the difference of two residuals `e_hi − e_lo` of the least-squares circle, so its
/// variance is `σ²·((1 − h_hh) + (1 − h_ll) + 2·h_hl)` with `h` the hat matrix of the circle
/// fit (`h_ab = x_aᵀ (XᵀX)⁻¹ x_b`, `x = (1, cos φ, sin φ)`; for a full circle of `n` evenly
/// spaced readings with the extremes opposite, `2 − 8/n`). One revolution has no repeated
/// readings, so the repeatability of the machine cannot be separated from its circular
/// deviation: σ is the only random term. Which two readings are the extremes is taken as found
/// (docs/ACCEPTANCE.md: where several are within the noise of the extreme, G is biased high).
///
/// # Panics
/// If the slices differ in length.
pub fn circular_deviation_uncertainty(angles_rad: &[f64], dr_m: &[f64], sigma_m: f64) -> f64 {
    assert_eq!(angles_rad.len(), dr_m.len(), "one reading per angle");
    if angles_rad.is_empty() {
        return 0.0;
    }
    let circle = LeastSquaresCircle::fit(angles_rad, dr_m);
    let ((lo, _), (hi, _)) = circle.extremes(angles_rad, dr_m);
    if lo == hi {
        // Every residual equal: G is zero whatever the noise moves them by together.
        return 0.0;
    }
    let h = |a: usize, b: usize| circle.hat(angles_rad, a, b);
    let variance = (1.0 - h(hi, hi)) + (1.0 - h(lo, lo)) + 2.0 * h(hi, lo);
    2.0 * sigma_m * variance.max(0.0).sqrt()
}

/// The linearised least-squares circle `dr ≈ R + a·cos φ + b·sin φ` of [`circular_deviation`].
struct LeastSquaresCircle {
    /// `(R, a, b)`.
    fit: Vector3<f64>,
    /// `(XᵀX)⁻¹` when the centre was fitted; `None` when only the mean was (too few or
    /// degenerate angles).
    inverse: Option<Matrix3<f64>>,
    n: usize,
}

impl LeastSquaresCircle {
    fn fit(angles_rad: &[f64], dr_m: &[f64]) -> Self {
        let mut ata = Matrix3::zeros();
        let mut atb = Vector3::zeros();
        for (&phi, &dr) in angles_rad.iter().zip(dr_m) {
            let row = Vector3::new(1.0, phi.cos(), phi.sin());
            ata += row * row.transpose();
            atb += row * dr;
        }
        let count = angles_rad.len();
        let n = count as f64;
        let cholesky = (count >= 3 && ata.determinant() > 1e-9 * n * n * n)
            .then(|| ata.cholesky())
            .flatten();
        match cholesky {
            Some(c) => Self {
                fit: c.solve(&atb),
                inverse: Some(c.inverse()),
                n: count,
            },
            None => Self {
                fit: Vector3::new(dr_m.iter().sum::<f64>() / n, 0.0, 0.0),
                inverse: None,
                n: count,
            },
        }
    }

    fn residual(&self, phi: f64, dr: f64) -> f64 {
        dr - self.fit[0] - self.fit[1] * phi.cos() - self.fit[2] * phi.sin()
    }

    /// The smallest and largest residual with their indices (the first on ties).
    fn extremes(&self, angles_rad: &[f64], dr_m: &[f64]) -> ((usize, f64), (usize, f64)) {
        let mut lo = (0, f64::INFINITY);
        let mut hi = (0, f64::NEG_INFINITY);
        for (k, (&phi, &dr)) in angles_rad.iter().zip(dr_m).enumerate() {
            let e = self.residual(phi, dr);
            if e < lo.1 {
                lo = (k, e);
            }
            if e > hi.1 {
                hi = (k, e);
            }
        }
        (lo, hi)
    }

    /// The hat matrix element `h_ab` of the fit.
    fn hat(&self, angles_rad: &[f64], a: usize, b: usize) -> f64 {
        match &self.inverse {
            Some(inv) => {
                let x = |k: usize| Vector3::new(1.0, angles_rad[k].cos(), angles_rad[k].sin());
                x(a).dot(&(inv * x(b)))
            }
            None => 1.0 / self.n as f64,
        }
    }
}

/// ISO 230-4 results of a bidirectional test (one counter-clockwise and one clockwise run).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bidirectional {
    /// Bidirectional circular deviation G(b): both runs about their common least-squares circle
    /// (centre and radius fitted to both), max over both − min over both. Its `centre_*` and
    /// `radius_offset` are that common circle's.
    pub both: CircularDeviation,
    /// The counter-clockwise run on its own.
    pub ccw: CircularDeviation,
    /// The clockwise run on its own.
    pub cw: CircularDeviation,
}

/// Bidirectional circular deviation from a counter-clockwise and a clockwise run, each given as
/// `(angles_rad, dr_m)` like [`circular_deviation`].
pub fn bidirectional_circular_deviation(
    ccw: (&[f64], &[f64]),
    cw: (&[f64], &[f64]),
) -> Bidirectional {
    let angles: Vec<f64> = ccw.0.iter().chain(cw.0).copied().collect();
    let dr: Vec<f64> = ccw.1.iter().chain(cw.1).copied().collect();
    Bidirectional {
        both: circular_deviation(&angles, &dr),
        ccw: circular_deviation(ccw.0, ccw.1),
        cw: circular_deviation(cw.0, cw.1),
    }
}

/// A run recognised as a circle about the pivot: its plane and the commanded angles.
#[derive(Clone, Debug, PartialEq)]
pub struct CircleRun {
    pub plane: Plane,
    /// Commanded angle of every sample, rad, unwrapped along the run.
    pub angles: Vec<f64>,
    /// Which samples ISO 230-4 evaluates: all but the overshoot arcs.
    pub evaluated: Vec<usize>,
}

/// Recognises a circle run from its commanded positions (SI, row-major `samples × axes`): every
/// nominal tool point lies in one coordinate plane through the pivot at the bar length from it
/// (within 10 µm, as positions in files may be rounded) and the angle changes along the run.
/// When the run turns through more than one revolution, the excess is taken as equal overshoot
/// arcs at both ends (the paths this crate writes) and left out of `evaluated`, as ISO 230-4
/// evaluates one revolution.
pub fn recognise_circle(
    machine: &mtcal_kinematics::Machine,
    config: &BallbarConfig,
    q: &[f64],
) -> Option<CircleRun> {
    let n_axes = machine.n_axes();
    if n_axes == 0 || q.len() % n_axes != 0 || q.len() / n_axes < 3 {
        return None;
    }
    let pivot = config.pivot();
    let length = config.length();
    let rel: Vec<Vector3<f64>> = q
        .chunks_exact(n_axes)
        .map(|qi| machine.tool_in_workpiece(qi).t - pivot)
        .collect();
    let tol = 1e-5;
    let plane = Plane::ALL.into_iter().find(|p| {
        let [i, j, k] = p.indices();
        rel.iter()
            .all(|d| d[k].abs() < tol && (d[i].hypot(d[j]) - length).abs() < tol)
    })?;
    let [i, j, _] = plane.indices();
    let mut angles: Vec<f64> = Vec::with_capacity(rel.len());
    for d in &rel {
        let raw = d[j].atan2(d[i]);
        let a = match angles.last() {
            Some(&prev) => prev + wrap_pi(raw - prev),
            None => raw,
        };
        angles.push(a);
    }
    let first = angles[0];
    let travel = angles.iter().map(|a| (a - first).abs()).fold(0.0, f64::max);
    if travel < 1e-3 {
        return None;
    }
    let excess = (travel - TAU).max(0.0);
    let keep = |a: f64| {
        let s = (a - first).abs();
        s >= excess / 2.0 - 1e-9 && s <= excess / 2.0 + TAU + 1e-9
    };
    let evaluated = (0..angles.len()).filter(|&k| keep(angles[k])).collect();
    Some(CircleRun {
        plane,
        angles,
        evaluated,
    })
}

fn wrap_pi(x: f64) -> f64 {
    let w = x.rem_euclid(TAU);
    if w > std::f64::consts::PI { w - TAU } else { w }
}

/// The plugin's `evaluate`: for a circle run, `circular deviation G (ISO 230-4)` with its
/// expanded uncertainty ([`circular_deviation_uncertainty`], the set-up's `sigma_um`), the
/// fitted centre offsets along the plane's two axes and the radius offset (all µm), each about
/// the circle's plane (`XY`, [`Metric::subject`]); for any other run (rotary tests, unreadable
/// set-up) nothing.
pub fn evaluate(ev: &Evaluation<'_>) -> Vec<Metric> {
    let Some(config) = ev.setup_as::<BallbarSetup>().map(BallbarSetup::config) else {
        return Vec::new();
    };
    let Some(run) = recognise_circle(ev.machine, config, ev.q) else {
        return Vec::new();
    };
    let n = run.angles.len();
    if n == 0 || ev.readings.len() % n != 0 {
        return Vec::new();
    }
    let channels = ev.readings.len() / n;
    let angles: Vec<f64> = run.evaluated.iter().map(|&k| run.angles[k]).collect();
    let dr: Vec<f64> = run
        .evaluated
        .iter()
        .map(|&k| ev.readings[k * channels])
        .collect();
    let cd = circular_deviation(&angles, &dr);
    let g_u95 = circular_deviation_uncertainty(&angles, &dr, config.sigma_um * 1e-6);
    let name = run.plane.name();
    let (a, b) = (&name[..1], &name[1..]);
    let um = |what: String, value: f64| Metric::new(what, value, Unit::Um).about(name);
    vec![
        um("circular deviation G (ISO 230-4)".into(), cd.g).with_u95(g_u95),
        um(
            format!("centre offset {a} (least-squares circle)"),
            cd.centre_a,
        ),
        um(
            format!("centre offset {b} (least-squares circle)"),
            cd.centre_b,
        ),
        um(
            "radius offset (least-squares circle)".into(),
            cd.radius_offset,
        ),
    ]
}

/// The plugin's `polar_view`: a circle run (as [`recognise_circle`] finds it) drawn on its
/// circle, the bar length change `dr` at each sample's commanded angle; any other run (rotary
/// tests, unreadable set-up) none.
pub fn polar_view(ev: &Evaluation<'_>) -> Option<PolarView> {
    let config = ev.setup_as::<BallbarSetup>()?.config();
    let circle = recognise_circle(ev.machine, config, ev.q)?;
    Some(PolarView {
        plane: circle.plane.name().to_string(),
        radius: config.length(),
        angles: circle.angles,
        channel: 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_instrument::{PathSpec, SetupContext};

    fn machine() -> mtcal_kinematics::Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../machines/mcv754-zfyx.urdf"
        );
        mtcal_machine::load_machine(path, mtcal_machine::topology::Reading::default())
            .unwrap()
            .machine
    }

    fn table(s: &str) -> toml::Table {
        toml::from_str(s).unwrap()
    }

    /// The view of the run `path` of the set-up `setup` on the three-axis machine.
    fn view(setup: &toml::Table, path: &toml::Table) -> Option<PolarView> {
        let m = machine();
        let loaded = crate::load_setup(setup, &SetupContext { machine: &m }).unwrap();
        let q: Vec<f64> = crate::path(&PathSpec {
            path,
            setup: &*loaded,
            machine: &m,
        })
        .unwrap()
        .concat();
        polar_view(&Evaluation {
            machine: &m,
            setup: &*loaded,
            q: &q,
            readings: &[],
            t: &[],
            labels: &[],
        })
    }

    #[test]
    fn a_circle_is_drawn_on_its_plane_at_its_angles() {
        let setup = table("pivot = [0.0, 0.0, 390.0]\nlength = 100.0");
        let path = table("kind = \"circle\"\nplane = \"YZ\"\nsamples = 37");
        let v = view(&setup, &path).expect("a circle");
        assert_eq!(v.plane, "YZ");
        assert_eq!(v.radius, 0.1);
        assert_eq!(v.channel, 0);
        assert_eq!(v.angles.len(), 37);
        // Counter-clockwise from 0 through one revolution, 10° apart.
        for (k, a) in v.angles.iter().enumerate() {
            assert!(
                (a - (k as f64 * 10.0).to_radians()).abs() < 1e-9,
                "{k}: {a}"
            );
        }
    }

    #[test]
    fn no_view_without_a_circle() {
        let setup = table("pivot = [0.0, 0.0, 390.0]\nlength = 100.0");
        let path = table("kind = \"circle\"\nplane = \"XY\"\nsamples = 37");
        let m = machine();
        let loaded = crate::load_setup(&setup, &SetupContext { machine: &m }).unwrap();
        let q: Vec<f64> = crate::path(&PathSpec {
            path: &path,
            setup: &*loaded,
            machine: &m,
        })
        .unwrap()
        .concat();
        let ev = |setup: &toml::Table, q: &[f64]| {
            let loaded = crate::load_setup(setup, &SetupContext { machine: &m }).unwrap();
            polar_view(&Evaluation {
                machine: &m,
                setup: &*loaded,
                q,
                readings: &[],
                t: &[],
                labels: &[],
            })
        };
        assert!(ev(&setup, &q).is_some());
        // A bar of another length: the positions are no circle about the pivot.
        assert_eq!(
            ev(&table("pivot = [0.0, 0.0, 390.0]\nlength = 150.0"), &q),
            None
        );
        // Two samples are no circle.
        assert_eq!(ev(&setup, &q[..2 * m.n_axes()]), None);
    }
}
