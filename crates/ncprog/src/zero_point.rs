//! Source 004's zero point: the grid point whose error vector, taken as a constant offset, leaves
//! the smallest sum of error magnitudes over the grid; and the continuous optimum (the geometric
//! median) for comparison. See the crate documentation for the method.

use mtcal_kinematics::volmap::{Grid, MapOptions, volumetric_map};
use mtcal_kinematics::{Machine, MachineModel};
use std::sync::atomic::{AtomicU64, Ordering};

/// Error vectors in flat arrays (µm), one entry per point.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorVectors {
    pub x_um: Vec<f64>,
    pub y_um: Vec<f64>,
    pub z_um: Vec<f64>,
}

impl ErrorVectors {
    pub fn new(d_um: &[[f64; 3]]) -> Self {
        Self {
            x_um: d_um.iter().map(|d| d[0]).collect(),
            y_um: d_um.iter().map(|d| d[1]).collect(),
            z_um: d_um.iter().map(|d| d[2]).collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.x_um.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x_um.is_empty()
    }

    pub fn get(&self, k: usize) -> [f64; 3] {
        [self.x_um[k], self.y_um[k], self.z_um[k]]
    }

    /// `Σ_{i ∈ range} ‖d_i − c‖` in a fixed order (four interleaved partial sums, added at the
    /// end), so that every caller gets the same bits.
    pub fn distance_sum_um(&self, c: [f64; 3], range: std::ops::Range<usize>) -> f64 {
        let (xs, ys, zs) = (
            &self.x_um[range.clone()],
            &self.y_um[range.clone()],
            &self.z_um[range],
        );
        let mut acc = [0.0f64; 4];
        let (xc, yc, zc) = (xs.chunks_exact(4), ys.chunks_exact(4), zs.chunks_exact(4));
        let (xr, yr, zr) = (xc.remainder(), yc.remainder(), zc.remainder());
        for ((x, y), z) in xc.zip(yc).zip(zc) {
            for l in 0..4 {
                let (dx, dy, dz) = (x[l] - c[0], y[l] - c[1], z[l] - c[2]);
                acc[l] += (dx * dx + dy * dy + dz * dz).sqrt();
            }
        }
        for l in 0..xr.len() {
            let (dx, dy, dz) = (xr[l] - c[0], yr[l] - c[1], zr[l] - c[2]);
            acc[l] += (dx * dx + dy * dy + dz * dz).sqrt();
        }
        (acc[0] + acc[1]) + (acc[2] + acc[3])
    }

    /// `Σ_i ‖d_i − c‖` over all points, summed block by block of [`BLOCK`] points (the order
    /// [`zero_point`] uses).
    pub fn total_distance_um(&self, c: [f64; 3]) -> f64 {
        let n = self.len();
        (0..n)
            .step_by(BLOCK)
            .map(|s| self.distance_sum_um(c, s..(s + BLOCK).min(n)))
            .sum()
    }

    /// `max_i ‖d_i − c‖`.
    pub fn max_distance_um(&self, c: [f64; 3]) -> f64 {
        (0..self.len())
            .map(|i| dist(self.get(i), c))
            .fold(0.0, f64::max)
    }
}

/// Points per block of the exact search: the partial sum is compared with the best after each.
pub const BLOCK: usize = 1024;

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The result of [`zero_point`].
#[derive(Clone, Debug, PartialEq)]
pub struct ZeroPoint {
    /// k*: index of the zero point (grid order).
    pub index: usize,
    /// `d_k*` (µm).
    pub error_um: [f64; 3],
    /// The correction, `−d_k*` (µm): add it to every commanded X/Y/Z.
    pub offset_um: [f64; 3],
    /// `Σ ‖d_i‖` and `max ‖d_i‖` before the correction (µm).
    pub sum_before_um: f64,
    pub max_before_um: f64,
    /// `Σ ‖d_i − d_k*‖` and `max ‖d_i − d_k*‖` after it (µm).
    pub sum_after_um: f64,
    pub max_after_um: f64,
    /// Candidates whose sum was completed: a measure of the work.
    pub completed: usize,
    /// Candidates whose sum was started (the others were excluded by the bound alone).
    pub visited: usize,
}

/// The exact zero point `k* = argmin_k Σ_i ‖d_i − d_k‖` (ties: smallest k). `None` for no points.
///
/// Exact, but most candidates are never summed. For any pivot `p`, the triangle inequality
/// gives `‖d_i − d_k‖ ≥ |r_i − r_k|` with `r = ‖d − p‖`, so `S(k) ≥ L_p(k) = Σ_i |r_i − r_k|`,
/// which for all k costs one sort and prefix sums (O(N log N)). Four pivots — a rough geometric
/// median and points far out along +X, +Y, +Z (there `L_p` is nearly the one-dimensional bound
/// of the projections) — give `L(k) = max_p L_p(k)`. Candidates are visited in increasing `L`;
/// the search stops once `L(k)` exceeds the best sum, and a candidate's sum is abandoned after
/// any block of [`BLOCK`] points whose partial sum already exceeds it. Each completed sum is
/// [`ErrorVectors::total_distance_um`] (the same bits in any visiting order), so the result is
/// that of [`zero_point_naive`]. From 4 blocks on, candidates are dealt round-robin to up to
/// [`MAX_LANES`] threads sharing the best sum so far; pruning is strict, so the result (not the
/// work counters) is the same on any number of cores.
pub fn zero_point(d: &ErrorVectors) -> Option<ZeroPoint> {
    let n = d.len();
    if n == 0 {
        return None;
    }
    let bounds = Bounds::new(d)?;
    let global = bounds.global();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| global[a].total_cmp(&global[b]).then(a.cmp(&b)));
    let lanes = if n < 4 * BLOCK {
        1
    } else {
        std::thread::available_parallelism().map_or(1, |p| p.get().min(MAX_LANES))
    };
    let shared = AtomicU64::new(f64::INFINITY.to_bits());
    let run = |lane: usize| search_lane(d, &bounds, &global, &order, lane, lanes, &shared);
    let results: Vec<LaneResult> = if lanes == 1 {
        vec![run(0)]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..lanes).map(|l| s.spawn(move || run(l))).collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("a search lane panicked"))
                .collect()
        })
    };
    let best = results
        .iter()
        .filter(|r| r.best.is_finite())
        .min_by(|a, b| a.best.total_cmp(&b.best).then(a.best_k.cmp(&b.best_k)))?;
    let completed = results.iter().map(|r| r.completed).sum();
    let visited = results.iter().map(|r| r.visited).sum();
    Some(summarise(d, best.best_k, best.best, [completed, visited]))
}

