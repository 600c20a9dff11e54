//! Repeated quick checks within one day: the first-order thermal trajectory of a parameter.

use serde::Serialize;

use crate::error::TrendError;
use crate::point::{Point, check_series, distinct_times};
use crate::profile::{Checks, Held, Node, argmin, bisect, grid, minimum, profile};
use crate::scatter::Scatter;

/// Points a trajectory needs: three parameters and two degrees of freedom to judge the scatter.
pub const THERMAL_MIN_POINTS: usize = 5;

/// Settings of the trajectory fit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ThermalOptions {
    /// Range of time constants searched, seconds. Default: from a quarter of the shortest step
    /// between checks (a faster change is over before the second check) to ten times the
    /// series' span (a slower one is a straight line within it).
    pub tau_range_s: Option<(f64, f64)>,
    /// Log-spaced time constants of the coarse search before refining the best.
    pub grid_points: usize,
}

impl Default for ThermalOptions {
    fn default() -> Self {
        ThermalOptions {
            tau_range_s: None,
            grid_points: 200,
        }
    }
}

/// The outcome of the trajectory fit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ThermalFit {
    /// τ and the amplitude are determined by the checks.
    Determined(Trajectory),
    /// They are not, and why.
    NotDetermined(NotDetermined),
}

/// `value(t) = v∞ + (v0 − v∞)·exp(−(t − t0)/τ)`, `t0` the time of the first check.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Trajectory {
    /// Checks fitted.
    pub n: usize,
    /// `t0`.
    pub start_time_s: f64,
    /// The time constant τ, minutes.
    pub tau_min: f64,
    /// Its 95 % profile-likelihood interval, minutes (asymmetric).
    pub tau_low_min: f64,
    pub tau_high_min: f64,
    /// The larger side of that interval: `[τ − u95, τ + u95]` contains it.
    pub tau_u95_min: f64,
    /// `v0 − v∞` (the change still to come at `t0`), the parameter's unit.
    pub amplitude: f64,
    /// Its 95 % profile-likelihood interval (τ and `v∞` free).
    pub amplitude_low: f64,
    pub amplitude_high: f64,
    /// The larger side of that interval.
    pub amplitude_u95: f64,
    /// The settled value `v∞`.
    pub settled_value: f64,
    /// Its 95 % profile-likelihood interval (τ and the amplitude free).
    pub settled_value_low: f64,
    pub settled_value_high: f64,
    /// The larger side of that interval.
    pub settled_value_u95: f64,
    /// Scatter about the trajectory (dof = n − 3).
    pub scatter: Scatter,
}

impl Trajectory {
    /// The fitted value at `time_s`.
    pub fn value_at(&self, time_s: f64) -> f64 {
        let minutes = (time_s - self.start_time_s) / 60.0;
        self.settled_value + self.amplitude * (-minutes / self.tau_min).exp()
    }
}

/// Why τ is not determined.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum NotDetermined {
    /// Fewer checks than [`THERMAL_MIN_POINTS`].
    TooFewPoints { n: usize, needed: usize },
    /// Fewer different times than four.
    TooFewTimes { distinct: usize, needed: usize },
    /// The best τ is at an end of the searched range: the change is faster than the checks
    /// can follow (lower end) or too slow to bend within them (upper end).
    TauAtEdge { edge_min: f64 },
    /// The best τ is inside the range but its 95 % interval reaches an end of it.
    IntervalOpen { tau_min: f64, edge_min: f64 },
    /// τ is determined but the amplitude's or the settled value's 95 % interval has no end.
    LevelsOpen { tau_min: f64 },
}

