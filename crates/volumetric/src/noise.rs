//! The per-visit noise, estimated from the data (crate docs, "Noise").
//!
//! The readings of the complete cycles, per axis a table `Y` (cycle k × point j), are
//! `Y_kj = o_j + f_k(z_j) + e_kj`: each point's set-up offset `o_j`, the field at cycle k as a
//! linear function of the point's regressors `z_j = (1, X, Y, Z, δ)` (commanded position, mm,
//! and its visit's mean time in the cycle, s, which carries a drift within the cycle), and the
//! noise. The residuals of that two-way fit are `E = P·Y·Q`, `P = I − 11ᵀ/K` (each point's
//! mean over the cycles out) and `Q = I − H_z` (the regressors out, rank p). For noise of σ²,
//! AR(1) with φ along each set-up's visits (the head seating on one ball; a ball visited at
//! several table positions is several points) and independent between set-ups,
//! `E[Σ E²] = σ²·Σ_j Q_jj·tr(P R_j P)` and
//! `E[Σ_k Σ_j E_kj E_k+1,j] = σ²·Σ_j Q_jj·Σ_k (P R_j P)_k,k+1`, `R_j,ab = φ^|i_a − i_b|` over
//! the indices `i` of point j's visits in its set-up's sequence (the correlation between
//! points of one set-up is left out here: Q's off-diagonal terms are small). φ solves the
//! ratio of the two sums (the three axes' ratios averaged); σ² per axis the first. The field's own part that no linear function of the regressors
//! follows stays in the residuals: σ then comes out larger, never smaller. With fewer than
//! [`MIN_CYCLES_FOR_PHI`] complete cycles φ is taken as 0.

use crate::cycles::Cycles;
use crate::points::{SetupSequence, Visits};
use crate::{MIN_CYCLES, VolumetricError};

/// Complete cycles needed to estimate φ.
pub const MIN_CYCLES_FOR_PHI: usize = 5;
/// φ is sought in this range.
const PHI_RANGE: (f64, f64) = (-0.5, 0.95);

/// The per-visit noise.
#[derive(Debug, Clone, PartialEq)]
pub struct Noise {
    /// σ of one visit's reading per axis (dx, dy, dz), µm.
    pub sigma_um: [f64; 3],
    /// AR(1) correlation between two successive visits of a set-up (the head seating on one
    /// ball, whatever the table's position).
    pub phi: f64,
    /// Whether φ was estimated (else taken as 0).
    pub phi_estimated: bool,
    /// Residuals pooled per axis, and the complete cycles they come from.
    pub residuals: usize,
    pub cycles_used: usize,
    /// The σ the set-ups state, (smallest, largest), µm.
    pub stated_sigma_um: Option<(f64, f64)>,
}

impl Noise {
    /// The covariance of two visits of a set-up `lag` visits apart along `axis`, µm².
    pub fn covariance(&self, axis: usize, lag: usize) -> f64 {
        let s = self.sigma_um[axis];
        s * s * self.phi.powi(lag.min(i32::MAX as usize) as i32)
    }

    /// How σ and φ were found, in a sentence.
    pub fn how(&self) -> String {
        let phi = match self.phi_estimated {
            true => format!("AR(1) φ = {:.2} along each set-up's visits", self.phi),
            false => {
                format!("taken as white (φ = 0: fewer than {MIN_CYCLES_FOR_PHI} complete cycles)")
            }
        };
        format!(
            "σ = {:.2} / {:.2} / {:.2} µm per visit (X / Y / Z), {phi}; from the {} residual \
             degrees of freedom per axis of {} complete cycles, each point's readings less their \
             mean and each cycle's less a linear function of the points' X, Y, Z and visit time",
            self.sigma_um[0], self.sigma_um[1], self.sigma_um[2], self.residuals, self.cycles_used
        )
    }

    /// A stated σ far from the data's.
    pub(crate) fn notes(&self) -> Vec<String> {
        let Some((lo, hi)) = self.stated_sigma_um else {
            return Vec::new();
        };
        let found_lo = self.sigma_um.iter().copied().fold(f64::INFINITY, f64::min);
        let found_hi = self.sigma_um.iter().copied().fold(0.0, f64::max);
        let stated = match lo == hi {
            true => format!("{lo} µm"),
            false => format!("{lo}–{hi} µm"),
        };
        if found_hi > 1.3 * hi || found_lo < lo / 1.3 {
            vec![format!(
                "the set-ups state sigma_um = {stated}; the data show {found_lo:.2}–{found_hi:.2} \
                 µm per visit, which is what the uncertainties use"
            )]
        } else {
            Vec::new()
        }
    }
}

