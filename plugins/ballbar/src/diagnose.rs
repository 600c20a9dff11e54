//! Ball-bar diagnostics in the terms ball-bar users read: backlash, lateral play, reversal
//! spikes, cyclic error, servo mismatch, squareness, straightness and scale mismatch per plane,
//! from a counter-clockwise and a clockwise circle of the same set-up.
//!
//! # Model
//! Each diagnostic has the shape it draws on the polar plot, derived from what it does to the
//! tool point relative to the pivot, the circle's coordinates `u_a = R·cos θ`, `u_b = R·sin θ`
//! in the plane's axes `a`, `b` (the workpiece frame, as the plot is drawn), `s = ±1` the
//! direction (counter-clockwise +1), `dr` the radial deviation:
//!
//! | diagnostic | displacement | `dr` template |
//! |---|---|---|
//! | backlash a± (µm) | `u_a` lags its command by half the lost motion | `s·sgn(sin θ)·cos θ / 2`, on the half of the circle about the `±a` reversal |
//! | lateral play a (µm) | `u_b` shifts by `±play/2` with the direction of `u_a` | `−s·\|sin θ\| / 2` |
//! | reversal spike a (µm) | `u_a` trails by `h·(1 + Δ/w)·e^{−Δ/w}` after a reversal, `Δ` the arc since it | that, outwards |
//! | cyclic error a (µm) | `u_a` is off by `A·sin(2π·u_a/p + φ)` | `cos θ · sin(…)`, the pitch `p` scanned |
//! | servo mismatch (ms) | `a` trails by `T_a·v`, `b` by `T_b·v`; value `T_a − T_b` | `s·R·ω·sin 2θ / 2` |
//! | squareness (µm/m) | moving `+b` also moves `+a` by `S` per unit | `R·sin 2θ / 2` |
//! | straightness a (µm) | `u_b` bows by `k·u_a²`; value `k·R²` (the ends against the middle) | `cos² θ · sin θ` |
//! | scale mismatch (ppm) | `u_a` scaled by `1 + ε_a`, `u_b` by `1 + ε_b`; value `ε_a − ε_b` | `R·cos 2θ / 2` |
//!
//! `b`'s templates follow by exchanging the roles (`lateral play b`: `+s·|cos θ|/2`,
//! `straightness b`: `sin² θ·cos θ`). Each run keeps its own centre and radius (a pivot that
//! settles, a bar that warms between the runs), as ISO 230-4 removes them. One direction alone
//! cannot tell squareness from servo mismatch nor lateral play from a radius change: only
//! pairs are diagnosed. The backlash templates assume the axis arrived at the run's first point
//! as the circle continued backwards would have brought it (the feed-in arc of the usual test).
//!
//! # Fit and uncertainty
//! One linear least-squares fit per pair of everything at once. The reversal spikes' recovery
//! arc `w` is chosen from a few multiples of the sample spacing by the residual; a cyclic error
//! is kept only where the best pitch of the scan stands out of the noise with family-wise
//! confidence over the pitches scanned. The residuals give σ and their lag-1 autocorrelation
//! `ρ` the inflation `(1 + ρ)/(1 − ρ)` of the coloured noise; a value is *determined* when it
//! exceeds `z·u` with `z` the normal quantile of family-wise 5 % over the pair's items. Every
//! value is then a fixed linear function of the readings (`Diagnosis::estimator`).

use crate::evaluate::{circular_deviation, recognise_circle};
use crate::path::Plane;
use crate::setup::BallbarSetup;
use mtcal_instrument::{Diagnosis, Diagnostic, Evaluation};
use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ContinuousCDF, Normal};
use std::f64::consts::{PI, TAU};

/// Family-wise false-alarm probability of the determination and the cyclic-error scan. 1 %
/// rather than 5 %: on the independent simulator's clean sessions (AR(1) noise, its colour
/// estimated from the residuals) 5 % gave a false claim in about one pair in ten, the noise
/// estimate's own scatter widening the tails.
const FAMILY_ALPHA: f64 = 0.01;
/// The spikes' recovery arcs tried, in sample spacings.
const SPIKE_WIDTHS: [f64; 4] = [0.5, 1.0, 2.0, 4.0];
/// The noise's lag-1 correlation is taken as at most this.
const MAX_RHO: f64 = 0.95;
/// A cyclic error's direction-dependent part may be at most this share of its common part.
const CYCLIC_SPREAD: f64 = 0.5;
/// The longest recovery arc a reversal spike is given, degrees.
const MAX_SPIKE_ARC_DEG: f64 = 4.0;
/// A reversal spike's template ends this many recovery arcs after the reversal.
const SPIKE_REACH: f64 = 8.0;