impl std::fmt::Display for NotDetermined {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NotDetermined::TooFewPoints { n, needed } => write!(
                f,
                "time constant not determined: {n} checks, at least {needed} are needed"
            ),
            NotDetermined::TooFewTimes { distinct, needed } => write!(
                f,
                "time constant not determined: {distinct} different times, at least {needed} \
                 are needed"
            ),
            NotDetermined::TauAtEdge { edge_min } => write!(
                f,
                "time constant not determined: the best fit runs to the end of the searched \
                 range, {edge_min:.3} min"
            ),
            NotDetermined::IntervalOpen { tau_min, edge_min } => write!(
                f,
                "time constant not determined: best {tau_min:.3} min, but its 95 % interval \
                 reaches the end of the searched range ({edge_min:.3} min)"
            ),
            NotDetermined::LevelsOpen { tau_min } => write!(
                f,
                "trajectory not determined: τ = {tau_min:.3} min, but the amplitude or the \
                 settled value has no bounded 95 % interval"
            ),
        }
    }
}

/// Fits the first-order trajectory to same-day checks in time order.
///
/// For a fixed τ the model is linear in `v∞` and the amplitude, which weighted least squares
/// solves exactly; τ is found by a log-spaced search of the profile χ²(τ) refined by golden
/// section. Every interval is a **profile-likelihood** interval, `χ²_profile ≤ χ²_min + Δ`
/// with `Δ = 4` (k = 2) or, when the scatter exceeds the stated uncertainties, `Δ = R²·t²`
/// (Birge ratio `R`, Student's t(n − 3) at 97.5 %): for τ the outermost crossings (a profile
/// with two dips gives the hull); for the amplitude and `v∞` the profile holds one of them
/// and minimises over τ (searched again) and the other. A Jacobian covariance would be
/// simpler but under-covers when τ is long against the span (the settled value is then an
/// extrapolation). `tests/suite/thermal.rs` checks the coverage by simulation.
pub fn fit_thermal(points: &[Point], options: &ThermalOptions) -> Result<ThermalFit, TrendError> {
    check_series(points, 0, "a thermal trajectory")?;
    if options.grid_points < 3 {
        return Err(TrendError::BadSetting {
            what: "grid_points",
            value: options.grid_points as f64,
            expected: "at least 3",
        });
    }
    let n = points.len();
    if n < THERMAL_MIN_POINTS {
        return Ok(ThermalFit::NotDetermined(NotDetermined::TooFewPoints {
            n,
            needed: THERMAL_MIN_POINTS,
        }));
    }
    let distinct = distinct_times(points);
    if distinct < 4 {
        return Ok(ThermalFit::NotDetermined(NotDetermined::TooFewTimes {
            distinct,
            needed: 4,
        }));
    }
    let checks = Checks::new(points);
    let (lo, hi) = match options.tau_range_s {
        Some(range) => check_range(range)?,
        None => checks.default_range_s(),
    };
    fit(&checks, &grid(lo, hi, options.grid_points))
}

fn check_range((lo, hi): (f64, f64)) -> Result<(f64, f64), TrendError> {
    let bad = |value| TrendError::BadSetting {
        what: "tau_range_s",
        value,
        expected: "a range 0 < low < high of finite seconds",
    };
    if !(lo.is_finite() && lo > 0.0) {
        return Err(bad(lo));
    }
    if !(hi.is_finite() && hi > lo) {
        return Err(bad(hi));
    }
    Ok((lo, hi))
}

fn minutes(ln_tau: f64) -> f64 {
    ln_tau.exp() / 60.0
}