/// Threads of [`zero_point`] at most.
pub const MAX_LANES: usize = 4;

struct LaneResult {
    best: f64,
    best_k: usize,
    completed: usize,
    visited: usize,
}

/// Candidates `order[lane], order[lane + lanes], …`; `shared` holds the best sum of any lane
/// (bits of a non-negative f64, which order as integers). Pruning is strict (`>`), so a
/// candidate tying the final best is always completed: the result does not depend on timing.
fn search_lane(
    d: &ErrorVectors,
    bounds: &Bounds,
    global: &[f64],
    order: &[usize],
    lane: usize,
    lanes: usize,
    shared: &AtomicU64,
) -> LaneResult {
    let mut r = LaneResult {
        best: f64::INFINITY,
        best_k: usize::MAX,
        completed: 0,
        visited: 0,
    };
    let mut rest = vec![0.0; bounds.n_blocks + 1];
    for &k in order.iter().skip(lane).step_by(lanes) {
        let limit = f64::from_bits(shared.load(Ordering::Relaxed));
        if safe(global[k]) > limit {
            break;
        }
        r.visited += 1;
        bounds.block_rest(k, &mut rest);
        if let Some(s) = sum_below(d, d.get(k), limit, &rest) {
            r.completed += 1;
            if s < r.best || (s == r.best && k < r.best_k) {
                (r.best, r.best_k) = (s, k);
                shared.fetch_min(s.to_bits(), Ordering::Relaxed);
            }
        }
    }
    r
}

