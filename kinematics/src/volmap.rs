//! Volumetric error maps: the tool's pose error evaluated on a grid over the working volume, and
//! the statistics the sources report (source 004: a 10,164-point grid, maximum, share of points
//! under a threshold).
//!
//! A [`Grid`] spans the linear axes (`n` equally spaced points per axis between bounds that
//! default to the axis limits, both ends included) with the rotary axes held at given positions,
//! optionally repeated for a list of rotary positions (an orientation grid for five-axis
//! machines). [`volumetric_map`] evaluates [`MachineModel::pose_error_first_order`] (default)
//! or the exact [`MachineModel::pose_error`] at every point with one [`Workspace`] and
//! preallocated outputs: no allocation per point. First-order maps exploit the model's
//! structure (see [`volumetric_map`]): a 10,164-point five-axis map takes well under a
//! millisecond.
//!
//! Units: the map stores translations in µm and rotations in µrad (the model works in m, rad);
//! axis positions stay in m and rad.

use crate::machine::{AxisKind, Machine};
use crate::model::Role;
use crate::pose::{MachineModel, Workspace};
use nalgebra::Vector3;
use std::fmt;

/// Why a grid cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GridError {
    #[error("the machine has no axis {letter} (it has {letters})")]
    NoSuchAxis { letter: char, letters: String },
    #[error(
        "axis {letter} is rotary; grid bounds are for linear axes, rotary positions go in the \
         orientations"
    )]
    NotLinear { letter: char },
    #[error("{got} point counts given for {expected} linear axes ({letters})")]
    CountsLength {
        got: usize,
        expected: usize,
        letters: String,
    },
    #[error("axis {letter}: a grid needs at least one point per axis")]
    ZeroPoints { letter: char },
    #[error("axis {letter}: grid bounds must be finite with lower <= upper, got [{lo}, {hi}]")]
    BadBounds { letter: char, lo: f64, hi: f64 },
    #[error(
        "orientation {index}: {got} rotary positions given for the {expected} rotary axes \
         {letters}"
    )]
    OrientationLength {
        index: usize,
        got: usize,
        expected: usize,
        letters: String,
    },
    #[error("orientation {index}: rotary position {value} is not finite")]
    NotFinite { index: usize, value: f64 },
    #[error("an orientation grid needs at least one orientation")]
    NoOrientations,
    #[error(
        "the source-004 grid (21 × 22 × 22) needs exactly 3 linear axes; the machine has {letters}"
    )]
    NotThreeLinear { letters: String },
}

/// The points of one linear axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisRange {
    /// Index of the axis in [`Machine::axes`].
    pub axis: usize,
    pub letter: char,
    pub lo: f64,
    pub hi: f64,
    /// Number of points; 1 puts the single point at the middle of the bounds.
    pub n: usize,
}

impl AxisRange {
    /// Position of point `i` (0-based): `lo + (hi − lo)·i/(n − 1)`.
    #[inline]
    pub fn value(&self, i: usize) -> f64 {
        if self.n == 1 {
            0.5 * (self.lo + self.hi)
        } else if i + 1 == self.n {
            self.hi
        } else {
            self.lo + (self.hi - self.lo) * i as f64 / (self.n - 1) as f64
        }
    }
}

/// Grid of axis positions over the working volume.
///
/// Point order: orientations outermost; within an orientation the linear axes in canonical order
/// with the first one varying slowest and the last fastest (row-major).
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    letters: String,
    n_axes: usize,
    linear: Vec<AxisRange>,
    /// Machine indices of the rotary axes, canonical order.
    rotary: Vec<usize>,
    /// `n_orientations × rotary.len()`, row-major.
    orientations: Vec<f64>,
    n_orientations: usize,
    per_orientation: usize,
}

impl Grid {
    /// `n` points on every linear axis over its limits; rotary axes at 0.
    pub fn new(machine: &Machine, n: usize) -> Result<Self, GridError> {
        let n_linear = machine
            .axes()
            .iter()
            .filter(|a| a.kind() == AxisKind::Linear)
            .count();
        Self::with_counts(machine, &vec![n; n_linear])
    }

    /// `counts[k]` points on the k-th linear axis (canonical order) over its limits; rotary axes
    /// at 0.
    pub fn with_counts(machine: &Machine, counts: &[usize]) -> Result<Self, GridError> {
        let mut linear = Vec::new();
        let mut rotary = Vec::new();
        for (i, ax) in machine.axes().iter().enumerate() {
            match (ax.kind(), ax.limits()) {
                (AxisKind::Linear, Some((lo, hi))) => linear.push(AxisRange {
                    axis: i,
                    letter: ax.letter().as_char(),
                    lo,
                    hi,
                    n: 0,
                }),
                (AxisKind::Linear, None) => unreachable!("a validated linear axis has limits"),
                (AxisKind::Rotary, _) => rotary.push(i),
            }
        }
        if counts.len() != linear.len() {
            return Err(GridError::CountsLength {
                got: counts.len(),
                expected: linear.len(),
                letters: linear.iter().map(|r| r.letter).collect(),
            });
        }
        for (r, &n) in linear.iter_mut().zip(counts) {
            if n == 0 {
                return Err(GridError::ZeroPoints { letter: r.letter });
            }
            r.n = n;
        }
        let mut grid = Grid {
            letters: machine.letters(),
            n_axes: machine.n_axes(),
            linear,
            orientations: vec![0.0; rotary.len()],
            rotary,
            n_orientations: 1,
            per_orientation: 0,
        };
        grid.update_len();
        Ok(grid)
    }

