//! ISO 230-2:2014 evaluation of bidirectional positioning runs: a pure function on a table of
//! deviations per target and approach direction ([`iso230_2`]), the expanded uncertainty of
//! its values ([`Iso230_2::uncertainty`]), the grouping of a run's samples into that table by
//! the motion ([`approach_table`]) and the plugin's `evaluate`.
//!
//! # The uncertainty budget
//! In the spirit of ISO 230-2:2014 Annex A and ISO/TR 230-9 (GUM propagation, `U = k·u` with
//! `k = 2`), with the terms mtcal knows from the run itself (docs/ACCEPTANCE.md lists what is
//! left out: the device's calibration, the environment, misalignment):
//! - each mean `x̄` of `n` approaches has the standard uncertainty `σ_eff/√n`, and each
//!   standard deviation `s` the uncertainty `σ_eff/√(2(n − 1))` (GUM, the dispersion of an
//!   experimental standard deviation of a normal sample), with `σ_eff = max(s, σ)`: the
//!   repeatability `s` of that target and direction, but never less than the reading noise `σ`
//!   the set-up declares (`sigma_um`), since two to five approaches may scatter less than the
//!   instrument by chance. The reading noise is part of the scatter `s`, so it is not added a
//!   second time;
//! - every axis value is, near the data, a linear function of a few means and standard
//!   deviations: a range `max − min` of the two extreme ones (E, M, A), a largest one (R, B) or
//!   all of them (B̄). Its variance is the sum of their squared sensitivities times their
//!   variances (different targets and directions are independent samples; a mean and a
//!   standard deviation of one normal sample are independent). Which target is the extreme is
//!   taken as found: where two means are within about their uncertainty of each other the
//!   range is biased high by the noise and the budget does not say so.

use crate::setup::{LaserSetup, Mode};
use mtcal_instrument::{Evaluation, Metric, Setup as _, Unit};

/// Commanded positions closer than this (m) are the same target.
pub const TARGET_TOL: f64 = 1e-7;

/// Deviations `x_ij = P_ij − P_i` (measured − target) at each target `i`, by approach
/// direction: `up` = approached moving in the positive direction (↑), `down` = negative (↓).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Approaches {
    /// Target positions, ascending (any unit; the deviations' unit is independent).
    pub targets: Vec<f64>,
    pub up: Vec<Vec<f64>>,
    pub down: Vec<Vec<f64>>,
}

/// The statistics of one target (ISO 230-2:2014, 3.x and 4.x; deviations in the table's unit).
#[derive(Clone, Debug, PartialEq)]
pub struct TargetStats {
    pub target: f64,
    /// x̄↑_i, x̄↓_i: mean unidirectional positioning deviations.
    pub mean_up: f64,
    pub mean_down: f64,
    /// x̄_i = (x̄↑_i + x̄↓_i)/2: mean bidirectional positioning deviation.
    pub mean: f64,
    /// s↑_i, s↓_i: estimators of the unidirectional standard uncertainty (n − 1).
    pub s_up: f64,
    pub s_down: f64,
    /// n↑_i, n↓_i: the number of approaches in each direction.
    pub n_up: usize,
    pub n_down: usize,
    /// B_i = x̄↑_i − x̄↓_i: reversal value.
    pub reversal: f64,
    /// R↑_i = 4 s↑_i, R↓_i = 4 s↓_i: unidirectional repeatability.
    pub r_up: f64,
    pub r_down: f64,
    /// R_i = max(2 s↑_i + 2 s↓_i + |B_i|, R↑_i, R↓_i): bidirectional repeatability.
    pub r: f64,
}