/// A lower bound exact in real arithmetic, lowered by a relative margin for rounding.
fn safe(bound: f64) -> f64 {
    bound * (1.0 - 1e-9) - 1e-12
}

/// The pivots' distances, sorted globally and per block of [`BLOCK`] points, with prefix sums.
struct Bounds {
    n_blocks: usize,
    /// `r[p][i] = ‖d_i − pivot_p‖`.
    r: Vec<Vec<f64>>,
    /// Per pivot: the block-wise sorted `r` and their prefix sums (one leading 0 per block).
    sorted: Vec<Vec<f64>>,
    prefix: Vec<Vec<f64>>,
}

impl Bounds {
    fn new(d: &ErrorVectors) -> Option<Self> {
        let rough = WeiszfeldOptions {
            tol_um: 1e-3,
            max_iterations: 30,
        };
        let m = geometric_median(d, &rough)?.point_um;
        let far = 1e3 * (d.max_distance_um(m) + 1.0);
        let pivots = [
            m,
            [m[0] + far, m[1], m[2]],
            [m[0], m[1] + far, m[2]],
            [m[0], m[1], m[2] + far],
        ];
        let n = d.len();
        let r: Vec<Vec<f64>> = pivots
            .iter()
            .map(|&p| (0..n).map(|i| dist(d.get(i), p)).collect())
            .collect();
        let (mut sorted, mut prefix) = (Vec::new(), Vec::new());
        for rp in &r {
            let mut s = Vec::with_capacity(n);
            let mut pre = Vec::with_capacity(n + n.div_ceil(BLOCK));
            for chunk in rp.chunks(BLOCK) {
                let mut c = chunk.to_vec();
                c.sort_by(f64::total_cmp);
                pre.push(0.0);
                let mut acc = 0.0;
                for v in &c {
                    acc += v;
                    pre.push(acc);
                }
                s.extend(c);
            }
            sorted.push(s);
            prefix.push(pre);
        }
        Some(Self {
            n_blocks: n.div_ceil(BLOCK),
            r,
            sorted,
            prefix,
        })
    }

    /// `L(k) = max_p Σ_i |r_p,i − r_p,k|` over all points (one sort per pivot).
    fn global(&self) -> Vec<f64> {
        let mut bound = vec![0.0f64; self.r[0].len()];
        for rp in &self.r {
            let mut sorted = rp.clone();
            sorted.sort_by(f64::total_cmp);
            let prefix = prefix_sums(&sorted);
            for (b, &x) in bound.iter_mut().zip(rp) {
                *b = b.max(abs_deviation_sum(&sorted, &prefix, x));
            }
        }
        bound
    }

    /// `rest[b] = Σ_{b' ≥ b} max_p Σ_{i ∈ block b'} |r_p,i − r_p,k|`, `rest[n_blocks] = 0`.
    fn block_rest(&self, k: usize, rest: &mut [f64]) {
        rest[self.n_blocks] = 0.0;
        let n = self.r[0].len();
        for b in (0..self.n_blocks).rev() {
            let (lo, hi) = (b * BLOCK, ((b + 1) * BLOCK).min(n));
            let mut lb = 0.0f64;
            for p in 0..self.r.len() {
                let pre = &self.prefix[p][lo + b..hi + b + 1];
                lb = lb.max(abs_deviation_sum(
                    &self.sorted[p][lo..hi],
                    pre,
                    self.r[p][k],
                ));
            }
            rest[b] = rest[b + 1] + lb;
        }
    }
}