    /// The grid of source 004: 21 × 22 × 22 = 10,164 points over the limits of the three
    /// linear axes (21 on the first in canonical order, usually X), rotary axes at 0.
    pub fn source004(machine: &Machine) -> Result<Self, GridError> {
        let n_linear = machine
            .axes()
            .iter()
            .filter(|a| a.kind() == AxisKind::Linear)
            .count();
        if n_linear != 3 {
            return Err(GridError::NotThreeLinear {
                letters: machine.letters(),
            });
        }
        Self::with_counts(machine, &[21, 22, 22])
    }

    /// Sets the bounds of linear axis `letter` (m), keeping its point count.
    pub fn with_bounds(mut self, letter: char, lo: f64, hi: f64) -> Result<Self, GridError> {
        let letters = self.letters.clone();
        let r = self
            .linear
            .iter_mut()
            .find(|r| r.letter == letter)
            .ok_or_else(|| {
                if letters.contains(letter) {
                    GridError::NotLinear { letter }
                } else {
                    GridError::NoSuchAxis { letter, letters }
                }
            })?;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(GridError::BadBounds { letter, lo, hi });
        }
        r.lo = lo;
        r.hi = hi;
        Ok(self)
    }

    /// Holds the rotary axes at `positions` (rad, rotary axes in canonical order).
    pub fn with_rotary(self, positions: &[f64]) -> Result<Self, GridError> {
        self.with_orientations(&[positions.to_vec()])
    }

    /// Repeats the linear grid for every entry of `orientations` (each: rad, rotary axes in
    /// canonical order).
    pub fn with_orientations(mut self, orientations: &[Vec<f64>]) -> Result<Self, GridError> {
        if orientations.is_empty() {
            return Err(GridError::NoOrientations);
        }
        let m = self.rotary.len();
        let mut flat = Vec::with_capacity(orientations.len() * m);
        for (index, o) in orientations.iter().enumerate() {
            if o.len() != m {
                return Err(GridError::OrientationLength {
                    index,
                    got: o.len(),
                    expected: m,
                    letters: self.rotary_letters(),
                });
            }
            if let Some(&value) = o.iter().find(|v| !v.is_finite()) {
                return Err(GridError::NotFinite { index, value });
            }
            flat.extend_from_slice(o);
        }
        self.orientations = flat;
        self.n_orientations = orientations.len();
        self.update_len();
        Ok(self)
    }

    fn rotary_letters(&self) -> String {
        let chars: Vec<char> = self.letters.chars().collect();
        self.rotary.iter().map(|&i| chars[i]).collect()
    }

    fn update_len(&mut self) {
        self.per_orientation = self.linear.iter().map(|r| r.n).product();
    }

    /// Total number of points.
    pub fn len(&self) -> usize {
        self.per_orientation * self.n_orientations
    }

    /// Never true: every axis has at least one point and there is at least one orientation.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The axis letters of the machine the grid was built for, canonical order.
    pub fn letters(&self) -> &str {
        &self.letters
    }

    pub fn n_axes(&self) -> usize {
        self.n_axes
    }

    /// The linear axes' ranges, canonical order.
    pub fn linear(&self) -> &[AxisRange] {
        &self.linear
    }

    pub fn n_orientations(&self) -> usize {
        self.n_orientations
    }

    /// Rotary positions of orientation `o` (rotary axes in canonical order).
    pub fn orientation(&self, o: usize) -> &[f64] {
        let m = self.rotary.len();
        &self.orientations[o * m..(o + 1) * m]
    }

    /// Writes the axis positions of point `k` into `q` (canonical order, `n_axes` long).
    ///
    /// # Panics
    /// If `k >= self.len()` or `q.len() != self.n_axes()`.
    pub fn point(&self, k: usize, q: &mut [f64]) {
        assert!(k < self.len(), "grid point {k} of {}", self.len());
        assert_eq!(q.len(), self.n_axes, "one position per axis");
        let (o, mut rest) = (k / self.per_orientation, k % self.per_orientation);
        for (&i, &v) in self.rotary.iter().zip(self.orientation(o)) {
            q[i] = v;
        }
        for r in self.linear.iter().rev() {
            q[r.axis] = r.value(rest % r.n);
            rest /= r.n;
        }
    }
}

/// Which pose error [`volumetric_map`] evaluates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MapMethod {
    /// [`MachineModel::pose_error_first_order`]: linear in the errors, the usual map.
    #[default]
    FirstOrder,
    /// [`MachineModel::pose_error`]: the full rigid-body chain.
    Exact,
}

/// Options of [`volumetric_map`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MapOptions {
    pub method: MapMethod,
    /// Evaluate the model at every point even for a first-order map (slow; for checks and
    /// benchmarks). By default a first-order map uses the separable evaluation described at
    /// [`volumetric_map`].
    pub pointwise: bool,
}

/// The pose error at every grid point, in grid order.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumetricMap {
    letters: Vec<char>,
    n_axes: usize,
    /// `len × n_axes`, m and rad.
    positions: Vec<f64>,
    translation_um: Vec<[f64; 3]>,
    magnitude_um: Vec<f64>,
    rotation_urad: Vec<[f64; 3]>,
    angle_urad: Vec<f64>,
}

/// One point of a [`VolumetricMap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint<'a> {
    /// Axis positions (m, rad), canonical order.
    pub q: &'a [f64],
    /// Translation error Δ in the workpiece frame, µm.
    pub translation_um: Vector3<f64>,
    /// |Δ|, µm.
    pub magnitude_um: f64,
    /// Rotation error (rotation vector) in the workpiece frame, µrad.
    pub rotation_urad: Vector3<f64>,
    /// Its magnitude, µrad.
    pub angle_urad: f64,
}

