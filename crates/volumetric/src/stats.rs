//! The field at each instant: mean, standard deviation and max − min between the points per
//! axis, the mean's magnitude, the spread's shares of it, their intervals and the noise
//! floors (crate docs, "Uncertainties").

use crate::bootstrap::{Normals, basic_interval, quantile};
use crate::cycles::Cycles;
use crate::timebase::{At, AtInstants, NoiseBlock};
use crate::{BOOTSTRAP_DRAWS, K95};

/// The share a draw with no mean deformation counts as (a billion times the mean).
const NO_SHARE: f64 = 1e9;

/// One axis of the field at an instant, µm.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSpread {
    pub mean_um: f64,
    pub mean_u95_um: f64,
    /// Standard deviation between the points (N − 1), observed; the interval is for the
    /// field's own (noise removed); the floor what noise alone gives at 95 %.
    pub std_um: f64,
    pub std_interval_um: [f64; 2],
    pub std_floor_um: f64,
    /// max − min between the points, likewise.
    pub range_um: f64,
    pub range_interval_um: [f64; 2],
    pub range_floor_um: f64,
    /// max − min and the standard deviation as shares of the mean's magnitude, with their
    /// intervals; `None` when the mean is 0.
    pub range_share: Option<f64>,
    pub range_share_interval: Option<[f64; 2]>,
    pub std_share: Option<f64>,
    pub std_share_interval: Option<[f64; 2]>,
}

/// The field at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct Instant {
    /// 0-based.
    pub cycle: usize,
    pub t_s: f64,
    /// Whether every point was visited in the cycle.
    pub complete: bool,
    pub axes: [AxisSpread; 3],
    /// `|mean|`, the mean deformation vector's length, µm, and its interval.
    pub mean_magnitude_um: f64,
    pub mean_magnitude_interval_um: [f64; 2],
    /// Every point's deformation and its 95 % uncertainty, µm (the points' order).
    pub points_um: Vec<[f64; 3]>,
    pub points_u95_um: Vec<[f64; 3]>,
    /// Each point's visit in the cycle relative to the instant, s (`None`: not visited).
    pub offset_s: Vec<Option<f64>>,
}

/// The statistics at each of `times`, whose values `at` gives (in the same order).
pub(crate) fn instants(cycles: &Cycles, times: &[At], at: &AtInstants) -> Vec<Instant> {
    times
        .iter()
        .enumerate()
        .map(|(k, time)| {
            // Seeded by the cycle and the time, so an instant's draws do not depend on which
            // other instants are asked for.
            let seed = (time.cycle as u64) << 32 ^ time.t_s.to_bits();
            let (axes, magnitude) = field(&at.d_um[k], &at.blocks[k], seed);
            Instant {
                cycle: time.cycle,
                t_s: time.t_s,
                complete: cycles.complete[time.cycle],
                axes,
                mean_magnitude_um: magnitude.0,
                mean_magnitude_interval_um: magnitude.1,
                points_um: at.d_um[k].clone(),
                points_u95_um: at.var_um2[k]
                    .iter()
                    .map(|v| v.map(|x| K95 * x.sqrt()))
                    .collect(),
                offset_s: at.offset_s[k].clone(),
            }
        })
        .collect()
}

/// Mean, standard deviation (N − 1) and max − min of `x`.
fn describe(x: &[f64]) -> (f64, f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let ss: f64 = x.iter().map(|v| (v - mean).powi(2)).sum();
    let std = match x.len() > 1 {
        true => (ss / (n - 1.0)).sqrt(),
        false => 0.0,
    };
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    (mean, std, hi - lo)
}