/// The plugin's `diagnose`: every counter-clockwise circle paired with a clockwise one of the
/// same set-up, plane and held axes (in the order given), each pair diagnosed.
pub fn diagnose(evs: &[Evaluation<'_>]) -> Vec<Diagnosis> {
    let circles: Vec<Circle> = evs
        .iter()
        .enumerate()
        .filter_map(|(k, ev)| Circle::of(k, ev))
        .collect();
    let mut used = vec![false; circles.len()];
    let mut out = Vec::new();
    for i in 0..circles.len() {
        if used[i] || circles[i].s < 0.0 {
            continue;
        }
        let partner = (0..circles.len())
            .find(|&j| !used[j] && circles[j].s < 0.0 && circles[j].key == circles[i].key);
        let Some(j) = partner else { continue };
        used[i] = true;
        used[j] = true;
        out.push(diagnose_pair(&circles[i], &circles[j]));
    }
    out
}

/// One circle run as the diagnosis reads it.
#[derive(Clone)]
struct Circle {
    /// Index among the evaluations.
    run: usize,
    plane: Plane,
    /// +1 counter-clockwise, −1 clockwise.
    s: f64,
    radius: f64,
    /// The evaluated samples (overshoot arcs left out) and their angles, rad.
    samples: Vec<usize>,
    angles: Vec<f64>,
    dr: Vec<f64>,
    /// Samples in the run.
    len: usize,
    /// The angle of the run's first evaluated sample along the travel, `s·θ`.
    start: f64,
    /// Angular speed, rad/s, when the run's times give one.
    omega: Option<f64>,
    /// Set-up, plane and held axes: runs with the same key form pairs.
    key: String,
}

impl Circle {
    fn of(run: usize, ev: &Evaluation<'_>) -> Option<Circle> {
        let config = ev.setup_as::<BallbarSetup>()?.config();
        let circle = recognise_circle(ev.machine, config, ev.q)?;
        let len = circle.angles.len();
        if len == 0 || ev.readings.len() % len != 0 {
            return None;
        }
        let channels = ev.readings.len() / len;
        let samples = circle.evaluated.clone();
        let angles: Vec<f64> = samples.iter().map(|&k| circle.angles[k]).collect();
        let travel = angles.last()? - angles.first()?;
        // A full revolution (within a sample), or the templates lose their meaning.
        if travel.abs() < TAU * 0.99 {
            return None;
        }
        let s = travel.signum();
        let dr = samples.iter().map(|&k| ev.readings[k * channels]).collect();
        let omega = (ev.t.len() == len)
            .then(|| {
                let dt = ev.t[*samples.last()?] - ev.t[samples[0]];
                (dt > 0.0).then(|| travel.abs() / dt)
            })
            .flatten();
        let n_axes = ev.machine.n_axes();
        let held: Vec<String> = (0..n_axes)
            .map(|a| {
                let v: Vec<f64> = ev.q.iter().skip(a).step_by(n_axes).copied().collect();
                let (lo, hi) = v
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| {
                        (l.min(x), h.max(x))
                    });
                if hi - lo < 1e-9 {
                    format!("{lo:.6}")
                } else {
                    "*".into()
                }
            })
            .collect();
        Some(Circle {
            run,
            plane: circle.plane,
            s,
            radius: config.length(),
            start: s * angles[0],
            samples,
            angles,
            dr,
            len,
            omega,
            key: format!("{config:?}|{}|{}", circle.plane.name(), held.join(",")),
        })
    }
}

/// What a column of the design is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    /// Run `k`'s radius, centre along a, centre along b.
    Radius(usize),
    CentreA(usize),
    CentreB(usize),
    /// `+` (true) or `−` end of axis a (0) or b (1).
    Backlash(usize, bool),
    LateralPlay(usize),
    /// Recovery arc, rad.
    Spike(usize, f64),
    /// A spike of axis a (0) or b (1) at run `k`'s first sample, which stands at the axis'
    /// turning point: how the axis arrived there is not in the file (a nuisance).
    StartSpike(usize, usize, f64),
    /// The direction-dependent part of a cyclic error (`s` times the cyclic shape): a screw's
    /// error depends on the position only, so a real one has none.
    CyclicSpread(usize, f64, bool),
    /// Frequency 1/m; the sine (false) or cosine (true) part.
    Cyclic(usize, f64, bool),
    ServoMismatch,
    Squareness,
    Straightness(usize),
    ScaleMismatch,
}