/// Evaluates the pose error of `model` with coefficients `coeffs` at every point of `grid`.
///
/// One [`Workspace`], outputs preallocated: no allocation per point.
///
/// # Separable first-order evaluation
/// The first-order pose error is linear in the coefficients, and with the rotary axes held every
/// frame of the chain keeps its orientation while its position is affine in the linear axis
/// positions. So the part of the error due to linear axis `i`'s own parameters (component errors,
/// squareness) is `a_i(q_i) + Σ_{j≠i} m_ij(q_i)·q_j`, and the part due to everything else
/// (rotary axes, locations, set-up) is affine in all linear positions. A first-order map
/// evaluates the model only to tabulate `a_i`, `m_ij` at the grid values of each axis (about
/// `Σ n_i · L` evaluations per orientation for `L` linear axes instead of `Π n_i`) and sums the
/// tables at each point; this is exact up to rounding. Each orientation is then checked against
/// direct evaluation at 8 grid points, and the whole map is recomputed point by point should a
/// check fail (a model change breaking the structure) or should the grid be too small for the
/// tables to pay off. [`MapOptions::pointwise`] forces direct evaluation.
///
/// # Panics
/// If the grid was built for a machine with other axes than `model`'s, or `coeffs` has the
/// wrong length.
///
/// [`Workspace`]: crate::pose::Workspace
pub fn volumetric_map(
    model: &MachineModel,
    coeffs: &[f64],
    grid: &Grid,
    opts: &MapOptions,
) -> VolumetricMap {
    let machine = model.machine();
    assert_eq!(
        grid.letters(),
        machine.letters(),
        "the grid was built for a machine with other axes"
    );
    assert_eq!(coeffs.len(), model.n_coeffs(), "one value per coefficient");
    let n = grid.len();
    let n_axes = machine.n_axes();
    let mut map = VolumetricMap {
        letters: machine.letters().chars().collect(),
        n_axes,
        positions: vec![0.0; n * n_axes],
        translation_um: vec![[0.0; 3]; n],
        magnitude_um: vec![0.0; n],
        rotation_urad: vec![[0.0; 3]; n],
        angle_urad: vec![0.0; n],
    };
    let mut ws = model.workspace();
    let separable = opts.method == MapMethod::FirstOrder && !opts.pointwise;
    if !(separable && fill_separable(model, coeffs, grid, &mut map, &mut ws)) {
        fill_pointwise(model, coeffs, grid, opts.method, &mut map, &mut ws);
    }
    map
}

/// Direct evaluation at every point.
fn fill_pointwise(
    model: &MachineModel,
    coeffs: &[f64],
    grid: &Grid,
    method: MapMethod,
    map: &mut VolumetricMap,
    ws: &mut Workspace,
) {
    let n_axes = map.n_axes;
    for k in 0..grid.len() {
        let q = &mut map.positions[k * n_axes..(k + 1) * n_axes];
        grid.point(k, q);
        let e = match method {
            MapMethod::FirstOrder => model.pose_error_first_order(q, coeffs, ws),
            MapMethod::Exact => model.pose_error(q, coeffs, ws),
        };
        map.store(k, &e.to_array());
    }
}

/// Grid points per orientation checked against direct evaluation in [`fill_separable`].
const SEPARABLE_CHECKS: usize = 8;

/// The separable first-order evaluation (see [`volumetric_map`]). Returns false, leaving the map
/// partly filled, if the grid is too small for it to pay off or a check fails.
fn fill_separable(
    model: &MachineModel,
    coeffs: &[f64],
    grid: &Grid,
    map: &mut VolumetricMap,
    ws: &mut Workspace,
) -> bool {
    let lin = grid.linear();
    let nl = lin.len();
    let per = grid.per_orientation;
    let evals = 1 + nl + lin.iter().map(|r| r.n * nl).sum::<usize>() + SEPARABLE_CHECKS;
    if evals >= per {
        return false;
    }
    // Coefficients split into groups: 0 = not tied to a linear axis, 1 + l = linear axis l's.
    let mut masks = vec![vec![0.0; coeffs.len()]; nl + 1];
    for p in model.errors().params() {
        let axis = match p.role {
            Role::Component { axis, .. } | Role::Location { axis, .. } => Some(axis),
            Role::ToolOffset(_) | Role::WorkpieceOffset(_) => None,
        };
        let g = axis
            .and_then(|a| lin.iter().position(|r| r.axis == a))
            .map_or(0, |l| l + 1);
        let range = p.offset..p.offset + p.len;
        masks[g][range.clone()].copy_from_slice(&coeffs[range]);
    }
    let base: Vec<f64> = lin.iter().map(|r| r.value(0)).collect();
    let top: Vec<f64> = lin.iter().map(|r| r.value(r.n - 1)).collect();
    let span: Vec<f64> = base.iter().zip(&top).map(|(b, t)| t - b).collect();
    let n_axes = map.n_axes;
    let mut q = vec![0.0; n_axes];
    let mut s0 = vec![[0.0; 6]; nl];
    let mut a: Vec<Vec<[f64; 6]>> = lin.iter().map(|r| vec![[0.0; 6]; r.n]).collect();
    let mut m: Vec<Vec<[f64; 6]>> = lin.iter().map(|r| vec![[0.0; 6]; r.n * nl]).collect();
    let (mut idx, mut d) = (vec![0usize; nl], vec![0.0; nl]);
    let mut eval = |mask: &[f64], q: &[f64]| model.pose_error_first_order(q, mask, ws).to_array();
    for o in 0..grid.n_orientations {
        for (&i, &v) in grid.rotary.iter().zip(grid.orientation(o)) {
            q[i] = v;
        }
        for (r, &b) in lin.iter().zip(&base) {
            q[r.axis] = b;
        }
        // Tables: the constant group at the base and its slopes, then each linear axis'.
        let c0 = eval(&masks[0], &q);
        for j in 0..nl {
            if span[j] > 0.0 {
                q[lin[j].axis] = top[j];
                s0[j] = slope(&eval(&masks[0], &q), &c0, span[j]);
                q[lin[j].axis] = base[j];
            }
        }
        for l in 0..nl {
            for k in 0..lin[l].n {
                q[lin[l].axis] = lin[l].value(k);
                let ak = eval(&masks[l + 1], &q);
                a[l][k] = ak;
                for j in (0..nl).filter(|&j| j != l && span[j] > 0.0) {
                    q[lin[j].axis] = top[j];
                    m[l][k * nl + j] = slope(&eval(&masks[l + 1], &q), &ak, span[j]);
                    q[lin[j].axis] = base[j];
                }
            }
            q[lin[l].axis] = base[l];
        }
        // Sum the tables at every point.
        for p in 0..per {
            let k = o * per + p;
            let pos = &mut map.positions[k * n_axes..(k + 1) * n_axes];
            for (&i, &v) in grid.rotary.iter().zip(grid.orientation(o)) {
                pos[i] = v;
            }
            let mut rest = p;
            for l in (0..nl).rev() {
                let r = &lin[l];
                idx[l] = rest % r.n;
                rest /= r.n;
                let v = r.value(idx[l]);
                pos[r.axis] = v;
                d[l] = v - base[l];
            }
            let mut e = c0;
            for l in 0..nl {
                add_scaled(&mut e, &s0[l], d[l]);
                add_scaled(&mut e, &a[l][idx[l]], 1.0);
                let ml = &m[l][idx[l] * nl..(idx[l] + 1) * nl];
                for j in (0..nl).filter(|&j| j != l) {
                    add_scaled(&mut e, &ml[j], d[j]);
                }
            }
            map.store(k, &e);
        }
        // Check against direct evaluation.
        for t in 0..SEPARABLE_CHECKS {
            let k = o * per + t * (per - 1) / (SEPARABLE_CHECKS - 1);
            grid.point(k, &mut q);
            let direct = eval(coeffs, &q);
            let table = map.point(k);
            let close = |got: Vector3<f64>, want: Vector3<f64>| {
                (got - want).norm() <= 1e-6 + 1e-9 * want.norm()
            };
            let want_t = Vector3::new(direct[0], direct[1], direct[2]) * 1e6;
            let want_r = Vector3::new(direct[3], direct[4], direct[5]) * 1e6;
            if !(close(table.translation_um, want_t) && close(table.rotation_urad, want_r)) {
                return false;
            }
        }
    }
    true
}