/// σ and φ from `visits` cut into `cycles` (module docs).
pub(crate) fn estimate(visits: &Visits, cycles: &Cycles) -> Result<Noise, VolumetricError> {
    let complete: Vec<usize> = (0..cycles.len()).filter(|&c| cycles.complete[c]).collect();
    if complete.len() < MIN_CYCLES {
        return Err(VolumetricError::invalid(
            visits.session.display().to_string(),
            format!(
                "{} complete cycles (one visit of each of the {} points): at least {MIN_CYCLES} \
                 are needed to tell the noise from the deformation",
                complete.len(),
                visits.points.len()
            ),
        ));
    }
    let q = regressors_out(&regressors(visits, cycles, &complete));
    let lags = setup_indices(visits, cycles, &complete);
    let k = complete.len();
    let mut s0 = [0.0; 3];
    let mut s1 = [0.0; 3];
    for (i, (s0, s1)) in s0.iter_mut().zip(&mut s1).enumerate() {
        let e = residuals(&readings(visits, cycles, &complete, i), &q);
        *s0 = e.iter().flatten().map(|x| x * x).sum();
        *s1 = e
            .windows(2)
            .map(|w| w[0].iter().zip(&w[1]).map(|(a, b)| a * b).sum::<f64>())
            .sum();
    }
    let expected = |phi: f64| {
        lags.iter()
            .zip(q.diagonal())
            .fold((0.0, 0.0), |acc, (idx, d)| {
                let (t0, t1) = demeaned(idx, phi);
                (acc.0 + d * t0, acc.1 + d * t1)
            })
    };
    let phi_estimated = k >= MIN_CYCLES_FOR_PHI;
    let phi = match phi_estimated {
        true => solve_phi(&s0, &s1, &expected),
        false => 0.0,
    };
    let dof = q.len() - q.rank;
    let t0 = expected(phi).0;
    let sigma_um = s0.map(|s| match t0 > 0.0 {
        true => (s / t0).max(0.0).sqrt(),
        false => 0.0,
    });
    Ok(Noise {
        sigma_um,
        phi,
        phi_estimated,
        residuals: (k - 1) * dof,
        cycles_used: k,
        stated_sigma_um: visits.stated_sigma_um,
    })
}

/// Per point, its regressors `(1, X, Y, Z, δ)`: commanded position (mm) and the mean of its
/// visit times relative to their cycles' instants (s).
fn regressors(visits: &Visits, cycles: &Cycles, complete: &[usize]) -> Vec<Vec<f64>> {
    let mut delta = vec![0.0; visits.points.len()];
    for &c in complete {
        for &(j, v) in &cycles.visits[c] {
            let offset = visits.points[j].visits[v].t_s - cycles.mid_s[c];
            delta[j] += offset / complete.len() as f64;
        }
    }
    visits
        .points
        .iter()
        .zip(&delta)
        .map(|(p, &d)| {
            let [x, y, z] = p.position_mm;
            vec![1.0, x, y, z, d]
        })
        .collect()
}

/// `Q = I − H` as an orthonormal basis of the regressors' span over the points.
struct Projection {
    basis: Vec<Vec<f64>>,
    /// The basis' size, p.
    rank: usize,
    /// Points, N.
    n: usize,
}

impl Projection {
    fn len(&self) -> usize {
        self.n
    }

    /// `Q_jj = 1 − Σ_b basis_b[j]²`.
    fn diagonal(&self) -> Vec<f64> {
        (0..self.n)
            .map(|j| 1.0 - self.basis.iter().map(|b| b[j] * b[j]).sum::<f64>())
            .collect()
    }
}