fn norm(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// The statistics of one instant: its points' values `d` and the noise's
/// covariance by set-up `blocks`; the draws seeded by `seed`.
fn field(d: &[[f64; 3]], blocks: &[NoiseBlock], seed: u64) -> ([AxisSpread; 3], (f64, [f64; 2])) {
    let n = d.len();
    let column = |v: &[[f64; 3]], i: usize| -> Vec<f64> { v.iter().map(|p| p[i]).collect() };
    let observed: [(f64, f64, f64); 3] = [0, 1, 2].map(|i| describe(&column(d, i)));
    let mean = observed.map(|o| o.0);
    let magnitude = norm(mean);
    let draws = Draws::run(d, blocks, seed);
    let mut mag_draws = draws.magnitude.clone();
    let magnitude_interval = basic_interval(magnitude, &mut mag_draws);
    let axes = [0, 1, 2].map(|i| {
        let (m, std, range) = observed[i];
        // The mean's variance: every covariance within a set-up's block, over N².
        let sum: f64 = blocks
            .iter()
            .map(|b| b.cov_um2[i].iter().flatten().sum::<f64>())
            .sum();
        let u_mean = K95 * sum.max(0.0).sqrt() / n as f64;
        let share = |v: f64| (magnitude > 0.0).then(|| v / magnitude);
        // A share's interval as its spread's: from 0 when the spread is not above its floor.
        let share_interval = |v: f64, floor: f64, ratio_draws: &[f64]| {
            let floor_share = match v <= floor {
                true => f64::INFINITY,
                false => 0.0,
            };
            share(v).map(|s| spread_interval(s, floor_share, &mut ratio_draws.to_vec()))
        };
        let std_floor = quantile(&mut draws.std_noise[i].clone(), 0.95);
        let range_floor = quantile(&mut draws.range_noise[i].clone(), 0.95);
        AxisSpread {
            mean_um: m,
            mean_u95_um: u_mean,
            std_um: std,
            std_interval_um: spread_interval(std, std_floor, &mut draws.std[i].clone()),
            std_floor_um: std_floor,
            range_um: range,
            range_interval_um: spread_interval(range, range_floor, &mut draws.range[i].clone()),
            range_floor_um: range_floor,
            range_share: share(range),
            range_share_interval: share_interval(range, range_floor, &draws.range_share[i]),
            std_share: share(std),
            std_share_interval: share_interval(std, std_floor, &draws.std_share[i]),
        }
    });
    (axes, (magnitude, magnitude_interval))
}

/// A spread's interval: the lower end the basic bootstrap's, `2T − q₉₇.₅` (it removes the
/// inflation noise gives a spread), or 0 when the spread is not above its noise floor (a field
/// with no spread at all is then not excluded: the floor is that test at 95 %); the upper end
/// the larger of the basic bootstrap's, `2T − q₂.₅`, and `T + (q₅₀ − q₂.₅)`: it does not count
/// on the noise having inflated the observed spread (noise can also pull the extreme points
/// in).
fn spread_interval(t: f64, floor: f64, draws: &mut [f64]) -> [f64; 2] {
    let [lo, hi] = basic_interval(t, draws);
    let hi = hi.max(t + quantile(draws, 0.5) - quantile(draws, 0.025));
    match t <= floor {
        true => [0.0, hi],
        false => [lo, hi],
    }
}

/// The lower triangular `L` with `L·Lᵀ = C` for a covariance `C`; a pivot that is not
/// positive (a value with no noise, such as a point at its first visit) gives a zero column.
fn cholesky(c: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = c.len();
    let mut l = vec![vec![0.0; n]; n];
    for a in 0..n {
        for b in 0..=a {
            let s: f64 = (0..b).map(|k| l[a][k] * l[b][k]).sum();
            if a == b {
                let d = c[a][a] - s;
                l[a][a] = if d > 1e-12 * c[a][a].abs().max(1e-300) {
                    d.sqrt()
                } else {
                    0.0
                };
            } else if l[b][b] > 0.0 {
                l[a][b] = (c[a][b] - s) / l[b][b];
            }
        }
    }
    l
}

/// The bootstrap's draws of one instant: the statistics of `d + noise` and of the noise
/// alone.
struct Draws {
    magnitude: Vec<f64>,
    std: [Vec<f64>; 3],
    range: [Vec<f64>; 3],
    std_noise: [Vec<f64>; 3],
    range_noise: [Vec<f64>; 3],
    std_share: [Vec<f64>; 3],
    range_share: [Vec<f64>; 3],
}

impl Draws {
    fn run(d: &[[f64; 3]], blocks: &[NoiseBlock], seed: u64) -> Draws {
        let b = BOOTSTRAP_DRAWS;
        let empty = || {
            [
                Vec::with_capacity(b),
                Vec::with_capacity(b),
                Vec::with_capacity(b),
            ]
        };
        let mut out = Draws {
            magnitude: Vec::with_capacity(b),
            std: empty(),
            range: empty(),
            std_noise: empty(),
            range_noise: empty(),
            std_share: empty(),
            range_share: empty(),
        };
        let factors: Vec<[Vec<Vec<f64>>; 3]> = blocks
            .iter()
            .map(|blk| [0, 1, 2].map(|i| cholesky(&blk.cov_um2[i])))
            .collect();
        let mut g = Normals::new(seed);
        let n = d.len();
        let (mut x, mut e) = (vec![0.0; n], vec![0.0; n]);
        let mut z = Vec::new();
        for _ in 0..b {
            let mut stats = [(0.0, 0.0, 0.0); 3];
            for i in 0..3 {
                for (blk, l) in blocks.iter().zip(&factors) {
                    let l = &l[i];
                    z.clear();
                    z.extend((0..blk.points.len()).map(|_| g.next()));
                    for (a, &j) in blk.points.iter().enumerate() {
                        e[j] = (0..=a).map(|k| l[a][k] * z[k]).sum();
                    }
                }
                for j in 0..n {
                    x[j] = d[j][i] + e[j];
                }
                stats[i] = describe(&x);
                let (_, std0, range0) = describe(&e);
                out.std_noise[i].push(std0);
                out.range_noise[i].push(range0);
            }
            let magnitude = norm(stats.map(|s| s.0));
            out.magnitude.push(magnitude);
            for (i, &(_, std, range)) in stats.iter().enumerate() {
                out.std[i].push(std);
                out.range[i].push(range);
                // A draw whose mean is 0 has no share: it counts as beyond any bound (a large
                // finite one, so that the intervals stay numbers).
                let ratio = |v: f64| match magnitude > 0.0 {
                    true => (v / magnitude).min(NO_SHARE),
                    false => NO_SHARE,
                };
                out.std_share[i].push(ratio(std));
                out.range_share[i].push(ratio(range));
            }
        }
        out
    }
}