/// The axis values of ISO 230-2:2014 (deviations in the table's unit).
#[derive(Clone, Debug, PartialEq)]
pub struct Iso230_2 {
    pub targets: Vec<TargetStats>,
    /// B = max |B_i|: reversal value of the axis.
    pub b: f64,
    /// B̄ = Σ B_i / m: mean reversal value (signed).
    pub b_mean: f64,
    /// R↑ = max R↑_i, R↓ = max R↓_i, R = max R_i.
    pub r_up: f64,
    pub r_down: f64,
    pub r: f64,
    /// E↑ = max x̄↑_i − min x̄↑_i, E↓ likewise: unidirectional systematic positioning error.
    pub e_up: f64,
    pub e_down: f64,
    /// E = max(x̄↑_i, x̄↓_i) − min(x̄↑_i, x̄↓_i) over all i: bidirectional systematic
    /// positioning error.
    pub e: f64,
    /// M = max x̄_i − min x̄_i: range of the mean bidirectional positioning deviation.
    pub m: f64,
    /// A↑ = max(x̄↑_i + 2 s↑_i) − min(x̄↑_i − 2 s↑_i), A↓ likewise: unidirectional accuracy.
    pub a_up: f64,
    pub a_down: f64,
    /// A = max(x̄↑_i + 2 s↑_i, x̄↓_i + 2 s↓_i) − min(x̄↑_i − 2 s↑_i, x̄↓_i − 2 s↓_i):
    /// bidirectional accuracy.
    pub a: f64,
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// The estimator of the standard uncertainty, `√(Σ (x − x̄)² / (n − 1))`.
fn std_n1(x: &[f64], m: f64) -> f64 {
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
}

fn range(it: impl Iterator<Item = f64> + Clone) -> f64 {
    it.clone().fold(f64::NEG_INFINITY, f64::max) - it.fold(f64::INFINITY, f64::min)
}

/// Why a bidirectional table cannot be evaluated to ISO 230-2.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Iso230_2Error {
    #[error(
        "need at least one target with deviations in both directions ({targets} targets, {up} ↑ \
         lists, {down} ↓ lists)"
    )]
    Shape {
        targets: usize,
        up: usize,
        down: usize,
    },
    #[error(
        "target {number} ({position}) has {up} ↑ and {down} ↓ approaches; ISO 230-2 needs at \
         least 2 each"
    )]
    TooFewApproaches {
        /// 1-based, in table order.
        number: usize,
        position: f64,
        up: usize,
        down: usize,
    },
}

/// The ISO 230-2:2014 evaluation of a bidirectional table. Every target needs at least two
/// approaches in each direction (the error names the target otherwise), and there must be at
/// least one target.
pub fn iso230_2(table: &Approaches) -> Result<Iso230_2, Iso230_2Error> {
    let m = table.targets.len();
    if m == 0 || table.up.len() != m || table.down.len() != m {
        return Err(Iso230_2Error::Shape {
            targets: m,
            up: table.up.len(),
            down: table.down.len(),
        });
    }
    let mut targets = Vec::with_capacity(m);
    for i in 0..m {
        let (up, down) = (&table.up[i], &table.down[i]);
        if up.len() < 2 || down.len() < 2 {
            return Err(Iso230_2Error::TooFewApproaches {
                number: i + 1,
                position: table.targets[i],
                up: up.len(),
                down: down.len(),
            });
        }
        let (mu, md) = (mean(up), mean(down));
        let (su, sd) = (std_n1(up, mu), std_n1(down, md));
        let b = mu - md;
        let (ru, rd) = (4.0 * su, 4.0 * sd);
        targets.push(TargetStats {
            target: table.targets[i],
            mean_up: mu,
            mean_down: md,
            mean: 0.5 * (mu + md),
            s_up: su,
            s_down: sd,
            n_up: up.len(),
            n_down: down.len(),
            reversal: b,
            r_up: ru,
            r_down: rd,
            r: (2.0 * su + 2.0 * sd + b.abs()).max(ru).max(rd),
        });
    }
    let t = &targets;
    let max = |f: &dyn Fn(&TargetStats) -> f64| t.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
    let min = |f: &dyn Fn(&TargetStats) -> f64| t.iter().map(f).fold(f64::INFINITY, f64::min);
    let both = t.iter().flat_map(|s| [s.mean_up, s.mean_down]);
    Ok(Iso230_2 {
        b: max(&|s| s.reversal.abs()),
        b_mean: t.iter().map(|s| s.reversal).sum::<f64>() / m as f64,
        r_up: max(&|s| s.r_up),
        r_down: max(&|s| s.r_down),
        r: max(&|s| s.r),
        e_up: range(t.iter().map(|s| s.mean_up)),
        e_down: range(t.iter().map(|s| s.mean_down)),
        e: range(both),
        m: range(t.iter().map(|s| s.mean)),
        a_up: max(&|s| s.mean_up + 2.0 * s.s_up) - min(&|s| s.mean_up - 2.0 * s.s_up),
        a_down: max(&|s| s.mean_down + 2.0 * s.s_down) - min(&|s| s.mean_down - 2.0 * s.s_down),
        a: max(&|s| (s.mean_up + 2.0 * s.s_up).max(s.mean_down + 2.0 * s.s_down))
            - min(&|s| (s.mean_up - 2.0 * s.s_up).min(s.mean_down - 2.0 * s.s_down)),
        targets,
    })
}

