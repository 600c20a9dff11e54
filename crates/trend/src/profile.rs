//! Profile χ² of the first-order trajectory `v(t) = v∞ + A·exp(−(t − t0)/τ)`: for a fixed τ
//! (and optionally a fixed `v∞` or `A`) the remaining parameters are linear and solved exactly,
//! so every profile is a one-dimensional search over `ln τ`.

use crate::line::{Line, fit_line};
use crate::point::Point;

/// What is held fixed besides τ.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Held {
    /// Nothing: `v∞` and `A` both solved.
    Nothing,
    /// `v∞` held at this value, `A` solved.
    Settled(f64),
    /// `A` held at this value, `v∞` solved.
    Amplitude(f64),
}

/// A point of a profile: `ln τ` and the χ² there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub ln_tau: f64,
    pub chi2: f64,
}

/// The checks, ready for χ²: times since the first check, values, standard uncertainties and
/// weights relative to the smallest one (so the sums stay in range in any unit).
pub(crate) struct Checks {
    pub start_time_s: f64,
    pub dt: Vec<f64>,
    values: Vec<f64>,
    sigma: Vec<f64>,
    /// The smallest σ; `w = (s/σ)²`.
    s: f64,
    w: Vec<f64>,
}

impl Checks {
    pub fn new(points: &[Point]) -> Checks {
        let start_time_s = points[0].time_s;
        let sigma: Vec<f64> = points.iter().map(Point::sigma).collect();
        let s = sigma.iter().copied().fold(f64::INFINITY, f64::min);
        Checks {
            start_time_s,
            dt: points.iter().map(|p| p.time_s - start_time_s).collect(),
            values: points.iter().map(|p| p.value).collect(),
            w: sigma.iter().map(|sg| (s / sg).powi(2)).collect(),
            sigma,
            s,
        }
    }

    /// From a quarter of the shortest step between checks (a faster change is over before the
    /// second check) to ten times the span (a slower one is a straight line within it).
    pub fn default_range_s(&self) -> (f64, f64) {
        let shortest = self
            .dt
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|&d| d > 0.0)
            .fold(f64::INFINITY, f64::min);
        (shortest / 4.0, 10.0 * self.dt[self.dt.len() - 1])
    }

    /// `v∞` and `A` at τ: a line of value against `exp(−Δt/τ)`, whose slope is `A` and whose
    /// value at 0 is `v∞`.
    pub fn line(&self, tau: f64) -> Option<Line> {
        let e: Vec<f64> = self.dt.iter().map(|dt| (-dt / tau).exp()).collect();
        fit_line(&e, &self.values, &self.sigma)
    }

    /// χ² at `ln τ` with the free linear parameters solved; infinite when out of range.
    pub fn chi2(&self, held: Held, ln_tau: f64) -> f64 {
        let tau = ln_tau.exp();
        let chi2 = match held {
            Held::Nothing => self.line(tau).map_or(f64::INFINITY, |l| l.chi2),
            Held::Settled(v) => self.chi2_settled_held(v, tau),
            Held::Amplitude(a) => self.chi2_amplitude_held(a, tau),
        };
        if chi2.is_finite() {
            chi2
        } else {
            f64::INFINITY
        }
    }

    /// `z = y − v∞ = A·e`: `A = Σ w e z / Σ w e²` (the first check has e = 1, so the
    /// denominator is positive).
    fn chi2_settled_held(&self, settled: f64, tau: f64) -> f64 {
        let (mut sez, mut see) = (0.0, 0.0);
        for i in 0..self.dt.len() {
            let e = (-self.dt[i] / tau).exp();
            sez += self.w[i] * e * (self.values[i] - settled);
            see += self.w[i] * e * e;
        }
        let a = sez / see;
        self.weighted_sum_of_squares(|i, e| self.values[i] - settled - a * e, tau)
    }

    /// `z = y − A·e = v∞`: the weighted mean of `z`.
    fn chi2_amplitude_held(&self, amplitude: f64, tau: f64) -> f64 {
        let (mut sw, mut swz) = (0.0, 0.0);
        for i in 0..self.dt.len() {
            let e = (-self.dt[i] / tau).exp();
            sw += self.w[i];
            swz += self.w[i] * (self.values[i] - amplitude * e);
        }
        let mean = swz / sw;
        self.weighted_sum_of_squares(|i, e| self.values[i] - amplitude * e - mean, tau)
    }

    fn weighted_sum_of_squares(&self, residual: impl Fn(usize, f64) -> f64, tau: f64) -> f64 {
        (0..self.dt.len())
            .map(|i| {
                let r = residual(i, (-self.dt[i] / tau).exp()) / self.s;
                self.w[i] * r * r
            })
            .sum()
    }
}