fn slope(hi: &[f64; 6], lo: &[f64; 6], span: f64) -> [f64; 6] {
    std::array::from_fn(|r| (hi[r] - lo[r]) / span)
}

#[inline]
fn add_scaled(acc: &mut [f64; 6], v: &[f64; 6], f: f64) {
    for (a, x) in acc.iter_mut().zip(v) {
        *a += x * f;
    }
}

impl VolumetricMap {
    /// Stores `[dx, dy, dz, ea, eb, ec]` (m, rad) at point `k`.
    #[inline]
    fn store(&mut self, k: usize, e: &[f64; 6]) {
        let t = [e[0] * 1e6, e[1] * 1e6, e[2] * 1e6];
        let r = [e[3] * 1e6, e[4] * 1e6, e[5] * 1e6];
        self.translation_um[k] = t;
        self.magnitude_um[k] = Vector3::from(t).norm();
        self.rotation_urad[k] = r;
        self.angle_urad[k] = Vector3::from(r).norm();
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.magnitude_um.len()
    }

    pub fn is_empty(&self) -> bool {
        self.magnitude_um.is_empty()
    }

    /// The machine's axis letters, canonical order.
    pub fn letters(&self) -> &[char] {
        &self.letters
    }

    /// Point `k`.
    pub fn point(&self, k: usize) -> MapPoint<'_> {
        MapPoint {
            q: self.positions(k),
            translation_um: Vector3::from(self.translation_um[k]),
            magnitude_um: self.magnitude_um[k],
            rotation_urad: Vector3::from(self.rotation_urad[k]),
            angle_urad: self.angle_urad[k],
        }
    }

    /// All points in grid order.
    pub fn iter(&self) -> impl Iterator<Item = MapPoint<'_>> + '_ {
        (0..self.len()).map(|k| self.point(k))
    }

    /// Axis positions of point `k` (m, rad), canonical order.
    pub fn positions(&self, k: usize) -> &[f64] {
        &self.positions[k * self.n_axes..(k + 1) * self.n_axes]
    }

    /// Translation errors Δ (µm, workpiece frame), grid order.
    pub fn translations_um(&self) -> &[[f64; 3]] {
        &self.translation_um
    }

    /// |Δ| (µm), grid order.
    pub fn magnitudes_um(&self) -> &[f64] {
        &self.magnitude_um
    }

    /// Rotation errors (µrad, workpiece frame), grid order.
    pub fn rotations_urad(&self) -> &[[f64; 3]] {
        &self.rotation_urad
    }

    /// Angular error magnitudes (µrad), grid order.
    pub fn angles_urad(&self) -> &[f64] {
        &self.angle_urad
    }

    /// Statistics of the map; `thresholds_um` are the levels for the share of points with
    /// `|Δ| ≤ threshold` (source 004 uses 5 and 30 µm).
    ///
    /// The P90 is the nearest-rank percentile ([`percentile_nearest_rank`]). An empty map gives
    /// zero counts and NaN statistics.
    pub fn summary(&self, thresholds_um: &[f64]) -> MapSummary {
        let n = self.len();
        let nan = f64::NAN;
        let (mut max_k, mut max) = (0, f64::NEG_INFINITY);
        let (mut sum, mut sum_sq) = (0.0, 0.0);
        for (k, &m) in self.magnitude_um.iter().enumerate() {
            if m > max {
                (max_k, max) = (k, m);
            }
            sum += m;
            sum_sq += m * m;
        }
        let mut max_abs = [0.0f64; 3];
        for t in &self.translation_um {
            for (a, v) in max_abs.iter_mut().zip(t) {
                *a = a.max(v.abs());
            }
        }
        let max_angle = self.angle_urad.iter().fold(0.0f64, |a, &b| a.max(b));
        let sum_sq_angle: f64 = self.angle_urad.iter().map(|a| a * a).sum();
        let shares = thresholds_um
            .iter()
            .map(|&threshold_um| {
                let count = self
                    .magnitude_um
                    .iter()
                    .filter(|&&m| m <= threshold_um)
                    .count();
                ThresholdShare {
                    threshold_um,
                    count,
                    share: if n == 0 { nan } else { count as f64 / n as f64 },
                }
            })
            .collect();
        let nf = n as f64;
        MapSummary {
            n_points: n,
            max_um: if n == 0 { nan } else { max },
            max_at: if n == 0 {
                Vec::new()
            } else {
                self.letters
                    .iter()
                    .copied()
                    .zip(self.positions(max_k).iter().copied())
                    .collect()
            },
            rms_um: (sum_sq / nf).sqrt(),
            mean_um: sum / nf,
            p90_um: percentile_nearest_rank(&self.magnitude_um, 90.0),
            shares,
            max_abs_component_um: if n == 0 { [nan; 3] } else { max_abs },
            max_angle_urad: if n == 0 { nan } else { max_angle },
            rms_angle_urad: (sum_sq_angle / nf).sqrt(),
        }
    }
}