/// The value of `shape` at angle `theta` of a circle (`k` its index in the pair).
fn template(shape: Shape, c: &Circle, k: usize, theta: f64) -> f64 {
    let (sin, cos) = theta.sin_cos();
    let r = c.radius;
    // The sign of sin θ or cos θ as the motion had it just before θ: at a turning point the
    // axis still lags as it did arriving there (the step comes after it).
    let before = theta - c.s * 1e-6;
    let (sin_before, cos_before) = before.sin_cos();
    let own = |run: usize, v: f64| if run == k { v } else { 0.0 };
    match shape {
        Shape::Radius(run) => own(run, 1.0),
        Shape::CentreA(run) => own(run, cos),
        Shape::CentreB(run) => own(run, sin),
        Shape::Backlash(0, plus) => {
            let side = if plus { cos > 0.0 } else { cos < 0.0 };
            if side {
                c.s * sin_before.signum() * cos / 2.0
            } else {
                0.0
            }
        }
        Shape::Backlash(_, plus) => {
            let side = if plus { sin > 0.0 } else { sin < 0.0 };
            if side {
                -c.s * cos_before.signum() * sin / 2.0
            } else {
                0.0
            }
        }
        Shape::LateralPlay(0) => -c.s * sin.abs() / 2.0,
        Shape::LateralPlay(_) => c.s * cos.abs() / 2.0,
        Shape::Spike(axis, width) => spike(c, axis, width, theta),
        Shape::StartSpike(run, axis, width) => own(run, start_spike(c, axis, width, theta)),
        Shape::CyclicSpread(axis, f, cosine) => {
            c.s * template(Shape::Cyclic(axis, f, cosine), c, k, theta)
        }
        Shape::Cyclic(axis, f, cosine) => {
            let (u, along) = if axis == 0 {
                (r * cos, cos)
            } else {
                (r * sin, sin)
            };
            let phase = TAU * f * u;
            along * if cosine { phase.cos() } else { phase.sin() }
        }
        Shape::ServoMismatch => c.s * r * c.omega.unwrap_or(0.0) * (2.0 * theta).sin() / 2.0,
        Shape::Squareness => r * (2.0 * theta).sin() / 2.0,
        Shape::Straightness(0) => cos * cos * sin,
        Shape::Straightness(_) => sin * sin * cos,
        Shape::ScaleMismatch => r * (2.0 * theta).cos() / 2.0,
    }
}

/// A reversal spike of axis a (0: reversals at θ = kπ) or b (1: θ = π/2 + kπ) at `theta`: the
/// axis trails its new motion, outwards, by `(1 + Δ/w)·e^{−Δ/w}` with `Δ` the arc travelled
/// since the last reversal inside the run.
fn spike(c: &Circle, axis: usize, width: f64, theta: f64) -> f64 {
    let offset = if axis == 0 { 0.0 } else { PI / 2.0 };
    let psi = c.s * theta;
    let since = (psi - c.s * offset).rem_euclid(PI);
    // A sample at the turning point itself, whichever side the rounding put it.
    let since = if PI - since < 1e-9 { 0.0 } else { since };
    let at = psi - since;
    // The sample at the turning point itself still moves the old way: the spike comes after.
    if since < 1e-9 || at <= c.start + 1e-9 || since > SPIKE_REACH * width {
        return 0.0;
    }
    spike_after(axis, c.s * at, theta, since / width)
}

/// The spike of axis a (0) or b (1) at `theta`, `u` recovery arcs after its reversal at
/// `theta_r`: after the reversal the coordinate moves back from its extreme, so a trailing
/// axis stands outwards, `cos θ_r·cos θ` (a) or `sin θ_r·sin θ` (b) along the bar.
fn spike_after(axis: usize, theta_r: f64, theta: f64, u: f64) -> f64 {
    let outward = if axis == 0 {
        theta_r.cos() * theta.cos()
    } else {
        theta_r.sin() * theta.sin()
    };
    (1.0 + u) * (-u).exp() * outward
}

/// Whether run `c` starts at a turning point of axis a (0) or b (1).
fn starts_at_reversal(c: &Circle, axis: usize) -> bool {
    let offset = if axis == 0 { 0.0 } else { PI / 2.0 };
    let since = (c.start - c.s * offset).rem_euclid(PI);
    since < 1e-6 || PI - since < 1e-6
}