fn prefix_sums(sorted: &[f64]) -> Vec<f64> {
    let mut prefix = Vec::with_capacity(sorted.len() + 1);
    prefix.push(0.0);
    for v in sorted {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + v);
    }
    prefix
}

/// `Σ_i |sorted_i − x|` from the sorted values and their prefix sums.
fn abs_deviation_sum(sorted: &[f64], prefix: &[f64], x: f64) -> f64 {
    let (n, total) = (sorted.len(), prefix[sorted.len()]);
    let j = sorted.partition_point(|&v| v <= x);
    let below = x * j as f64 - prefix[j];
    let above = (total - prefix[j]) - x * (n - j) as f64;
    (below + above).max(0.0)
}

/// `Σ_i ‖d_i − c‖` block by block, or `None` once the partial sum plus the lower bound of the
/// remaining blocks (`rest`, see [`Bounds::block_rest`]) exceeds `limit`.
fn sum_below(d: &ErrorVectors, c: [f64; 3], limit: f64, rest: &[f64]) -> Option<f64> {
    let n = d.len();
    let mut s = 0.0;
    if safe(rest[0]) > limit {
        return None;
    }
    for (b, start) in (0..n).step_by(BLOCK).enumerate() {
        s += d.distance_sum_um(c, start..(start + BLOCK).min(n));
        if s + safe(rest[b + 1]) > limit {
            return None;
        }
    }
    Some(s)
}

fn summarise(d: &ErrorVectors, k: usize, sum_after_um: f64, work: [usize; 2]) -> ZeroPoint {
    let e = d.get(k);
    ZeroPoint {
        index: k,
        error_um: e,
        offset_um: [-e[0], -e[1], -e[2]],
        sum_before_um: d.total_distance_um([0.0; 3]),
        max_before_um: d.max_distance_um([0.0; 3]),
        sum_after_um,
        max_after_um: d.max_distance_um(e),
        completed: work[0],
        visited: work[1],
    }
}

/// The plain O(N²) search (every sum completed, candidates in index order): the reference
/// [`zero_point`] is tested against.
pub fn zero_point_naive(d: &ErrorVectors) -> Option<ZeroPoint> {
    let n = d.len();
    let (best_k, best) = (0..n).map(|k| (k, d.total_distance_um(d.get(k)))).fold(
        None,
        |acc: Option<(usize, f64)>, (k, s)| match acc {
            Some((_, b)) if b <= s => acc,
            _ => Some((k, s)),
        },
    )?;
    Some(summarise(d, best_k, best, [n, n]))
}

/// Options of [`geometric_median`].
#[derive(Clone, Debug, PartialEq)]
pub struct WeiszfeldOptions {
    /// Stop when an iteration moves the estimate less than this (µm).
    pub tol_um: f64,
    pub max_iterations: usize,
}

impl Default for WeiszfeldOptions {
    fn default() -> Self {
        Self {
            tol_um: 1e-9,
            max_iterations: 2_000,
        }
    }
}

/// The continuous optimum: the offset may be any vector, not only a grid point's error.
#[derive(Clone, Debug, PartialEq)]
pub struct GeometricMedian {
    /// The median `m` of the error vectors (µm).
    pub point_um: [f64; 3],
    /// The correction `−m` (µm).
    pub offset_um: [f64; 3],
    /// `Σ ‖d_i − m‖`, `max ‖d_i − m‖` (µm).
    pub sum_um: f64,
    pub max_um: f64,
    pub iterations: usize,
}