/// The `p`-th percentile (0 < p ≤ 100) by the nearest-rank method: the smallest value `x` of the
/// data such that at least `p` % of the values are ≤ `x`, i.e. the value of rank
/// `⌈p/100 · N⌉` (1-based) in ascending order. NaN for empty data; `p` outside (0, 100] is
/// clamped to that range (p → 0 gives the minimum).
pub fn percentile_nearest_rank(values: &[f64], p: f64) -> f64 {
    let n = values.len();
    if n == 0 {
        return f64::NAN;
    }
    // The small guard keeps p·N/100 landing on an integer (e.g. 90 % of 10) from rounding up.
    let x = p.clamp(0.0, 100.0) / 100.0 * n as f64;
    let rank = ((x - 1e-9).ceil() as usize).clamp(1, n);
    let mut buf = values.to_vec();
    let (_, v, _) = buf.select_nth_unstable_by(rank - 1, f64::total_cmp);
    *v
}

/// Share of the points with `|Δ| ≤ threshold_um`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThresholdShare {
    pub threshold_um: f64,
    pub count: usize,
    /// `count / n_points`, 0..1.
    pub share: f64,
}

/// Statistics of a [`VolumetricMap`] (µm, µrad).
#[derive(Clone, Debug, PartialEq)]
pub struct MapSummary {
    pub n_points: usize,
    /// Largest |Δ|.
    pub max_um: f64,
    /// Where it occurs (first such point in grid order): axis letter and position (m, rad).
    pub max_at: Vec<(char, f64)>,
    /// Root mean square of |Δ|.
    pub rms_um: f64,
    /// Mean |Δ| (times `n_points`: the sum of |Δ| that source 004 compares).
    pub mean_um: f64,
    /// 90th percentile of |Δ|, nearest rank.
    pub p90_um: f64,
    /// Share of points with |Δ| ≤ each threshold, in the order given.
    pub shares: Vec<ThresholdShare>,
    /// Largest |Δx|, |Δy|, |Δz| (workpiece frame).
    pub max_abs_component_um: [f64; 3],
    /// Largest angular error magnitude.
    pub max_angle_urad: f64,
    /// Root mean square of the angular error magnitude.
    pub rms_angle_urad: f64,
}