/// The regressors' span, by Gram–Schmidt: a column that adds nothing is dropped, and the
/// later columns when two residual degrees of freedom per cycle would not be left (with few
/// points the noise must still be seen).
fn regressors_out(z: &[Vec<f64>]) -> Projection {
    let n = z.len();
    let columns = z.first().map_or(0, Vec::len);
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for c in 0..columns {
        if !basis.is_empty() && n - basis.len() <= 2 {
            break;
        }
        let mut v: Vec<f64> = z.iter().map(|row| row[c]).collect();
        let scale = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        for b in &basis {
            let dot: f64 = v.iter().zip(b).map(|(x, y)| x * y).sum();
            v.iter_mut().zip(b).for_each(|(x, y)| *x -= dot * y);
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-9 * scale && norm > 0.0 {
            basis.push(v.into_iter().map(|x| x / norm).collect());
        }
    }
    Projection {
        rank: basis.len(),
        basis,
        n,
    }
}

/// The readings along `axis`: `[complete cycle][point]`.
fn readings(visits: &Visits, cycles: &Cycles, complete: &[usize], axis: usize) -> Vec<Vec<f64>> {
    complete
        .iter()
        .map(|&c| {
            let mut row = vec![0.0; visits.points.len()];
            for &(j, v) in &cycles.visits[c] {
                row[j] = visits.points[j].visits[v].reading_um[axis];
            }
            row
        })
        .collect()
}

/// `P·Y·Q`: each point's mean over the cycles out, then each cycle's regressors.
fn residuals(y: &[Vec<f64>], q: &Projection) -> Vec<Vec<f64>> {
    let k = y.len() as f64;
    let means: Vec<f64> = (0..q.len())
        .map(|j| y.iter().map(|row| row[j]).sum::<f64>() / k)
        .collect();
    y.iter()
        .map(|row| {
            let mut e: Vec<f64> = row.iter().zip(&means).map(|(a, m)| a - m).collect();
            for b in &q.basis {
                let dot: f64 = e.iter().zip(b).map(|(x, y)| x * y).sum();
                e.iter_mut().zip(b).for_each(|(x, y)| *x -= dot * y);
            }
            e
        })
        .collect()
}

/// Per point, the index in its set-up's visit sequence of its visit in each complete cycle.
fn setup_indices(visits: &Visits, cycles: &Cycles, complete: &[usize]) -> Vec<Vec<usize>> {
    let seq = SetupSequence::of(visits);
    let mut out = vec![Vec::with_capacity(complete.len()); visits.points.len()];
    for &c in complete {
        for &(j, v) in &cycles.visits[c] {
            out[j].push(seq.index[j][v]);
        }
    }
    out
}

/// `(tr(P R P), Σ_k (P R P)_k,k+1)` for one point, `R_ab = φ^|i_a − i_b|` over its visits'
/// indices `i` in its set-up's sequence, `P = I − 11ᵀ/k`.
fn demeaned(idx: &[usize], phi: f64) -> (f64, f64) {
    let k = idx.len();
    let r = |a: usize, b: usize| phi.powi(idx[a].abs_diff(idx[b]) as i32);
    let row: Vec<f64> = (0..k)
        .map(|a| (0..k).map(|b| r(a, b)).sum::<f64>() / k as f64)
        .collect();
    let all = row.iter().sum::<f64>() / k as f64;
    let prp = |a: usize, b: usize| r(a, b) - row[a] - row[b] + all;
    let trace = (0..k).map(|a| prp(a, a)).sum();
    let lag1 = (0..k.saturating_sub(1)).map(|a| prp(a, a + 1)).sum();
    (trace, lag1)
}

/// φ whose ratio of lag-one products to squares is the axes' mean ratio, within
/// [`PHI_RANGE`] (the ratio grows with φ).
fn solve_phi(s0: &[f64; 3], s1: &[f64; 3], expected: &dyn Fn(f64) -> (f64, f64)) -> f64 {
    let ratios: Vec<f64> = (0..3)
        .filter(|&i| s0[i] > 0.0)
        .map(|i| s1[i] / s0[i])
        .collect();
    if ratios.is_empty() {
        return 0.0;
    }
    let target = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let f = |phi: f64| {
        let (t0, t1) = expected(phi);
        t1 - target * t0
    };
    let (mut lo, mut hi) = PHI_RANGE;
    if f(lo) >= 0.0 {
        return lo;
    }
    if f(hi) <= 0.0 {
        return hi;
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
