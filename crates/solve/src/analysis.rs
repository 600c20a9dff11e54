//! The small dense `n × n` algebra on the factor: column scaling, SVD, rank, damped minimum-norm
//! steps, predicted cost reduction and covariance.

use faer::Mat;

use crate::SolveError;
use crate::eval::Lin;

/// SVD of the column-scaled factor `R·D⁻¹ = U Σ Vᵀ` at one point.
#[derive(Debug, Clone)]
pub(crate) struct Analysis {
    /// Column norms of the (whitened, prior-augmented) Jacobian; 1 for empty columns.
    pub(crate) d: Vec<f64>,
    /// Singular values, descending.
    pub(crate) s: Vec<f64>,
    pub(crate) v: Mat<f64>,
    /// `Uᵀ z`.
    pub(crate) c: Vec<f64>,
    /// Number of singular values above the threshold.
    pub(crate) rank: usize,
}

impl Analysis {
    pub(crate) fn new(lin: &Lin, rank_tolerance: f64) -> Result<Self, SolveError> {
        let n = lin.n();
        let d: Vec<f64> = (0..n)
            .map(|j| {
                let norm = crate::qr::norm2(&lin.r[j * n..j * n + j + 1]);
                if norm > 0.0 { norm } else { 1.0 }
            })
            .collect();
        let rs = Mat::<f64>::from_fn(
            n,
            n,
            |i, j| if i <= j { lin.r[i + j * n] / d[j] } else { 0.0 },
        );
        if n == 0 {
            return Ok(Self {
                d,
                s: Vec::new(),
                v: Mat::zeros(0, 0),
                c: Vec::new(),
                rank: 0,
            });
        }
        if !rs.as_ref().is_all_finite() {
            return Err(SolveError::Numerical(
                "the scaled Jacobian factor is not finite".into(),
            ));
        }
        let svd = rs.svd().map_err(|e| {
            SolveError::Numerical(format!("the SVD of the scaled Jacobian failed: {e:?}"))
        })?;
        let s: Vec<f64> = svd.S().column_vector().iter().copied().collect();
        let smax = s.first().copied().unwrap_or(0.0);
        let rank = s
            .iter()
            .filter(|&&si| si > rank_tolerance * smax && si > 0.0)
            .count();
        let u = svd.U();
        let c: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|k| u[(k, i)] * lin.z[k]).sum())
            .collect();
        Ok(Self {
            d,
            s,
            v: svd.V().to_owned(),
            c,
            rank,
        })
    }

    /// `σ_max²`, the natural unit of the damping λ.
    pub(crate) fn s2max(&self) -> f64 {
        self.s
            .first()
            .map_or(1.0, |s| if *s > 0.0 { s * s } else { 1.0 })
    }

    /// The damped step `argmin ‖R dx + z‖² + λ‖D dx‖²` restricted to the identified directions
    /// (column order of the factor).
    pub(crate) fn step(&self, lambda: f64) -> Vec<f64> {
        let n = self.d.len();
        let mut y = vec![0.0; n];
        for i in 0..self.rank {
            let si = self.s[i];
            let coef = -si * self.c[i] / (si * si + lambda);
            for (j, yj) in y.iter_mut().enumerate() {
                *yj += coef * self.v[(j, i)];
            }
        }
        for (yj, dj) in y.iter_mut().zip(&self.d) {
            *yj /= dj;
        }
        y
    }

    /// `‖D·dx‖`.
    pub(crate) fn scaled_norm(&self, dx: &[f64]) -> f64 {
        let scaled: Vec<f64> = dx.iter().zip(&self.d).map(|(a, d)| a * d).collect();
        crate::qr::norm2(&scaled)
    }

    /// Covariance `D⁻¹ V_r Σ_r⁻² V_rᵀ D⁻¹` in the column order of the factor.
    pub(crate) fn covariance(&self) -> Mat<f64> {
        let n = self.d.len();
        let m = Mat::<f64>::from_fn(n, self.rank, |j, i| {
            self.v[(j, i)] / (self.s[i] * self.d[j])
        });
        &m * m.transpose()
    }

    /// Null-space basis (one column per direction) in scaled units, rows in factor order.
    pub(crate) fn null_space(&self) -> Mat<f64> {
        let n = self.d.len();
        Mat::<f64>::from_fn(n, n - self.rank, |j, k| self.v[(j, self.rank + k)])
    }
}

/// The linear model's prediction for a step: `(cost − model cost, ‖R·dx‖)`, with
/// `cost − model = −zᵀ(R dx) − ½‖R dx‖²` (no cancellation against the constant part).
pub(crate) fn predicted(lin: &Lin, dx: &[f64]) -> (f64, f64) {
    let n = lin.n();
    let mut w = vec![0.0; n];
    for (j, &dxj) in dx.iter().enumerate() {
        if dxj == 0.0 {
            continue;
        }
        let col = &lin.r[j * n..j * n + j + 1];
        for (wi, &rij) in w.iter_mut().zip(col) {
            *wi += rij * dxj;
        }
    }
    let zw = crate::qr::dot(&lin.z, &w);
    let ww = crate::qr::dot(&w, &w);
    (-zw - 0.5 * ww, ww.sqrt())
}