/// The geometric median `argmin_m Σ_i ‖d_i − m‖` by Weiszfeld's iteration with the Vardi–Zhang
/// modification (correct when an iterate lands on a data point), started at the mean. `None`
/// for no points.
pub fn geometric_median(d: &ErrorVectors, opts: &WeiszfeldOptions) -> Option<GeometricMedian> {
    let n = d.len();
    if n == 0 {
        return None;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
    let mut y = [mean(&d.x_um), mean(&d.y_um), mean(&d.z_um)];
    let mut iterations = 0;
    while iterations < opts.max_iterations {
        iterations += 1;
        let next = weiszfeld_step(d, y);
        let moved = dist(next, y);
        y = next;
        if moved <= opts.tol_um {
            break;
        }
    }
    Some(GeometricMedian {
        point_um: y,
        offset_um: [-y[0], -y[1], -y[2]],
        sum_um: d.total_distance_um(y),
        max_um: d.max_distance_um(y),
        iterations,
    })
}

fn weiszfeld_step(d: &ErrorVectors, y: [f64; 3]) -> [f64; 3] {
    let (mut t, mut w_sum, mut r, mut eta) = ([0.0; 3], 0.0, [0.0; 3], 0.0);
    for i in 0..d.len() {
        let p = d.get(i);
        let dist_i = dist(p, y);
        if dist_i == 0.0 {
            eta += 1.0;
            continue;
        }
        let w = 1.0 / dist_i;
        w_sum += w;
        for c in 0..3 {
            t[c] += w * p[c];
            r[c] += w * (p[c] - y[c]);
        }
    }
    if w_sum == 0.0 {
        return y;
    }
    let t = t.map(|v| v / w_sum);
    let r_norm = dist(r, [0.0; 3]);
    if eta == 0.0 || r_norm == 0.0 {
        return if eta == 0.0 { t } else { y };
    }
    let f = (eta / r_norm).min(1.0);
    [0, 1, 2].map(|c| (1.0 - f) * t[c] + f * y[c])
}

/// The zero point of `model` with `coeffs` on `grid` (e.g. [`Grid::source004`]): the
/// first-order volumetric map's translation errors (µm, workpiece frame), the exact search and
/// the geometric median. `positions` are the zero point's axis positions (m, rad).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelZeroPoint {
    pub zero_point: ZeroPoint,
    pub median: GeometricMedian,
    pub positions: Vec<f64>,
}

impl ModelZeroPoint {
    /// The three lines `mtcal zero-point` prints: where the zero point is (the axis positions
    /// of `machine`, mm / degrees) among `grid_points` points, the offset, and the summed and
    /// largest errors before and after it.
    pub fn report(&self, machine: &Machine, grid_points: usize) -> String {
        let zp = &self.zero_point;
        let at: Vec<String> = self
            .positions
            .iter()
            .zip(machine.axes())
            .map(|(&v, a)| format!("{}={:.3}", a.letter().as_char(), a.kind().to_file(v)))
            .collect();
        format!(
            "zero point  {} of {grid_points} grid points\n\
             offset      [{:.3}, {:.3}, {:.3}] um\n\
             sum |error| {:.1} um before, {:.1} um after (geometric median {:.1} um); max {:.3} \
             um before, {:.3} um after\n",
            at.join(" "),
            zp.offset_um[0],
            zp.offset_um[1],
            zp.offset_um[2],
            zp.sum_before_um,
            zp.sum_after_um,
            self.median.sum_um,
            zp.max_before_um,
            zp.max_after_um
        )
    }
}