/// [`spike`] from the run's first sample, for a run that starts at the axis' turning point.
fn start_spike(c: &Circle, axis: usize, width: f64, theta: f64) -> f64 {
    let since = c.s * theta - c.start;
    if !starts_at_reversal(c, axis) || since < 1e-9 || since > SPIKE_REACH * width {
        return 0.0;
    }
    spike_after(axis, c.s * c.start, theta, since / width)
}

/// A diagnostic item of the report and the design columns it reads.
struct Item {
    name: String,
    about: String,
    unit: &'static str,
    per_si: f64,
    /// Column and weight: the value is `Σ weight·coefficient` (one column; a cyclic error's
    /// two, along its fitted phase).
    columns: Vec<(usize, f64)>,
}

/// The linear least-squares fit of a pair's readings on `shapes`.
struct PairFit {
    coef: DVector<f64>,
    /// `(XᵀX)⁻¹`.
    inverse: DMatrix<f64>,
    rss: f64,
    residuals: Vec<f64>,
}

fn design(pair: [&Circle; 2], shapes: &[Shape]) -> DMatrix<f64> {
    let rows: usize = pair.iter().map(|c| c.angles.len()).sum();
    let mut x = DMatrix::zeros(rows, shapes.len());
    let mut row = 0;
    for (k, c) in pair.iter().enumerate() {
        for &theta in &c.angles {
            for (j, &shape) in shapes.iter().enumerate() {
                x[(row, j)] = template(shape, c, k, theta);
            }
            row += 1;
        }
    }
    x
}

fn fit(pair: [&Circle; 2], shapes: &[Shape]) -> Option<PairFit> {
    let x = design(pair, shapes);
    let y = DVector::from_iterator(x.nrows(), pair.iter().flat_map(|c| c.dr.iter().copied()));
    // Columns scaled to unit norm for the factorisation, the scale undone after.
    let norms: Vec<f64> = (0..x.ncols())
        .map(|j| x.column(j).norm().max(1e-300))
        .collect();
    let mut xs = x.clone();
    for (j, n) in norms.iter().enumerate() {
        xs.column_mut(j).scale_mut(1.0 / n);
    }
    let xtx = xs.transpose() * &xs;
    let chol = xtx.clone().cholesky()?;
    // A column the others (nearly) reproduce leaves the fit undetermined.
    let eig = xtx.symmetric_eigenvalues();
    let (lo, hi) = eig
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &e| (l.min(e), h.max(e)));
    if lo <= hi * 1e-10 {
        return None;
    }
    let mut inverse = chol.inverse();
    let mut coef = chol.solve(&(xs.transpose() * &y));
    for a in 0..norms.len() {
        coef[a] /= norms[a];
        for b in 0..norms.len() {
            inverse[(a, b)] /= norms[a] * norms[b];
        }
    }
    let resid = &y - &x * &coef;
    Some(PairFit {
        rss: resid.norm_squared(),
        residuals: resid.iter().copied().collect(),
        coef,
        inverse,
    })
}

/// The readings' noise as AR(1) within each run: marginal variance and lag-1 correlation.
struct Noise {
    variance: f64,
    rho: f64,
}

/// Run lengths of the pair's rows (the blocks of the noise's covariance).
fn blocks(pair: [&Circle; 2]) -> [usize; 2] {
    [pair[0].angles.len(), pair[1].angles.len()]
}

/// `Σ(ρ)·v` for the block-diagonal AR(1) correlation `Σ_ij = ρ^|i−j|` within each block.
fn ar1_apply(blocks: [usize; 2], rho: f64, v: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; v.len()];
    let mut start = 0;
    for n in blocks {
        let b = &v[start..start + n];
        let mut forward = vec![0.0; n];
        let mut acc = 0.0;
        for i in 0..n {
            acc = b[i] + rho * acc;
            forward[i] = acc;
        }
        acc = 0.0;
        for i in (0..n).rev() {
            acc = b[i] + rho * acc;
            out[start + i] = forward[i] + acc - b[i];
        }
        start += n;
    }
    out
}

/// `D·v`, `D` the lag-1 neighbour matrix within each block (`vᵀDv = 2·Σ v_i·v_(i+1)`).
fn lag1_apply(blocks: [usize; 2], v: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; v.len()];
    let mut start = 0;
    for n in blocks {
        for i in 0..n {
            let prev = if i > 0 { v[start + i - 1] } else { 0.0 };
            let next = if i + 1 < n { v[start + i + 1] } else { 0.0 };
            out[start + i] = prev + next;
        }
        start += n;
    }
    out
}