/// The coverage factor of [`Iso230_2Uncertainty`]: `U = 2·u`.
pub const COVERAGE: f64 = 2.0;

/// The expanded uncertainties `U = 2·u` of the axis values of an [`Iso230_2`], field by field
/// (the table's unit); the budget is the module doc's.
#[derive(Clone, Debug, PartialEq)]
pub struct Iso230_2Uncertainty {
    pub a_up: f64,
    pub a_down: f64,
    pub a: f64,
    pub e_up: f64,
    pub e_down: f64,
    pub e: f64,
    pub m: f64,
    pub r_up: f64,
    pub r_down: f64,
    pub r: f64,
    pub b: f64,
    pub b_mean: f64,
}

/// How an axis value moves with the mean and the standard deviation of one target and
/// direction: the sensitivity coefficients of the budget.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sensitivity {
    target: usize,
    up: bool,
    to_mean: f64,
    to_s: f64,
}

const BOTH: [bool; 2] = [true, false];

impl TargetStats {
    /// (x̄, s, n) of one direction.
    fn direction(&self, up: bool) -> (f64, f64, usize) {
        if up {
            (self.mean_up, self.s_up, self.n_up)
        } else {
            (self.mean_down, self.s_down, self.n_down)
        }
    }
}

impl Iso230_2 {
    /// The axis values as metrics, `scale` from the table's unit to SI (1e-6 for µm, 1e-3
    /// for mm, 1 for m), reported in µm: `A↑ (ISO 230-2)`, `A↓`, `A`, `E↑`, `E↓`, `E`, `M`,
    /// `R↑`, `R↓`, `R`, `B`, `B̄` (mean reversal, signed). No uncertainty: see
    /// [`Self::metrics_with_uncertainty`].
    pub fn metrics(&self, scale: f64) -> Vec<Metric> {
        self.named()
            .into_iter()
            .map(|(name, v)| Metric::new(format!("{name} (ISO 230-2)"), v * scale, Unit::Um))
            .collect()
    }

    /// [`Self::metrics`], each with its expanded uncertainty from `u` (the same unit as the
    /// table, scaled alike).
    pub fn metrics_with_uncertainty(&self, scale: f64, u: &Iso230_2Uncertainty) -> Vec<Metric> {
        let mut metrics = self.metrics(scale);
        for (m, u) in metrics.iter_mut().zip(u.in_order()) {
            m.u95 = Some(u * scale);
        }
        metrics
    }