impl fmt::Display for MapSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let at: Vec<String> = self
            .max_at
            .iter()
            .map(|&(c, v)| {
                if matches!(c, 'A' | 'B' | 'C') {
                    format!("{c} {:.3}°", v.to_degrees())
                } else {
                    format!("{c} {:.3} mm", v * 1e3)
                }
            })
            .collect();
        let [ax, ay, az] = self.max_abs_component_um;
        let row = |f: &mut fmt::Formatter<'_>, label: &str, value: f64, unit: &str| {
            write!(f, "\n  {label:<20}{value:>10.2} {unit}")
        };
        write!(f, "volumetric map: {} points", self.n_points)?;
        row(f, "max |Δ|", self.max_um, "µm")?;
        write!(f, "   at {}", at.join(", "))?;
        row(f, "RMS |Δ|", self.rms_um, "µm")?;
        row(f, "mean |Δ|", self.mean_um, "µm")?;
        row(f, "P90 |Δ|", self.p90_um, "µm")?;
        write!(f, "   (nearest rank)")?;
        write!(
            f,
            "\n  {:<20}{ax:>10.2} {ay:.2} {az:.2} µm",
            "max |Δx| |Δy| |Δz|"
        )?;
        row(f, "max angle", self.max_angle_urad, "µrad")?;
        row(f, "RMS angle", self.rms_angle_urad, "µrad")?;
        for s in &self.shares {
            let label = format!("|Δ| ≤ {:.2} µm", s.threshold_um);
            write!(
                f,
                "\n  {label:<20}{:>10.1} %    ({} of {} points)",
                s.share * 100.0,
                s.count,
                self.n_points
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::Basis;
    use crate::machine::{BranchSpec, JointSpec, MachineSpec};
    use crate::model::{BasisChoice, ParamConfig, iso_full_config};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use proptest::prelude::*;

    fn joint(letter: char, axis: [f64; 3], at: [f64; 3], limits: Option<(f64, f64)>) -> JointSpec {
        JointSpec {
            letter,
            kind: if "ABC".contains(letter) {
                AxisKind::Rotary
            } else {
                AxisKind::Linear
            },
            origin: Isometry3::from_parts(
                Translation3::from(Vector3::from(at)),
                UnitQuaternion::identity(),
            ),
            axis: Vector3::from(axis),
            limits,
        }
    }

    fn machine(wp: Vec<JointSpec>, tool: Vec<JointSpec>) -> Machine {
        Machine::try_new(&MachineSpec {
            name: "test".into(),
            workpiece: BranchSpec {
                joints: wp,
                end: Isometry3::identity(),
            },
            tool: BranchSpec {
                joints: tool,
                end: Isometry3::translation(0.0, 0.0, -0.1),
            },
        })
        .unwrap()
    }

    /// wXFYZt: X table (−0.4..0.4 m), Y and Z in the tool branch.
    fn three_axis() -> Machine {
        machine(
            vec![joint('X', [-1., 0., 0.], [0.; 3], Some((-0.4, 0.4)))],
            vec![
                joint('Y', [0., 1., 0.], [0.; 3], Some((-0.3, 0.3))),
                joint('Z', [0., 0., 1.], [0., 0., 0.3], Some((-0.25, 0.25))),
            ],
        )
    }

    /// wCAFYXZt trunnion with pivot offsets.
    fn trunnion() -> Machine {
        machine(
            vec![
                joint('A', [-1., 0., 0.], [0.01, -0.02, 0.2], Some((-2.0, 0.6))),
                joint('C', [0., 0., -1.], [0.005, 0.01, -0.05], None),
            ],
            vec![
                joint('Y', [0., 1., 0.], [0.; 3], Some((-0.3, 0.3))),
                joint('X', [1., 0., 0.], [0.; 3], Some((-0.4, 0.4))),
                joint('Z', [0., 0., 1.], [0., 0., 0.4], Some((-0.25, 0.25))),
            ],
        )
    }

    /// The full ISO model (41 errors for a five-axis machine) with cubic Legendre / 3-harmonic
    /// Fourier bases, and deterministic pseudo-random coefficients of size `scale`.
    fn full_model(m: Machine, scale: f64) -> (MachineModel, Vec<f64>) {
        let config = iso_full_config(
            &m,
            &BasisChoice::Legendre { degree: 3 },
            &BasisChoice::Fourier { harmonics: 3 },
        )
        .unwrap();
        let model = MachineModel::new(m, &config).unwrap();
        let coeffs = (0..model.n_coeffs())
            .map(|k| scale * ((k as f64 * 0.7548776662).fract() * 2.0 - 1.0))
            .collect();
        (model, coeffs)
    }

    fn orientation_grid(m: &Machine, n: usize) -> Grid {
        Grid::new(m, n)
            .unwrap()
            .with_orientations(&[vec![0.0, 0.0], vec![-0.5, 1.0], vec![0.4, -2.5]])
            .unwrap()
    }

    #[test]
    fn grid_layout_and_source004() {
        let m = three_axis();
        let g = Grid::source004(&m).unwrap();
        assert_eq!(g.len(), 10_164);
        let mut q = [0.0; 3];
        g.point(0, &mut q);
        assert_eq!(q, [-0.4, -0.3, -0.25]);
        g.point(1, &mut q);
        assert_eq!(q[..2], [-0.4, -0.3]);
        assert!((q[2] - (-0.25 + 0.5 / 21.0)).abs() < 1e-15);
        g.point(g.len() - 1, &mut q);
        assert_eq!(q, [0.4, 0.3, 0.25]);
        assert_eq!(
            g.linear().iter().map(|r| r.n).collect::<Vec<_>>(),
            [21, 22, 22]
        );

        let t = trunnion();
        let g = orientation_grid(&t, 2).with_bounds('X', 0.0, 0.1).unwrap();
        assert_eq!(g.len(), 3 * 8);
        let mut q = [0.0; 5];
        g.point(8 + 7, &mut q);
        assert_eq!(q, [0.1, 0.3, 0.25, -0.5, 1.0]);
        let g1 = Grid::with_counts(&t, &[1, 2, 3]).unwrap();
        g1.point(0, &mut q);
        assert_eq!(q[0], 0.0); // one point: the middle

        assert_eq!(
            Grid::new(&t, 2).unwrap().with_bounds('A', 0.0, 1.0),
            Err(GridError::NotLinear { letter: 'A' })
        );
        assert!(matches!(
            Grid::new(&t, 2).unwrap().with_bounds('W', 0.0, 1.0),
            Err(GridError::NoSuchAxis { letter: 'W', .. })
        ));
        assert!(matches!(
            Grid::new(&t, 2).unwrap().with_bounds('X', 1.0, 0.0),
            Err(GridError::BadBounds { .. })
        ));
        assert!(matches!(
            Grid::new(&t, 0),
            Err(GridError::ZeroPoints { letter: 'X' })
        ));
        assert!(matches!(
            Grid::new(&t, 2).unwrap().with_rotary(&[0.0]),
            Err(GridError::OrientationLength { expected: 2, .. })
        ));
        assert!(matches!(
            Grid::new(&t, 2).unwrap().with_rotary(&[0.0, f64::NAN]),
            Err(GridError::NotFinite { .. })
        ));
        assert_eq!(
            Grid::new(&t, 2).unwrap().with_orientations(&[]),
            Err(GridError::NoOrientations)
        );
    }

    #[test]
    fn zero_coefficients_give_a_zero_map() {
        let (model, coeffs) = full_model(trunnion(), 0.0);
        let grid = orientation_grid(model.machine(), 4);
        let fo = volumetric_map(&model, &coeffs, &grid, &MapOptions::default());
        assert_eq!(fo.len(), grid.len());
        assert!(
            fo.iter()
                .all(|p| p.magnitude_um == 0.0 && p.angle_urad == 0.0)
        );
        let ex = volumetric_map(
            &model,
            &coeffs,
            &grid,
            &MapOptions {
                method: MapMethod::Exact,
                ..MapOptions::default()
            },
        );
        assert!(
            ex.iter()
                .all(|p| p.magnitude_um < 1e-9 && p.angle_urad < 1e-9)
        );
        let s = fo.summary(&[0.0]);
        assert_eq!((s.max_um, s.rms_um, s.p90_um), (0.0, 0.0, 0.0));
        assert_eq!(s.shares[0].share, 1.0);
    }

    #[test]
    fn linear_scale_error_by_hand() {
        // EXX = s·x on a 3-axis machine (X ∈ [−0.4, 0.4]): P1(u) = x/0.4, coefficient 0.4·s.
        let s = 1e-5; // 10 µm/m
        let m = three_axis();
        let config = [ParamConfig {
            name: "EXX".parse().unwrap(),
            basis: Some(Basis::legendre(-0.4, 0.4, 1, 1).unwrap()),
        }];
        let model = MachineModel::new(m, &config).unwrap();
        let coeffs = [0.4 * s];
        // x ∈ {−0.4, −0.2, 0, 0.2, 0.4}, 2 × 2 points in Y, Z: |Δ| = 4, 2, 0, 2, 4 µm, 4 each.
        let grid = Grid::with_counts(model.machine(), &[5, 2, 2]).unwrap();
        for method in [MapMethod::FirstOrder, MapMethod::Exact] {
            let opts = MapOptions {
                method,
                ..MapOptions::default()
            };
            let map = volumetric_map(&model, &coeffs, &grid, &opts);
            for p in map.iter() {
                let expected = s * p.q[0] * 1e6;
                assert!((p.translation_um - Vector3::new(expected, 0.0, 0.0)).norm() < 1e-9);
                assert!((p.magnitude_um - expected.abs()).abs() < 1e-9);
                assert!(p.angle_urad < 1e-12);
            }
            let sum = map.summary(&[1e-6, 1.0, 3.0, 10.0]);
            assert_eq!(sum.n_points, 20);
            assert!((sum.max_um - 4.0).abs() < 1e-9);
            // The first maximum in grid order: the negative stroke end.
            assert_eq!(sum.max_at[0], ('X', -0.4));
            assert!((sum.rms_um - 8f64.sqrt()).abs() < 1e-9); // sqrt((16+4+0+4+16)/5)
            assert!((sum.mean_um - 2.4).abs() < 1e-9); // (4+2+0+2+4)/5
            // Nearest rank: ⌈0.9·20⌉ = 18th of 0×4, 2×8, 4×8 → 4.
            assert!((sum.p90_um - 4.0).abs() < 1e-9);
            let shares: Vec<f64> = sum.shares.iter().map(|t| t.share).collect();
            assert_eq!(shares, [0.2, 0.2, 0.6, 1.0]);
            assert!((sum.max_abs_component_um[0] - 4.0).abs() < 1e-9);
            assert!(sum.max_abs_component_um[1] < 1e-12 && sum.max_abs_component_um[2] < 1e-12);
            let text = sum.to_string();
            assert!(
                text.contains("20 points") && text.contains("4.00 µm"),
                "{text}"
            );
            assert!(text.contains("X -400.000 mm"), "{text}");
        }
    }

    #[test]
    fn exact_and_first_order_agree_to_second_order() {
        let grid = orientation_grid(&trunnion(), 3);
        let diff = |scale: f64| {
            let (model, coeffs) = full_model(trunnion(), scale);
            let fo = volumetric_map(&model, &coeffs, &grid, &MapOptions::default());
            let ex = volumetric_map(
                &model,
                &coeffs,
                &grid,
                &MapOptions {
                    method: MapMethod::Exact,
                    ..MapOptions::default()
                },
            );
            let size = ex.summary(&[]).max_um;
            let d = fo
                .iter()
                .zip(ex.iter())
                .map(|(a, b)| {
                    (a.translation_um - b.translation_um)
                        .norm()
                        .max((a.rotation_urad - b.rotation_urad).norm())
                })
                .fold(0.0, f64::max);
            (d, size)
        };
        let (d1, size1) = diff(1e-5);
        let (d2, size2) = diff(2e-5);
        assert!(size1 > 1.0, "the errors are visible: {size1} µm");
        assert!(d1 < 1e-2 * size1, "second order is small: {d1} vs {size1}");
        let ratio = d2 / d1;
        assert!(
            (3.5..4.5).contains(&ratio),
            "quadratic: ratio {ratio}, sizes {size1} {size2}"
        );
    }

    /// wYXFZCAt head-head with tilted joint origins and offsets.
    fn head_head() -> Machine {
        let mut spec = machine(
            vec![
                joint('X', [-1., 0., 0.], [0.; 3], Some((-0.4, 0.4))),
                joint('Y', [0., -1., 0.], [0.; 3], Some((-0.3, 0.3))),
            ],
            vec![
                joint('Z', [0., 0., 1.], [0., 0., 0.5], Some((-0.25, 0.25))),
                joint('C', [0., 0., 1.], [0.01, 0.0, -0.1], None),
                joint('A', [1., 0., 0.], [0.0, 0.02, -0.15], Some((-2.0, 2.0))),
            ],
        )
        .to_spec();
        for (k, j) in spec
            .tool
            .joints
            .iter_mut()
            .chain(&mut spec.workpiece.joints)
            .enumerate()
        {
            let r = Vector3::new(0.003 * k as f64, -0.002, 0.001 * (k % 2) as f64);
            j.origin.rotation = UnitQuaternion::from_scaled_axis(r);
        }
        Machine::try_new(&spec).unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn separable_first_order_equals_pointwise(
            which in 0..3usize,
            coeffs in prop::collection::vec(-1e-5..1e-5f64, 200),
            counts in prop::collection::vec(2..7usize, 3),
            orient in prop::collection::vec(-2.0..2.0f64, 4),
        ) {
            let m = [three_axis(), trunnion(), head_head()][which].clone();
            let (model, _) = full_model(m, 0.0);
            let coeffs = &coeffs[..model.n_coeffs()];
            let counts = [counts[0] + 5, counts[1] + 5, counts[2]];
            let mut grid = Grid::with_counts(model.machine(), &counts)
                .unwrap()
                .with_bounds('Y', -0.1, 0.25)
                .unwrap();
            if which > 0 {
                grid = grid
                    .with_orientations(&[orient[..2].to_vec(), orient[2..].to_vec()])
                    .unwrap();
            }
            let slow = volumetric_map(
                &model,
                coeffs,
                &grid,
                &MapOptions {
                    pointwise: true,
                    ..MapOptions::default()
                },
            );
            let mut fast = slow.clone();
            fast.positions.fill(f64::NAN);
            fast.translation_um.fill([f64::NAN; 3]);
            prop_assert!(fill_separable(&model, coeffs, &grid, &mut fast, &mut model.workspace()));
            prop_assert_eq!(&fast, &volumetric_map(&model, coeffs, &grid, &MapOptions::default()));
            for (a, b) in fast.iter().zip(slow.iter()) {
                prop_assert_eq!(a.q, b.q);
                prop_assert!((a.translation_um - b.translation_um).norm() < 1e-8);
                prop_assert!((a.rotation_urad - b.rotation_urad).norm() < 1e-8);
            }
        }
    }

    fn map_from(values: &[f64]) -> VolumetricMap {
        let n = values.len();
        VolumetricMap {
            letters: vec!['X'],
            n_axes: 1,
            positions: (0..n).map(|k| k as f64).collect(),
            translation_um: values.iter().map(|&v| [v, 0.0, 0.0]).collect(),
            magnitude_um: values.to_vec(),
            rotation_urad: vec![[0.0; 3]; n],
            angle_urad: vec![0.0; n],
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        #[test]
        fn percentiles_and_shares_match_brute_force(
            values in prop::collection::vec(
                prop_oneof![0.0..50.0f64, prop::sample::select(vec![0.0, 5.0, 10.0, 30.0])],
                1..200,
            ),
            p in prop_oneof![0.01..100.0f64, prop::sample::select(vec![10.0, 50.0, 90.0, 100.0])],
            thresholds in prop::collection::vec(
                prop_oneof![0.0..60.0f64, prop::sample::select(vec![5.0, 30.0])],
                0..4,
            ),
        ) {
            let n = values.len();
            let mut sorted = values.clone();
            sorted.sort_by(f64::total_cmp);
            // Smallest data value with at least p % of the data ≤ it.
            let at_least = |share: f64| {
                *sorted
                    .iter()
                    .find(|&&x| {
                        let count = sorted.iter().filter(|&&y| y <= x).count() as f64;
                        100.0 * count >= share * n as f64 - 1e-7
                    })
                    .unwrap()
            };
            prop_assert_eq!(percentile_nearest_rank(&values, p), at_least(p));
            let s = map_from(&values).summary(&thresholds);
            prop_assert_eq!(s.p90_um, at_least(90.0));
            prop_assert_eq!(s.max_um, sorted[n - 1]);
            let rms = (values.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            prop_assert!((s.rms_um - rms).abs() <= 1e-12 * (1.0 + rms));
            for (t, share) in thresholds.iter().zip(&s.shares) {
                let count = values.iter().filter(|&&v| v <= *t).count();
                prop_assert_eq!(share.count, count);
                prop_assert_eq!(share.share, count as f64 / n as f64);
            }
        }
    }

    /// `cargo test --release -p mtcal-kinematics volmap::tests::timing -- --ignored --nocapture`
    #[test]
    #[ignore = "timing; run in release"]
    fn timing_source004_five_axis() {
        let (model, coeffs) = full_model(trunnion(), 1e-5);
        let grid = Grid::source004(model.machine())
            .unwrap()
            .with_rotary(&[-0.3, 0.7])
            .unwrap();
        for (method, pointwise) in [
            (MapMethod::FirstOrder, false),
            (MapMethod::FirstOrder, true),
            (MapMethod::Exact, true),
        ] {
            let opts = MapOptions { method, pointwise };
            let mut best = f64::INFINITY;
            let mut map = volumetric_map(&model, &coeffs, &grid, &opts);
            for _ in 0..20 {
                let t0 = std::time::Instant::now();
                map = volumetric_map(&model, &coeffs, &grid, &opts);
                best = best.min(t0.elapsed().as_secs_f64() * 1e3);
            }
            let t0 = std::time::Instant::now();
            let summary = map.summary(&[5.0, 30.0]);
            let summary_ms = t0.elapsed().as_secs_f64() * 1e3;
            if !pointwise {
                println!("{summary}");
            }
            println!(
                "{method:?} (pointwise: {pointwise}): {} points, {} coefficients: map {best:.3} ms \
                 (best of 20), summary {summary_ms:.3} ms; max {:.1} µm",
                grid.len(),
                model.n_coeffs(),
                summary.max_um
            );
        }
    }
}