fn columns_apply(x: &DMatrix<f64>, f: impl Fn(&[f64]) -> Vec<f64>) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(x.nrows(), x.ncols());
    for j in 0..x.ncols() {
        let col: Vec<f64> = x.column(j).iter().copied().collect();
        out.column_mut(j).copy_from_slice(&f(&col));
    }
    out
}

/// The noise from the fit's residuals, by the method of moments with the regression's own
/// finite-sample effect: residuals are `e = M·ε` (`M = I − X(XᵀX)⁻¹Xᵀ`), so their lag-1
/// correlation is biased towards zero (a fit with many columns takes up part of the colour);
/// `ρ` is the value at which `E[eᵀDe]/(2·E[eᵀe]) = tr(MDMΣ)/(2·tr(MΣ))` equals the observed
/// ratio, and `σ² = eᵀe/tr(MΣ)`.
fn noise(pair: [&Circle; 2], x: &DMatrix<f64>, fit: &PairFit) -> Noise {
    let blocks = blocks(pair);
    let e = &fit.residuals;
    let lag0: f64 = e.iter().map(|v| v * v).sum();
    let de = lag1_apply(blocks, e);
    let lag1: f64 = e.iter().zip(&de).map(|(a, b)| a * b).sum::<f64>() / 2.0;
    let observed = if lag0 > 0.0 { lag1 / lag0 } else { 0.0 };
    let a_inv = &fit.inverse;
    let r = columns_apply(x, |c| lag1_apply(blocks, c));
    let k = x.transpose() * &r;
    // (expected lag-1 ratio, tr(MΣ)) at ρ.
    let moments = |rho: f64| {
        let q = columns_apply(x, |c| ar1_apply(blocks, rho, c));
        let g = x.transpose() * &q;
        let n: usize = blocks.iter().sum();
        let tr_d_sigma: f64 = blocks
            .iter()
            .map(|&b| 2.0 * (b.max(1) - 1) as f64 * rho)
            .sum();
        let tr_ai_qr = (a_inv * (q.transpose() * &r)).trace();
        let tr_ai_g_ai_k = (a_inv * &g * a_inv * &k).trace();
        let numerator = tr_d_sigma - 2.0 * tr_ai_qr + tr_ai_g_ai_k;
        let denominator = n as f64 - (a_inv * &g).trace();
        (numerator / (2.0 * denominator), denominator)
    };
    let (mut lo, mut hi) = (0.0, MAX_RHO);
    let rho = if moments(lo).0 >= observed {
        0.0
    } else if moments(hi).0 <= observed {
        MAX_RHO
    } else {
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if moments(mid).0 < observed {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let (_, trace) = moments(rho);
    Noise {
        variance: lag0 / trace.max(1.0),
        rho,
    }
}

/// The covariance of the fitted coefficients under `noise`: `A⁻¹·XᵀΣX·A⁻¹·σ²`.
fn coefficient_covariance(
    pair: [&Circle; 2],
    x: &DMatrix<f64>,
    fit: &PairFit,
    noise: &Noise,
) -> DMatrix<f64> {
    let q = columns_apply(x, |c| ar1_apply(blocks(pair), noise.rho, c));
    let g = x.transpose() * q;
    &fit.inverse * g * &fit.inverse * noise.variance
}

/// The pair with the second-order part of each run's centring removed from its readings.
///
/// A pivot off by `d` in the plane changes the bar length by `−d·u + |d × u|²/(2R)` (`u` the
/// bar's direction): the linear part is the fitted centre, the quadratic one draws an
/// ellipse (`cos 2θ`, `sin 2θ`) that would pass for a scale mismatch or a squareness — a
/// pivot 0.2 mm off on a 150 mm bar draws 0.07 µm of it.
fn centred(pair: [&Circle; 2], shapes: &[Shape]) -> [Circle; 2] {
    let mut out = [pair[0].clone(), pair[1].clone()];
    let Some(first) = fit(pair, shapes) else {
        return out;
    };
    for (k, c) in out.iter_mut().enumerate() {
        let coef = |want: Shape| {
            shapes
                .iter()
                .position(|&s| s == want)
                .map_or(0.0, |j| first.coef[j])
        };
        let (ca, cb) = (coef(Shape::CentreA(k)), coef(Shape::CentreB(k)));
        for (dr, &theta) in c.dr.iter_mut().zip(&c.angles) {
            let (sin, cos) = theta.sin_cos();
            *dr -= (ca * sin - cb * cos).powi(2) / (2.0 * c.radius);
        }
    }
    out
}

fn diagnose_pair(ccw: &Circle, cw: &Circle) -> Diagnosis {
    let pair = [ccw, cw];
    let name = ccw.plane.name();
    let letters = [&name[..1], &name[1..]];
    let mut notes = Vec::new();
    let mut shapes: Vec<Shape> = (0..2)
        .flat_map(|k| [Shape::Radius(k), Shape::CentreA(k), Shape::CentreB(k)])
        .collect();
    for axis in 0..2 {
        shapes.push(Shape::Backlash(axis, true));
        shapes.push(Shape::Backlash(axis, false));
    }
    shapes.extend([Shape::LateralPlay(0), Shape::LateralPlay(1)]);
    if ccw.omega.is_some() && cw.omega.is_some() {
        shapes.push(Shape::ServoMismatch);
    } else {
        notes.push("servo mismatch: the runs carry no times to give the feed".to_string());
    }
    shapes.extend([
        Shape::Squareness,
        Shape::Straightness(0),
        Shape::Straightness(1),
        Shape::ScaleMismatch,
    ]);
    let corrected = centred(pair, &shapes);
    let pair = [&corrected[0], &corrected[1]];
    let (ccw, cw) = (pair[0], pair[1]);
    // The spikes' recovery arc: the one that fits best.
    let spacing = pair
        .iter()
        .flat_map(|c| c.angles.windows(2).map(|w| (w[1] - w[0]).abs()))
        .fold(0.0, f64::max);
    // A bump that recovers over more than a few degrees is no spike: it would take up the
    // backlash's step on sparse circles.
    let best_width = SPIKE_WIDTHS
        .iter()
        .map(|m| m * spacing)
        .filter(|&w| w <= MAX_SPIKE_ARC_DEG.to_radians() || w <= spacing)
        .filter_map(|w| {
            let mut with = shapes.clone();
            with.extend(spike_shapes(pair, w));
            fit(pair, &with).map(|f| (w, f.rss))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(w, _)| w);
    if let Some(w) = best_width {
        shapes.extend(spike_shapes(pair, w));
    }
    for (axis, letter) in letters.iter().enumerate() {
        match scan_cyclic(pair, &shapes, axis, spacing) {
            Ok(Some(f)) => {
                shapes.extend([Shape::Cyclic(axis, f, false), Shape::Cyclic(axis, f, true)])
            }
            Ok(None) => {}
            Err(why) => notes.push(format!("cyclic error {letter}: {why}")),
        }
    }
    let circularity = pair
        .iter()
        .map(|c| circular_deviation(&c.angles, &c.dr).g)
        .fold(0.0, f64::max);
    let Some(fitted) = fit(pair, &shapes) else {
        notes.push("the pair's diagnostics cannot be told apart on these circles".into());
        return Diagnosis {
            subject: name.to_string(),
            runs: vec![ccw.run, cw.run],
            channel: 0,
            circularity,
            items: Vec::new(),
            estimator: vec![Vec::new(), Vec::new()],
            notes,
        };
    };
    let items = items(&shapes, &fitted, letters);
    let z = Normal::standard().inverse_cdf(1.0 - FAMILY_ALPHA / (2.0 * items.len() as f64));
    let x = design(pair, &shapes);
    let covariance = coefficient_covariance(pair, &x, &fitted, &noise(pair, &x, &fitted));
    // Rows of (XᵀX)⁻¹Xᵀ: the coefficients as linear functions of the readings.
    let hat = &fitted.inverse * x.transpose();
    let mut estimator = vec![
        vec![0.0; items.len() * ccw.len],
        vec![0.0; items.len() * cw.len],
    ];
    let mut diagnostics = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let value: f64 = item.columns.iter().map(|&(j, w)| w * fitted.coef[j]).sum();
        let var: f64 = item
            .columns
            .iter()
            .flat_map(|&(a, wa)| item.columns.iter().map(move |&(b, wb)| (a, wa, b, wb)))
            .map(|(a, wa, b, wb)| wa * wb * covariance[(a, b)])
            .sum::<f64>();
        let u = var.max(0.0).sqrt();
        let mut row = 0;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (k, c) in pair.iter().enumerate() {
            for &sample in &c.samples {
                let e: f64 = item.columns.iter().map(|&(j, w)| w * hat[(j, row)]).sum();
                estimator[k][i * c.len + sample] = e;
                let drawn: f64 = item
                    .columns
                    .iter()
                    .map(|&(j, w)| w * fitted.coef[j] * x[(row, j)])
                    .sum();
                lo = lo.min(drawn);
                hi = hi.max(drawn);
                row += 1;
            }
        }
        diagnostics.push(Diagnostic {
            name: item.name.clone(),
            about: item.about.clone(),
            value,
            u95: 1.96 * u,
            determined: value.abs() > z * u,
            contribution: hi - lo,
            unit: item.unit,
            per_si: item.per_si,
        });
    }
    Diagnosis {
        subject: name.to_string(),
        runs: vec![ccw.run, cw.run],
        channel: 0,
        circularity,
        items: diagnostics,
        estimator,
        notes,
    }
}

/// The reversal spikes' columns at recovery arc `w`: the two axes' spikes, and a nuisance
/// spike for every run that starts at an axis' turning point.
fn spike_shapes(pair: [&Circle; 2], w: f64) -> Vec<Shape> {
    let mut out = vec![Shape::Spike(0, w), Shape::Spike(1, w)];
    for (k, c) in pair.iter().enumerate() {
        for axis in 0..2 {
            if starts_at_reversal(c, axis) {
                out.push(Shape::StartSpike(k, axis, w));
            }
        }
    }
    out
}

/// The report's items of a fit on `shapes`.
fn items(shapes: &[Shape], fitted: &PairFit, letters: [&str; 2]) -> Vec<Item> {
    let mut out = Vec::new();
    let one = |name: String, about: String, unit, per_si, j| Item {
        name,
        about,
        unit,
        per_si,
        columns: vec![(j, 1.0)],
    };
    for (j, &shape) in shapes.iter().enumerate() {
        let (a, b) = match shape {
            Shape::Backlash(axis, _)
            | Shape::LateralPlay(axis)
            | Shape::Spike(axis, _)
            | Shape::Straightness(axis)
            | Shape::Cyclic(axis, _, _) => (letters[axis], letters[1 - axis]),
            _ => (letters[0], letters[1]),
        };
        let item = match shape {
            Shape::Radius(_)
            | Shape::CentreA(_)
            | Shape::CentreB(_)
            | Shape::StartSpike(..)
            | Shape::CyclicSpread(..) => None,
            Shape::Backlash(_, plus) => {
                let end = if plus { "+" } else { "−" };
                Some(one(
                    format!("backlash {a}{end}"),
                    format!(
                        "the step at the reversal of {a} at its {end} end: the lost motion there (positive: the axis lags its command)"
                    ),
                    "um",
                    1e6,
                    j,
                ))
            }
            Shape::LateralPlay(_) => Some(one(
                format!("lateral play {a}"),
                format!(
                    "the shift along {b} between moving {a}+ and {a}− (positive: towards +{b} when moving +{a})"
                ),
                "um",
                1e6,
                j,
            )),
            Shape::Spike(_, w) => Some(one(
                format!("reversal spike {a}"),
                format!(
                    "the height of the bump after each reversal of {a}, recovering over {:.1}° of arc (positive: the axis trails, outwards)",
                    w.to_degrees()
                ),
                "um",
                1e6,
                j,
            )),
            Shape::Cyclic(_, f, false) => {
                let (s, c) = (fitted.coef[j], fitted.coef[j + 1]);
                let amplitude = s.hypot(c);
                let (ws, wc) = if amplitude > 0.0 {
                    (s / amplitude, c / amplitude)
                } else {
                    (1.0, 0.0)
                };
                Some(Item {
                    name: format!("cyclic error {a} (pitch {:.2} mm)", 1e3 / f),
                    about: format!(
                        "the amplitude of the periodic error of {a} at the pitch that stands out of the noise (its phase as fitted)"
                    ),
                    unit: "um",
                    per_si: 1e6,
                    columns: vec![(j, ws), (j + 1, wc)],
                })
            }
            Shape::Cyclic(_, _, true) => None,
            Shape::ServoMismatch => Some(one(
                "servo mismatch".into(),
                format!(
                    "how much longer {a} trails its command than {b} (positive: {a} lags more), from the feed of the runs"
                ),
                "ms",
                1e3,
                j,
            )),
            Shape::Squareness => Some(one(
                "squareness".into(),
                format!(
                    "how far moving +{b} also moves +{a}, per metre (positive: the angle between +{a} and +{b} is less than 90°)"
                ),
                "um/m",
                1e6,
                j,
            )),
            Shape::Straightness(_) => Some(one(
                format!("straightness {a}"),
                format!(
                    "the bow of {a}'s motion along {b} at ±R against its middle (positive: the ends towards +{b})"
                ),
                "um",
                1e6,
                j,
            )),
            Shape::ScaleMismatch => Some(one(
                "scale mismatch".into(),
                format!(
                    "{a}'s scale error minus {b}'s (positive: {a} travels further than {b} for the same command)"
                ),
                "ppm",
                1e6,
                j,
            )),
        };
        out.extend(item);
    }
    out
}

/// The pitch of a cyclic error of `axis` (frequency, 1/m) that stands out of the noise over
/// the scan with family-wise confidence, given the other `shapes`; `Ok(None)` when none does,
/// `Err` when the circles cannot show one (too sparse for two periods over the stroke).
fn scan_cyclic(
    pair: [&Circle; 2],
    shapes: &[Shape],
    axis: usize,
    spacing: f64,
) -> Result<Option<f64>, String> {
    let radius = pair[0].radius.min(pair[1].radius);
    // Nyquist with margin: four samples a period where the samples lie farthest apart.
    let shortest = 4.0 * radius * spacing;
    // A screw's pitch shows as a cycle only with several periods over the stroke; a longer
    // one is a smooth shape that straightness and scale already draw.
    let longest = radius / 4.0;
    if shortest >= longest {
        return Err(format!(
            "samples {:.1}° apart cannot show a pitch below a quarter of the radius",
            spacing.to_degrees()
        ));
    }
    let Some(base) = fit(pair, shapes) else {
        return Ok(None);
    };
    let step = 1.0 / (8.0 * radius);
    let (f_lo, f_hi) = (1.0 / longest, 1.0 / shortest);
    let count = ((f_hi - f_lo) / step).floor() as usize + 1;
    let mut best: Option<(f64, f64)> = None;
    for k in 0..count {
        let f = f_lo + k as f64 * step;
        let mut with = shapes.to_vec();
        with.extend([Shape::Cyclic(axis, f, false), Shape::Cyclic(axis, f, true)]);
        if let Some(fitted) = fit(pair, &with) {
            let gain = base.rss - fitted.rss;
            if best.is_none_or(|(_, g)| gain > g) {
                best = Some((f, gain));
            }
        }
    }
    let Some((f, _)) = best else {
        return Ok(None);
    };
    // The best pitch's χ² drop against the noise left once it is fitted (a cyclic error left
    // in the residuals would pass for coloured noise), taken at low frequencies,
    // `σ²·(1 + ρ)/(1 − ρ)`: conservative for a short pitch, where AR(1) noise has less power.
    // Two parameters: P(> x) = e^{−x/2}, Bonferroni over every pitch scanned (conservative:
    // neighbours a quarter of the resolution 1/(2R) apart are not independent).
    let mut with = shapes.to_vec();
    with.extend([Shape::Cyclic(axis, f, false), Shape::Cyclic(axis, f, true)]);
    let Some(fitted) = fit(pair, &with) else {
        return Ok(None);
    };
    let noise = noise(pair, &design(pair, &with), &fitted);
    let variance = noise.variance * (1.0 + noise.rho) / (1.0 - noise.rho);
    let independent = count.max(1) as f64;
    if (-(base.rss - fitted.rss) / variance / 2.0).exp() >= FAMILY_ALPHA / (2.0 * independent) {
        return Ok(None);
    }
    // A screw's error follows the position, whichever way the axis moves: the part that
    // differs between the directions must be small beside the common one. A misfit at the
    // reversals (a dead band, a spike) draws both alike and is no cyclic error.
    let mut with = shapes.to_vec();
    let first = with.len();
    with.extend([
        Shape::Cyclic(axis, f, false),
        Shape::Cyclic(axis, f, true),
        Shape::CyclicSpread(axis, f, false),
        Shape::CyclicSpread(axis, f, true),
    ]);
    let Some(split) = fit(pair, &with) else {
        return Ok(None);
    };
    let common = split.coef[first].hypot(split.coef[first + 1]);
    let spread = split.coef[first + 2].hypot(split.coef[first + 3]);
    Ok((spread < CYCLIC_SPREAD * common).then_some(f))
}