    /// The values in the order of [`Self::metrics`], with their symbols.
    fn named(&self) -> [(&'static str, f64); 12] {
        [
            ("A↑", self.a_up),
            ("A↓", self.a_down),
            ("A", self.a),
            ("E↑", self.e_up),
            ("E↓", self.e_down),
            ("E", self.e),
            ("M", self.m),
            ("R↑", self.r_up),
            ("R↓", self.r_down),
            ("R", self.r),
            ("B", self.b),
            ("B̄", self.b_mean),
        ]
    }

    /// The expanded uncertainty (k = [`COVERAGE`]) of every axis value, the readings' noise
    /// being `reading_sigma` (standard deviation of one reading, the table's unit): the budget
    /// of the module doc.
    pub fn uncertainty(&self, reading_sigma: f64) -> Iso230_2Uncertainty {
        let u = |terms: Vec<Sensitivity>| COVERAGE * self.variance(&terms, reading_sigma).sqrt();
        let mean = |t: &TargetStats, up: bool| t.direction(up).0;
        let top = |t: &TargetStats, up: bool| t.direction(up).0 + 2.0 * t.direction(up).1;
        let bottom = |t: &TargetStats, up: bool| t.direction(up).0 - 2.0 * t.direction(up).1;
        // E: max x̄ − min x̄; A: max(x̄ + 2s) − min(x̄ − 2s), so each end moves with 2s.
        let e = |dirs: &[bool]| self.range_terms(dirs, &mean, &mean, 0.0);
        let a = |dirs: &[bool]| self.range_terms(dirs, &top, &bottom, 2.0);
        Iso230_2Uncertainty {
            a_up: u(a(&[true])),
            a_down: u(a(&[false])),
            a: u(a(&BOTH)),
            e_up: u(e(&[true])),
            e_down: u(e(&[false])),
            e: u(e(&BOTH)),
            m: u(self.m_terms()),
            r_up: u(self.largest_s_terms(true)),
            r_down: u(self.largest_s_terms(false)),
            r: u(self.r_terms()),
            b: u(self.b_terms()),
            b_mean: u(self.b_mean_terms()),
        }
    }

    /// `max hi − min lo` over the targets in directions `dirs`, each end moving with its
    /// sample's standard deviation by `to_s`.
    fn range_terms(
        &self,
        dirs: &[bool],
        hi: &dyn Fn(&TargetStats, bool) -> f64,
        lo: &dyn Fn(&TargetStats, bool) -> f64,
        to_s: f64,
    ) -> Vec<Sensitivity> {
        let (i, ui) = self.extreme(dirs, true, hi);
        let (j, uj) = self.extreme(dirs, false, lo);
        vec![
            Sensitivity {
                target: i,
                up: ui,
                to_mean: 1.0,
                to_s,
            },
            Sensitivity {
                target: j,
                up: uj,
                to_mean: -1.0,
                to_s,
            },
        ]
    }

    /// R↑ = 4 s↑ at the largest (R↓ likewise).
    fn largest_s_terms(&self, up: bool) -> Vec<Sensitivity> {
        let spread = |t: &TargetStats, up: bool| t.direction(up).1;
        let (target, _) = self.extreme(&[up], true, &spread);
        vec![Sensitivity {
            target,
            up,
            to_mean: 0.0,
            to_s: 4.0,
        }]
    }

    /// The (target, direction) among `dirs` where `f` is largest (`largest`) or smallest; the
    /// first such in table order on ties.
    fn extreme(
        &self,
        dirs: &[bool],
        largest: bool,
        f: &dyn Fn(&TargetStats, bool) -> f64,
    ) -> (usize, bool) {
        let mut best: Option<(usize, bool, f64)> = None;
        for (i, t) in self.targets.iter().enumerate() {
            for &up in dirs {
                let v = f(t, up);
                let better = best.is_none_or(|(_, _, b)| if largest { v > b } else { v < b });
                if better {
                    best = Some((i, up, v));
                }
            }
        }
        best.map_or((0, true), |(i, up, _)| (i, up))
    }

    /// M = x̄_i − x̄_j with x̄ = (x̄↑ + x̄↓)/2 at the largest and smallest.
    fn m_terms(&self) -> Vec<Sensitivity> {
        let bidirectional = |t: &TargetStats, _: bool| t.mean;
        let (i, _) = self.extreme(&[true], true, &bidirectional);
        let (j, _) = self.extreme(&[true], false, &bidirectional);
        [(i, 0.5), (j, -0.5)]
            .into_iter()
            .flat_map(|(target, c)| {
                BOTH.map(|up| Sensitivity {
                    target,
                    up,
                    to_mean: c,
                    to_s: 0.0,
                })
            })
            .collect()
    }

    /// R = R_i at the largest, by the branch of its maximum that gave it.
    fn r_terms(&self) -> Vec<Sensitivity> {
        let r = |t: &TargetStats, _: bool| t.r;
        let (i, _) = self.extreme(&[true], true, &r);
        let t = &self.targets[i];
        let one = |up: bool, to_mean: f64, to_s: f64| Sensitivity {
            target: i,
            up,
            to_mean,
            to_s,
        };
        let sign = if t.reversal < 0.0 { -1.0 } else { 1.0 };
        if t.r == 2.0 * t.s_up + 2.0 * t.s_down + t.reversal.abs() {
            vec![one(true, sign, 2.0), one(false, -sign, 2.0)]
        } else if t.r == t.r_up {
            vec![one(true, 0.0, 4.0)]
        } else {
            vec![one(false, 0.0, 4.0)]
        }
    }

    /// B = |B_i| at the largest.
    fn b_terms(&self) -> Vec<Sensitivity> {
        let b = |t: &TargetStats, _: bool| t.reversal.abs();
        let (i, _) = self.extreme(&[true], true, &b);
        let sign = if self.targets[i].reversal < 0.0 {
            -1.0
        } else {
            1.0
        };
        BOTH.into_iter()
            .map(|up| Sensitivity {
                target: i,
                up,
                to_mean: if up { sign } else { -sign },
                to_s: 0.0,
            })
            .collect()
    }

    /// B̄ = Σ (x̄↑_i − x̄↓_i) / m.
    fn b_mean_terms(&self) -> Vec<Sensitivity> {
        let w = 1.0 / self.targets.len() as f64;
        (0..self.targets.len())
            .flat_map(|target| {
                BOTH.map(|up| Sensitivity {
                    target,
                    up,
                    to_mean: if up { w } else { -w },
                    to_s: 0.0,
                })
            })
            .collect()
    }

    /// Σ (c_x̄² σ_eff²/n + c_s² σ_eff²/(2(n − 1))) over the distinct (target, direction) of
    /// `terms`, their coefficients summed first (A = 4s when the top and the bottom are the
    /// same sample: its mean cancels).
    fn variance(&self, terms: &[Sensitivity], reading_sigma: f64) -> f64 {
        let mut merged: Vec<Sensitivity> = Vec::with_capacity(terms.len());
        for t in terms {
            match merged
                .iter_mut()
                .find(|m| m.target == t.target && m.up == t.up)
            {
                Some(m) => {
                    m.to_mean += t.to_mean;
                    m.to_s += t.to_s;
                }
                None => merged.push(*t),
            }
        }
        merged
            .iter()
            .map(|t| {
                let (_, s, n) = self.targets[t.target].direction(t.up);
                let sigma2 = s.max(reading_sigma).powi(2);
                let n = n as f64;
                t.to_mean.powi(2) * sigma2 / n + t.to_s.powi(2) * sigma2 / (2.0 * (n - 1.0))
            })
            .sum()
    }
}

impl Iso230_2Uncertainty {
    /// The uncertainties in the order of [`Iso230_2::metrics`].
    fn in_order(&self) -> [f64; 12] {
        [
            self.a_up,
            self.a_down,
            self.a,
            self.e_up,
            self.e_down,
            self.e,
            self.m,
            self.r_up,
            self.r_down,
            self.r,
            self.b,
            self.b_mean,
        ]
    }
}

/// The approach direction of every sample of a path along one coordinate `travel` (samples in
/// time order): `Some(true)` ↑, `Some(false)` ↓, `None` for a run that never moves.
///
/// A sample's direction is the sign of the move that brought the machine there. Consecutive
/// samples at the same position (within `tol`) form a group: the move into the group and the
/// move out of it decide. If they agree, or there is no move out, every sample of the group
/// has the direction of the move in; if there is no move in (the start), the direction of the
/// move out; at a reversal (the move out opposite to the move in) the first sample keeps the
/// move in and the others take the move out: they are the first readings of the reversed pass
/// after an overrun the run did not record (ISO 230-2 approaches each target from beyond it).
pub fn approach_directions(travel: &[f64], tol: f64) -> Vec<Option<bool>> {
    let n = travel.len();
    let mut out = vec![None; n];
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && (travel[end] - travel[start]).abs() <= tol {
            end += 1;
        }
        let into = (start > 0).then(|| travel[start] > travel[start - 1]);
        let out_of = (end < n).then(|| travel[end] > travel[start]);
        for (k, o) in out[start..end].iter_mut().enumerate() {
            *o = match (into, out_of) {
                (None, o) => o,
                (Some(i), Some(o)) if i != o && k > 0 => Some(o),
                (Some(i), _) => Some(i),
            };
        }
        start = end;
    }
    out
}