/// See [`ModelZeroPoint`]. `None` for an empty grid.
pub fn model_zero_point(
    model: &MachineModel,
    coeffs: &[f64],
    grid: &Grid,
) -> Option<ModelZeroPoint> {
    let map = volumetric_map(model, coeffs, grid, &MapOptions::default());
    let d = ErrorVectors::new(map.translations_um());
    let zero_point = zero_point(&d)?;
    let median = geometric_median(&d, &WeiszfeldOptions::default())?;
    Some(ModelZeroPoint {
        positions: map.positions(zero_point.index).to_vec(),
        zero_point,
        median,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_report_says_where_the_offset_and_what_it_gains() {
        let reading = mtcal_machine::topology::Reading::FromWorkpiece;
        let code = mtcal_machine::topology::parse_code("ZFYX", reading).unwrap();
        let machine = mtcal_machine::topology::nominal_machine(&code, "ZFYX").unwrap();
        let config = mtcal_machine::config::default_config(&machine);
        let model = MachineModel::new(machine, &config).unwrap();
        // Positioning errors only: 2 µm at every coefficient of EXX, EYY, EZZ.
        let mut coeffs = vec![0.0; model.n_coeffs()];
        for p in model.errors().params() {
            if ["EXX", "EYY", "EZZ"].contains(&p.name.to_string().as_str()) {
                coeffs[p.offset..p.offset + p.len].fill(2e-6);
            }
        }
        let grid = Grid::with_counts(model.machine(), &[3, 3, 3]).unwrap();
        let z = model_zero_point(&model, &coeffs, &grid).unwrap();
        let text = z.report(model.machine(), grid.len());
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        let at: Vec<String> = model
            .machine()
            .axes()
            .iter()
            .zip(&z.positions)
            .map(|(a, &v)| format!("{}={:.3}", a.letter().as_char(), v * 1e3))
            .collect();
        assert_eq!(
            lines[0],
            format!("zero point  {} of 27 grid points", at.join(" "))
        );
        let o = z.zero_point.offset_um;
        assert_eq!(
            lines[1],
            format!("offset      [{:.3}, {:.3}, {:.3}] um", o[0], o[1], o[2])
        );
        let zp = &z.zero_point;
        assert_eq!(
            lines[2],
            format!(
                "sum |error| {:.1} um before, {:.1} um after (geometric median {:.1} um); max \
                 {:.3} um before, {:.3} um after",
                zp.sum_before_um,
                zp.sum_after_um,
                z.median.sum_um,
                zp.max_before_um,
                zp.max_after_um
            )
        );
    }

    fn vectors(raw: &[(f64, f64, f64)]) -> ErrorVectors {
        let d: Vec<[f64; 3]> = raw.iter().map(|&(x, y, z)| [x, y, z]).collect();
        ErrorVectors::new(&d)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn the_search_equals_the_naive_reference(
            raw in proptest::collection::vec((-30.0..30.0f64, -30.0..30.0f64, -5.0..5.0f64), 1..1500)
        ) {
            let d = vectors(&raw);
            let fast = zero_point(&d).unwrap();
            let naive = zero_point_naive(&d).unwrap();
            prop_assert_eq!(fast.index, naive.index);
            prop_assert_eq!(fast.sum_after_um, naive.sum_after_um);
            prop_assert_eq!(fast.max_after_um, naive.max_after_um);
            let median = geometric_median(&d, &WeiszfeldOptions::default()).unwrap();
            prop_assert!(median.sum_um <= naive.sum_after_um * (1.0 + 1e-12) + 1e-9,
                "median {} > discrete {}", median.sum_um, naive.sum_after_um);
        }
    }

    #[test]
    fn ties_and_duplicates_pick_the_smallest_index() {
        let d = vectors(&[
            (1.0, 0.0, 0.0),
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.0),
            (-1.0, 0.0, 0.0),
        ]);
        let z = zero_point(&d).unwrap();
        assert_eq!(z.index, 1);
        assert_eq!(z.sum_after_um, 2.0);
        assert_eq!(z.offset_um, [-0.0, -0.0, -0.0]);
        let m = geometric_median(&d, &WeiszfeldOptions::default()).unwrap();
        assert!(m.sum_um <= 2.0 + 1e-12, "{m:?}");
        assert!(zero_point(&vectors(&[])).is_none());
    }

    #[test]
    fn a_single_outlier_does_not_move_the_zero_point() {
        let mut raw = vec![(5.0, 5.0, 5.0); 10];
        raw.push((100.0, 0.0, 0.0));
        let z = zero_point(&vectors(&raw)).unwrap();
        assert_eq!(z.error_um, [5.0, 5.0, 5.0]);
        assert_eq!(z.max_after_um, dist([100.0, 0.0, 0.0], [5.0, 5.0, 5.0]));
        assert!(z.sum_after_um < z.sum_before_um);
    }
}