fn fit(checks: &Checks, grid: &[f64]) -> Result<ThermalFit, TrendError> {
    let not = |why| Ok(ThermalFit::NotDetermined(why));
    let (nodes, best) = profile(|x| checks.chi2(Held::Nothing, x), grid);
    let Some(j) = best else {
        let edge_min = minutes(nodes[argmin(&nodes)].ln_tau);
        return not(NotDetermined::TauAtEdge { edge_min });
    };
    let best = nodes[j];
    let tau_min = minutes(best.ln_tau);
    let scatter = Scatter::new(best.chi2, checks.dt.len() - 3);
    let threshold = best.chi2 + scatter.expansion().powi(2);
    let (low, high) = match tau_interval(checks, &nodes, j, threshold) {
        Ok(bounds) => bounds,
        Err(edge) => {
            let edge_min = minutes(edge);
            return not(NotDetermined::IntervalOpen { tau_min, edge_min });
        }
    };
    let line = checks
        .line(best.ln_tau.exp())
        .ok_or(TrendError::OutOfRange {
            what: "a thermal trajectory",
        })?;
    let amplitude = line.slope;
    let settled_value = line.level - amplitude * line.x_ref;
    // Steps to start the searches: the fixed-τ standard uncertainties, expanded.
    let step_a = scatter.expansion() * line.sd_slope;
    let step_v = scatter.expansion() * line.sd_level.hypot(line.x_ref * line.sd_slope);
    let levels = (
        held_interval(checks, grid, Held::Amplitude, amplitude, step_a, threshold),
        held_interval(
            checks,
            grid,
            Held::Settled,
            settled_value,
            step_v,
            threshold,
        ),
    );
    let (Some((amplitude_low, amplitude_high)), Some((settled_low, settled_high))) = levels else {
        return not(NotDetermined::LevelsOpen { tau_min });
    };
    let (tau_low_min, tau_high_min) = (minutes(low), minutes(high));
    let larger_side = |v: f64, lo: f64, hi: f64| (v - lo).max(hi - v);
    Ok(ThermalFit::Determined(Trajectory {
        n: checks.dt.len(),
        start_time_s: checks.start_time_s,
        tau_min,
        tau_low_min,
        tau_high_min,
        tau_u95_min: larger_side(tau_min, tau_low_min, tau_high_min),
        amplitude,
        amplitude_low,
        amplitude_high,
        amplitude_u95: larger_side(amplitude, amplitude_low, amplitude_high),
        settled_value,
        settled_value_low: settled_low,
        settled_value_high: settled_high,
        settled_value_u95: larger_side(settled_value, settled_low, settled_high),
        scatter,
    }))
}

/// τ's profile-likelihood interval (ln τ) from the outermost nodes inside the threshold, or
/// the end of the range (ln τ) where an end node is inside and the interval is open.
fn tau_interval(
    checks: &Checks,
    nodes: &[Node],
    best: usize,
    threshold: f64,
) -> Result<(f64, f64), f64> {
    let inside = |n: &Node| n.chi2 <= threshold;
    let first = nodes.iter().position(inside).unwrap_or(best);
    let last = nodes.iter().rposition(inside).unwrap_or(best);
    if first == 0 {
        return Err(nodes[0].ln_tau);
    }
    if last == nodes.len() - 1 {
        return Err(nodes[last].ln_tau);
    }
    let within = |x: f64| checks.chi2(Held::Nothing, x) <= threshold;
    Ok((
        bisect(within, nodes[first - 1].ln_tau, nodes[first].ln_tau, 1e-9),
        bisect(within, nodes[last + 1].ln_tau, nodes[last].ln_tau, 1e-9),
    ))
}

/// The profile-likelihood interval of a linear parameter held at trial values (`held`), τ and
/// the other linear parameter free: from the estimate, steps doubling from `step` until the
/// profile leaves the threshold, then bisection. `None` when it never does.
fn held_interval(
    checks: &Checks,
    grid: &[f64],
    held: impl Fn(f64) -> Held,
    estimate: f64,
    step: f64,
    threshold: f64,
) -> Option<(f64, f64)> {
    if !(step.is_finite() && step > 0.0) {
        return None;
    }
    // Every fourth node of τ's grid (the ends kept) is enough to find the valley the golden
    // section then refines, at a quarter of the cost of each of the ~50 profile points.
    let coarse: Vec<f64> = grid.iter().step_by(4).chain(grid.last()).copied().collect();
    let within = |v: f64| minimum(|x| checks.chi2(held(v), x), &coarse) <= threshold;
    let side = |sign: f64| {
        let (mut inside, mut h) = (estimate, step);
        for _ in 0..64 {
            let trial = estimate + sign * h;
            if !within(trial) {
                return Some(bisect(within, trial, inside, 1e-6 * step));
            }
            inside = trial;
            h *= 2.0;
        }
        None
    };
    Some((side(-1.0)?, side(1.0)?))
}