/// Groups a run's samples into an ISO 230-2 table: `travel` is the commanded position along
/// the measured direction, `deviation` the reading (measured − commanded), both in time
/// order. Directions by [`approach_directions`]; targets are the positions (within `tol`)
/// approached at least twice from each direction (ISO 230-2 needs two to estimate a standard
/// uncertainty), ascending; samples elsewhere are left out: overrun points (approached one
/// way, or — the start below the first target — once the other way) and the positions of a
/// single cycle.
pub fn approach_table(travel: &[f64], deviation: &[f64], tol: f64) -> Approaches {
    let dirs = approach_directions(travel, tol);
    // Distinct positions, ascending, merged within tol.
    let mut order: Vec<usize> = (0..travel.len()).collect();
    order.sort_by(|&a, &b| travel[a].total_cmp(&travel[b]));
    let mut positions: Vec<(f64, Vec<usize>, Vec<usize>)> = Vec::new();
    for &k in &order {
        let Some(up) = dirs[k] else { continue };
        let new = positions
            .last()
            .is_none_or(|(p, _, _)| (travel[k] - p).abs() > tol);
        if new {
            positions.push((travel[k], Vec::new(), Vec::new()));
        }
        let last = positions.last_mut().expect("pushed");
        if up { last.1.push(k) } else { last.2.push(k) }
    }
    let mut table = Approaches::default();
    for (p, mut up, mut down) in positions {
        if up.len() < 2 || down.len() < 2 {
            continue;
        }
        // Time order within a direction (the sort above is by position only).
        up.sort_unstable();
        down.sort_unstable();
        table.targets.push(p);
        table.up.push(up.iter().map(|&k| deviation[k]).collect());
        table
            .down
            .push(down.iter().map(|&k| deviation[k]).collect());
    }
    table
}

