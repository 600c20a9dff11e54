//! Does the scatter about a fit agree with the stated uncertainties, and how wide must the
//! intervals be?

use serde::Serialize;
use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// The scatter of a fit's residuals against the stated uncertainties, and the coverage factor
/// its intervals use.
///
/// With χ²/dof ≤ 1 the stated uncertainties explain the scatter and the intervals are
/// `2·σ` (k = 2 on the propagated standard uncertainty). With χ²/dof > 1 the points scatter
/// more than their uncertainties say (a campaign's `U` rarely holds its reproducibility), so
/// every standard uncertainty is multiplied by the **Birge ratio** `R = √(χ²/dof)` and the
/// coverage factor is Student's t with `dof` degrees of freedom at 97.5 %: the exact 95 %
/// interval when the true uncertainties are the stated ones times an unknown common factor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Scatter {
    /// χ² of the residuals weighted by the stated standard uncertainties `u = U/2`.
    pub chi2: f64,
    /// Degrees of freedom: points minus fitted parameters.
    pub dof: usize,
    /// `P(χ²(dof) ≥ chi2)`: how surprising the scatter is if the stated uncertainties hold
    /// (small: the points scatter more than they should).
    pub p_value: f64,
    /// `√(χ²/dof)`.
    pub birge_ratio: f64,
    /// Whether the intervals were widened by the Birge ratio (χ²/dof > 1).
    pub inflated: bool,
    /// The `k` of the intervals: 2, or Student's t(dof) at 97.5 % when inflated.
    pub coverage_factor: f64,
}

impl Scatter {
    /// The scatter of `chi2` on `dof ≥ 1` degrees of freedom.
    pub(crate) fn new(chi2: f64, dof: usize) -> Scatter {
        let nu = dof as f64;
        // dof ≥ 1 is every caller's precondition (they check their point counts first), so
        // the distributions exist.
        let chi = ChiSquared::new(nu).expect("χ² with dof ≥ 1");
        let birge_ratio = (chi2 / nu).sqrt();
        let inflated = birge_ratio > 1.0;
        let coverage_factor = if inflated {
            StudentsT::new(0.0, 1.0, nu)
                .expect("t with dof ≥ 1")
                .inverse_cdf(0.975)
        } else {
            2.0
        };
        Scatter {
            chi2,
            dof,
            p_value: chi.sf(chi2),
            birge_ratio,
            inflated,
            coverage_factor,
        }
    }

    /// χ² per degree of freedom (the reduced χ²).
    pub fn chi2_per_dof(&self) -> f64 {
        self.chi2 / self.dof as f64
    }

    /// The factor from a propagated standard uncertainty to the 95 % half-width:
    /// `k · max(1, R)`.
    pub(crate) fn expansion(&self) -> f64 {
        self.coverage_factor * self.birge_ratio.max(1.0)
    }
}