/// A log-spaced grid of `ln τ` over a range.
pub(crate) fn grid(lo_s: f64, hi_s: f64, points: usize) -> Vec<f64> {
    let (a, b) = (lo_s.ln(), hi_s.ln());
    let step = (b - a) / (points - 1) as f64;
    (0..points).map(|i| a + step * i as f64).collect()
}

/// The profile over the grid with its refined minimum inserted in order, and the minimum's
/// position; `None` when the minimum lies at an end of the grid.
pub(crate) fn profile(f: impl Fn(f64) -> f64, grid: &[f64]) -> (Vec<Node>, Option<usize>) {
    let mut nodes: Vec<Node> = grid
        .iter()
        .map(|&ln_tau| Node {
            ln_tau,
            chi2: f(ln_tau),
        })
        .collect();
    let j = argmin(&nodes);
    if j == 0 || j == nodes.len() - 1 {
        return (nodes, None);
    }
    let best = golden_section(&f, nodes[j - 1].ln_tau, nodes[j + 1].ln_tau);
    let at = j + usize::from(best.ln_tau > nodes[j].ln_tau);
    nodes.insert(at, best);
    let j = argmin(&nodes);
    (nodes, Some(j))
}

/// The smallest χ² over τ (grid, then golden section about the best node).
pub(crate) fn minimum(f: impl Fn(f64) -> f64, grid: &[f64]) -> f64 {
    let (nodes, best) = profile(&f, grid);
    match best {
        Some(j) => nodes[j].chi2,
        None => nodes[argmin(&nodes)].chi2,
    }
}

pub(crate) fn argmin(nodes: &[Node]) -> usize {
    (0..nodes.len())
        .min_by(|&i, &k| nodes[i].chi2.total_cmp(&nodes[k].chi2))
        .unwrap_or(0)
}

/// The minimum of a unimodal `f` on `[a, b]` by golden section (to 1e-9 in ln τ).
fn golden_section(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> Node {
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    let node = |x: f64| Node {
        ln_tau: x,
        chi2: f(x),
    };
    let mut c = node(b - INV_PHI * (b - a));
    let mut d = node(a + INV_PHI * (b - a));
    while b - a > 1e-9 {
        if c.chi2 <= d.chi2 {
            b = d.ln_tau;
            d = c;
            c = node(b - INV_PHI * (b - a));
        } else {
            a = c.ln_tau;
            c = d;
            d = node(a + INV_PHI * (b - a));
        }
    }
    if c.chi2 <= d.chi2 { c } else { d }
}

/// The boundary between `outside` and `inside` where `is_inside` changes, by bisection until
/// the bracket is narrower than `tolerance`.
pub(crate) fn bisect(
    is_inside: impl Fn(f64) -> bool,
    outside: f64,
    inside: f64,
    tolerance: f64,
) -> f64 {
    let (mut out, mut inn) = (outside, inside);
    for _ in 0..200 {
        if (out - inn).abs() <= tolerance {
            break;
        }
        let mid = 0.5 * (out + inn);
        if is_inside(mid) {
            inn = mid;
        } else {
            out = mid;
        }
    }
    0.5 * (out + inn)
}