/// The straightness deviation of ISO 230-1 (3.4.8): the range of the deviations from their
/// least-squares reference line over the travel (the readings' unit). `None` with fewer than
/// three samples or no travel.
pub fn straightness(travel: &[f64], deviation: &[f64]) -> Option<f64> {
    let n = travel.len().min(deviation.len());
    if n < 3 {
        return None;
    }
    let (t, d) = (&travel[..n], &deviation[..n]);
    let (mt, md) = (mean(t), mean(d));
    let stt: f64 = t.iter().map(|x| (x - mt) * (x - mt)).sum();
    if stt <= 0.0 {
        return None;
    }
    let slope = t
        .iter()
        .zip(d)
        .map(|(x, y)| (x - mt) * (y - md))
        .sum::<f64>()
        / stt;
    Some(range(
        t.iter().zip(d).map(move |(x, y)| y - md - slope * (x - mt)),
    ))
}

/// The plugin's `evaluate`. A `straightness` run reports `straightness deviation (ISO 230-1)`
/// ([`straightness`] over the travel along the beam, µm), an `angular` run
/// `angular deviation (ISO 230-1)` (the range of its readings, µrad). A `linear` or `diagonal`
/// run reports the ISO 230-2 axis values (µm):
///
/// A linear run that moves one axis is evaluated along that axis, as ISO 230-2 defines it:
/// the targets are the commanded positions, ↑ is the axis' positive direction, and the
/// deviation `x = P_measured − P_target` along it is the reading with the sign of the beam
/// against the axis' motion (`direction = "-X"` reads −x). Any other run (a diagonal, several
/// axes moving) is evaluated along the beam: the travel `n · p₀(q)`, ↑ = increasing along
/// `direction`, the reading as the deviation. Directions come from the motion
/// ([`approach_directions`]). Nothing for other modes, a set-up that does not load, or a run
/// without a target approached twice from each side.
///
/// Every ISO 230-2 value carries its expanded uncertainty ([`Iso230_2::uncertainty`], the
/// reading noise being the set-up's `sigma_um`); a run evaluated along an axis says which
/// ([`Metric::subject`]: its letter), a diagonal is about no axis.
pub fn evaluate(ev: &Evaluation<'_>) -> Vec<Metric> {
    let Some(setup) = ev.setup_as::<LaserSetup>() else {
        return Vec::new();
    };
    let n_axes = ev.machine.n_axes();
    if n_axes == 0 || ev.q.len() % n_axes != 0 || ev.q.len() / n_axes != ev.readings.len() {
        return Vec::new();
    }
    // Rows one at a time: a run can hold millions of samples.
    let rows = || ev.q.chunks_exact(n_axes);
    match setup.mode() {
        Mode::Straightness => {
            let travel: Vec<f64> = rows().map(|q| setup.travel(q)).collect();
            return straightness(&travel, ev.readings)
                .map(|value| {
                    vec![Metric::new(
                        "straightness deviation (ISO 230-1)",
                        value,
                        Unit::Um,
                    )]
                })
                .unwrap_or_default();
        }
        Mode::Angular => {
            let (lo, hi) = ev
                .readings
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            return if lo <= hi {
                vec![Metric::new(
                    "angular deviation (ISO 230-1)",
                    hi - lo,
                    Unit::Urad,
                )]
            } else {
                Vec::new()
            };
        }
        Mode::StepDiagonal => return Vec::new(),
        Mode::Linear | Mode::Diagonal => {}
    }
    let Some(first) = rows().next() else {
        return Vec::new();
    };
    let moving: Vec<usize> = (0..n_axes)
        .filter(|&i| rows().any(|q| (q[i] - first[i]).abs() > TARGET_TOL))
        .collect();
    let along_axis = match (setup.mode(), moving.as_slice()) {
        (Mode::Linear, &[i]) => {
            // How the optic moves when the axis moves positively, against the beam.
            let mut plus = first.to_vec();
            plus[i] += 1e-3;
            let sign = (setup.nominal_optic(&plus) - setup.nominal_optic(first))
                .dot(&setup.beam())
                .signum();
            (sign != 0.0).then_some((i, sign))
        }
        _ => None,
    };
    let (travel, deviation): (Vec<f64>, Vec<f64>) = match along_axis {
        Some((i, sign)) => (
            rows().map(|q| q[i]).collect(),
            ev.readings.iter().map(|d| sign * d).collect(),
        ),
        None => (
            rows().map(|q| setup.travel(q)).collect(),
            ev.readings.to_vec(),
        ),
    };
    let table = approach_table(&travel, &deviation, TARGET_TOL);
    let Ok(values) = iso230_2(&table) else {
        return Vec::new();
    };
    let reading_sigma = setup.channels().first().map_or(0.0, |c| c.sigma);
    let metrics = values.metrics_with_uncertainty(1.0, &values.uncertainty(reading_sigma));
    match along_axis {
        Some((i, _)) => {
            let letter = ev.machine.axes()[i].letter().as_char().to_string();
            metrics.into_iter().map(|m| m.about(&letter)).collect()
        }
        None => metrics,
    }
}
