//! Which instrument and which run constrain each parameter, and what more data would add.
//!
//! # Information share
//! At the solution the fit's information matrix is the sum of the runs' and the priors':
//! `I = Σ_r J_rᵀ J_r + P` (whitened Jacobians, so every instrument counts by its noise), and
//! the covariance is its (pseudo-)inverse `C`. Since `C = C I C = Σ_r C I_r C + C P C`, the
//! variance of parameter `k` splits exactly into one non-negative part per run and one for
//! the priors:
//!
//! ```text
//! share_r(k) = (C I_r C)_kk / C_kk = ‖R_r c_k‖² / C_kk,      Σ_r share_r(k) + share_P(k) = 1
//! ```
//!
//! (`R_r` the run's triangular factor, `R_rᵀR_r = I_r`; `c_k` column `k` of `C`). A share is
//! the fraction of what is known about `k` that run `r` supplies *in the presence of the other
//! runs*: a run that only repeats what another run already pins down gets a share split with
//! it, a run that alone fixes a direction gets that direction's whole share. Shares of runs of
//! one instrument add up to the instrument's share.
//!
//! # What a run would add
//! Repeating run `r` (the same path and set-up, new noise) adds `I_r` once more; the new
//! covariance follows from Woodbury without refitting:
//! `C' = C − W_rᵀ (𝟙 + R_r C R_rᵀ)⁻¹ W_r`, `W_r = R_r C`, evaluated in the equivalent form
//! `C' = L (𝟙 + Lᵀ R_rᵀ R_r L)⁻¹ Lᵀ` on the square-root factor `C = L Lᵀ`, which is exact for
//! the singular (pseudo-inverse) `C` of a rank-deficient fit and cannot turn indefinite by
//! rounding ([`updated_variances`]). Any other data (a run moved to
//! another place, another instrument, a planned campaign) is loaded as a session of its own
//! ([`what_if`]); its set-up parameters are not shared with this session's, so they are
//! eliminated (Schur complement) and only what it says about the machine's parameters is
//! added, matched by name.
//!
//! Unidentified parameters have no covariance and appear in neither account; data that makes
//! them identifiable is beyond a first-order update (fit the joint session instead).

use crate::fit::FitProblem;
use crate::{IdentifyError, Study, param_specs_from};
use mtcal_solve::Solution;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// How much of a parameter's information one source supplies.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Share {
    /// A run's name, or `prior` for the set-up parameters' priors.
    pub source: String,
    /// The run's instrument (`prior` for the priors).
    pub instrument: String,
    /// Fraction of the parameter's information, 0…1.
    pub share: f64,
}

/// What repeating one run would do to a parameter's interval.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Repeat {
    pub run: String,
    /// The 95 % interval half-width after the repeat, in the parameter's unit.
    pub u95_after: f64,
}

/// The account of one identified machine parameter.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct ParameterAccount {
    pub name: String,
    pub unit: String,
    pub u95: f64,
    /// The same from the account's own linearisation at the solution (the shares and repeats
    /// refer to it); equal to `u95` up to the solver's last chord step.
    pub u95_account: f64,
    /// Per run (and the priors when they carry any), largest first; the shares sum to 1.
    pub runs: Vec<Share>,
    /// The same summed per instrument, largest first.
    pub instruments: Vec<Share>,
    /// Repeating each fitted run once more, best first.
    pub repeat: Vec<Repeat>,
}

/// Information shares and repeat gains of every identified machine parameter.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct InformationAccount {
    pub parameters: Vec<ParameterAccount>,
}

impl InformationAccount {
    /// A plain-text table: per parameter its interval, the instruments and the runs that
    /// carry at least 5 % of it, and the best run to repeat.
    pub fn summary(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "what constrains each parameter (share of its information; repeat = the run whose \
             repetition narrows it most):"
        );
        let pct = |v: f64| format!("{:.0} %", 100.0 * v);
        for p in &self.parameters {
            let instruments: Vec<String> = p
                .instruments
                .iter()
                .filter(|i| i.share >= 0.05)
                .map(|i| format!("{} {}", i.instrument, pct(i.share)))
                .collect();
            let runs: Vec<String> = p
                .runs
                .iter()
                .filter(|r| r.share >= 0.05)
                .take(3)
                .map(|r| format!("{} {}", r.source, pct(r.share)))
                .collect();
            let repeat = p.repeat.first().map_or(String::new(), |r| {
                format!("; repeat {}: ±{:.4}", r.run, r.u95_after)
            });
            let _ = writeln!(
                s,
                "  {:<24} ±{:<10.4} {:<5} {} ({}){repeat}",
                p.name,
                p.u95,
                p.unit,
                instruments.join(", "),
                runs.join(", ")
            );
        }
        s
    }
}

/// The 95 % half-width factor of [`crate::report`].
const K95: f64 = crate::K95;

/// One run's information factor `R_r` (`n × n`, `R_rᵀ R_r = J_rᵀ J_r`) at `x`.
fn run_factor(study: &Study, x: &[f64], runs: &[usize]) -> Result<DMatrix<f64>, IdentifyError> {
    let problem = FitProblem::for_runs(study, runs);
    let mut specs = param_specs_from(study, x);
    for s in &mut specs {
        s.prior = None;
        s.bounds = None;
    }
    let lin = mtcal_solve::linearize(&problem, &specs, x, 0)?;
    let n = x.len();
    Ok(DMatrix::from_row_slice(n, n, &lin.r))
}

/// A square-root factor `L` (`n × r`, `C = L Lᵀ`) of the covariance: the pseudo-inverse of
/// `RᵀR` over its `rank` strongest directions, where `R` (`n × n`) is the information factor
/// of the whole fit. The column scaling, the visibility rule and the rank are the solver's
/// ([`mtcal_solve::Options::rank_tolerance`]): columns scaled by their norm but by no less than
/// `floor` (`1/plausible range`), columns below [`mtcal_solve::visible`] and exactly zero ones
/// left out of the identified directions, `rank` the solver's. So the `rank` directions kept
/// are the ones the solver identified.
///
/// Why the factor's SVD and not the information matrix's eigen-decomposition: the solver keeps
/// singular values down to 10⁻⁹ of the largest, whose squares (10⁻¹⁸) are below the rounding
/// of `RᵀR` (10⁻¹⁶ of its largest eigenvalue). An eigen-decomposition of `RᵀR` then inverts
/// rounding noise along such directions: a covariance 10¹⁵ times too large, and the Woodbury
/// update of [`updated_variances`] on it met an indefinite `𝟙 + UᵀCU` (a full default error
/// model on a five-axis session has many such directions). `R`'s own SVD resolves them.
/// Parameters correlated with a null direction keep the variance that correlation gives them;
/// the rows of unidentified parameters are kept too (they are what makes `C·I·C = C` hold, so
/// the shares add up), but never reported.
fn covariance_factor(
    r: &DMatrix<f64>,
    floor: &[f64],
    rank: usize,
) -> Result<DMatrix<f64>, IdentifyError> {
    let n = r.ncols();
    if n == 0 {
        return Ok(DMatrix::zeros(0, 0));
    }
    let mut visible = vec![true; n];
    let d: Vec<f64> = (0..n)
        .map(|j| {
            let norm = r.column(j).norm();
            let f = floor.get(j).copied().unwrap_or(0.0);
            visible[j] = mtcal_solve::visible(norm, f);
            let d = norm.max(f);
            if d > 0.0 { d } else { 1.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(r.nrows(), n, |i, j| {
        if visible[j] { r[(i, j)] / d[j] } else { 0.0 }
    });
    let s = checked_svd(scaled, "the scaled information factor")?;
    let Some(v_t) = s.v_t.as_ref() else {
        return Err(IdentifyError::Information(
            "the SVD of the information factor returned no V".into(),
        ));
    };
    let mut order: Vec<usize> = (0..s.singular_values.len()).collect();
    order.sort_by(|&a, &b| s.singular_values[b].total_cmp(&s.singular_values[a]));
    let kept: Vec<usize> = order
        .into_iter()
        .take(rank)
        .filter(|&k| s.singular_values[k] > 0.0)
        .collect();
    // A zero column lies exactly in the null space; the SVD leaves rounding there (as the
    // solver does, its rows are cleared).
    let zero = |j: usize| !visible[j] || r.column(j).iter().all(|&v| v == 0.0);
    Ok(DMatrix::from_fn(n, kept.len(), |j, a| {
        let k = kept[a];
        if zero(j) {
            0.0
        } else {
            v_t[(k, j)] / (s.singular_values[k] * d[j])
        }
    }))
}

/// The SVD (`V` only) of a matrix that must be finite; an error, never a panic or an endless
/// iteration, otherwise.
fn checked_svd(
    m: DMatrix<f64>,
    what: &str,
) -> Result<nalgebra::SVD<f64, nalgebra::Dyn, nalgebra::Dyn>, IdentifyError> {
    let fail = |why: &str| IdentifyError::Information(format!("{what} {why}"));
    if !m.iter().all(|v| v.is_finite()) {
        return Err(fail("is not finite"));
    }
    // Golub–Kahan converges in a few sweeps per singular value; the bound only turns a
    // pathological case into an error.
    let max_iterations = 1000 * (m.nrows() + m.ncols() + 1);
    nalgebra::SVD::try_new(m, false, true, f64::EPSILON, max_iterations)
        .ok_or_else(|| fail("has no converged SVD"))
}

/// The variances after adding the information `U Uᵀ` (`u` is `n × p`) to a fit of covariance
/// `C = L Lᵀ` (`l` is `n × r`, from [`covariance_factor`]).
///
/// Woodbury gives `C' = C − C U (𝟙 + Uᵀ C U)⁻¹ Uᵀ C`; with `B = Lᵀ U` (`r × p`) the same is,
/// by the push-through identity, `C' = L (𝟙 + B Bᵀ)⁻¹ Lᵀ`: the posterior of the `r`
/// identified coordinates `z` (`θ = L z`, prior covariance 𝟙) given the added information
/// `B Bᵀ` on them. This is exact for every positive semi-definite `C`, singular or not
/// (information along directions `C` does not cover cannot move the identified ones and drops
/// out), and it never forms `Uᵀ C U`, whose rounding can make `𝟙 + Uᵀ C U` indefinite when
/// `C` and `U` are large along the same direction. Instead `𝟙 + B Bᵀ = Tᵀ T` comes from the
/// Householder QR of the stacked `[𝟙; Bᵀ]` (backward stable; `T`'s diagonal is at least 1 in
/// magnitude, the pivots of a matrix `⪰ 𝟙`), and the variances are the squared row norms of
/// `L T⁻¹`: sums of squares, so never negative, and finite. In exact arithmetic
/// `(𝟙 + B Bᵀ)⁻¹ ⪯ 𝟙`, so no variance grows; the clamp to `C_kk` only removes rounding.
fn updated_variances(l: &DMatrix<f64>, u: &DMatrix<f64>) -> Result<Vec<f64>, IdentifyError> {
    let (n, r, p) = (l.nrows(), l.ncols(), u.ncols());
    let before: Vec<f64> = (0..n).map(|k| l.row(k).norm_squared()).collect();
    if r == 0 || p == 0 {
        return Ok(before);
    }
    let b = l.transpose() * u;
    if !b.iter().all(|v| v.is_finite()) {
        return Err(IdentifyError::Information(
            "the added information is not finite on the identified parameters".into(),
        ));
    }
    let mut stacked = DMatrix::zeros(r + p, r);
    stacked.view_mut((0, 0), (r, r)).fill_with_identity();
    stacked.view_mut((r, 0), (p, r)).copy_from(&b.transpose());
    let t = stacked.qr().r();
    // Rows of `L T⁻¹` are the columns of `T⁻ᵀ Lᵀ`.
    let solved = t
        .tr_solve_upper_triangular(&l.transpose())
        .filter(|x| x.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            IdentifyError::Information(
                "the updated covariance has no finite factor (𝟙 + BBᵀ lost its pivots)".into(),
            )
        })?;
    Ok((0..n)
        .map(|k| solved.column(k).norm_squared().min(before[k]))
        .collect())
}

/// The fit linearised at its solution, run by run.
struct Linearised {
    /// The fitted runs.
    fitted: Vec<usize>,
    /// Their information factors, in that order.
    factors: Vec<DMatrix<f64>>,
    /// The priors' information (diagonal).
    prior_info: DVector<f64>,
    /// The covariance of these very factors, `C = L Lᵀ`.
    c: DMatrix<f64>,
    /// Its square-root factor `L` (`n × rank`).
    l: DMatrix<f64>,
}

fn linearised(study: &Study, solution: &Solution) -> Result<Linearised, IdentifyError> {
    let x = &solution.x;
    let fitted: Vec<usize> = (0..study.runs.len())
        .filter(|&r| study.runs[r].fit)
        .collect();
    let factors = fitted
        .iter()
        .map(|&r| run_factor(study, x, &[r]))
        .collect::<Result<Vec<_>, _>>()?;
    let specs = param_specs_from(study, x);
    let prior_info = DVector::from_iterator(
        x.len(),
        specs
            .iter()
            .map(|s| s.prior.map_or(0.0, |(_, sd)| 1.0 / (sd * sd))),
    );
    // The covariance of these very factors (not the solver's, which comes from its last
    // factor, a chord step earlier): the shares then add up exactly, also along weakly
    // determined directions where a tiny difference would be amplified. The runs' factors
    // and the priors' are stacked and reduced by QR one run at a time (`RᵀR = Σ I_r + P`
    // without ever forming the sum, see `covariance_factor`).
    let n = x.len();
    let mut total = DMatrix::from_diagonal(&prior_info.map(f64::sqrt));
    for f in &factors {
        let mut stacked = DMatrix::zeros(2 * n, n);
        stacked.view_mut((0, 0), (n, n)).copy_from(&total);
        stacked.view_mut((n, 0), (n, n)).copy_from(f);
        total = stacked.qr().r();
    }
    let floor: Vec<f64> = specs
        .iter()
        .map(|s| {
            s.scale
                .filter(|s| *s > 0.0 && s.is_finite())
                .map_or(0.0, |s| 1.0 / s)
        })
        .collect();
    let l = covariance_factor(&total, &floor, solution.rank)?;
    let c = &l * l.transpose();
    Ok(Linearised {
        fitted,
        factors,
        prior_info,
        c,
        l,
    })
}

/// The account of `study`'s fit `solution`: shares by run, instrument and prior, and the gain
/// of repeating each fitted run.
pub fn account(study: &Study, solution: &Solution) -> Result<InformationAccount, IdentifyError> {
    let Linearised {
        fitted,
        factors,
        prior_info,
        c,
        l,
    } = linearised(study, solution)?;
    let x = &solution.x;
    let repeats: Vec<Vec<f64>> = factors
        .iter()
        .map(|f| updated_variances(&l, &f.transpose()))
        .collect::<Result<_, _>>()?;
    let mut parameters = Vec::new();
    for k in 0..x.len() {
        let info = study.param_info(k);
        let (Some(sigma), true) = (solution.sigma[k], info.machine) else {
            continue;
        };
        let ckk = c[(k, k)];
        if ckk <= 0.0 {
            continue;
        }
        let ck = c.column(k);
        let mut runs: Vec<Share> = fitted
            .iter()
            .zip(&factors)
            .map(|(&r, f)| Share {
                source: study.runs[r].name.clone(),
                instrument: study.setups[study.runs[r].setup].plugin.name.to_string(),
                share: (f * ck).norm_squared() / ckk,
            })
            .collect();
        let prior: f64 = ck
            .iter()
            .zip(prior_info.iter())
            .map(|(v, p)| v * v * p)
            .sum::<f64>()
            / ckk;
        if prior > 1e-9 {
            runs.push(Share {
                source: "prior".into(),
                instrument: "prior".into(),
                share: prior,
            });
        }
        let mut instruments: Vec<Share> = Vec::new();
        for s in &runs {
            match instruments
                .iter_mut()
                .find(|i| i.instrument == s.instrument)
            {
                Some(i) => i.share += s.share,
                None => instruments.push(Share {
                    source: s.instrument.clone(),
                    instrument: s.instrument.clone(),
                    share: s.share,
                }),
            }
        }
        let by_share = |a: &Share, b: &Share| b.share.total_cmp(&a.share);
        runs.sort_by(by_share);
        instruments.sort_by(by_share);
        let mut repeat: Vec<Repeat> = fitted
            .iter()
            .zip(&repeats)
            .map(|(&r, v)| Repeat {
                run: study.runs[r].name.clone(),
                u95_after: K95 * v[k].sqrt() * info.per_si,
            })
            .collect();
        repeat.sort_by(|a, b| a.u95_after.total_cmp(&b.u95_after));
        parameters.push(ParameterAccount {
            name: info.name,
            unit: info.unit,
            u95: K95 * sigma * info.per_si,
            u95_account: K95 * ckk.sqrt() * info.per_si,
            runs,
            instruments,
            repeat,
        });
    }
    Ok(InformationAccount { parameters })
}

/// What another session's data (planned, moved or added runs, loaded as `extra`) would do to
/// the intervals of `study`'s identified machine parameters: one entry per parameter, the
/// 95 % half-width after adding it (same unit as the report). `extra` is linearised at
/// `study`'s solution for every machine parameter the two share by name (its other
/// parameters at their start); its set-up parameters and machine parameters `study` does not
/// estimate are eliminated, never shared.
pub fn what_if(
    study: &Study,
    solution: &Solution,
    extra: &Study,
) -> Result<Vec<(String, f64)>, IdentifyError> {
    let (ours, theirs) = (study.model.machine(), extra.model.machine());
    if ours.name() != theirs.name() || ours.letters() != theirs.letters() {
        return Err(IdentifyError::Machine {
            at: extra.session.machine_at.to_string(),
            message: format!(
                "its runs are on another machine ({} {}) than the session identified ({} {}): \
                 what they would add cannot be matched parameter by parameter",
                theirs.name(),
                theirs.letters(),
                ours.name(),
                ours.letters()
            ),
        });
    }
    let n = solution.x.len();
    let names: Vec<_> = (0..n).map(|i| study.param_info(i)).collect();
    let mut x_extra = extra.initial_x();
    let mut map = vec![None; x_extra.len()];
    for (j, xe) in x_extra.iter_mut().enumerate() {
        let info = extra.param_info(j);
        if !info.machine {
            continue;
        }
        if let Some(i) = names.iter().position(|p| p.machine && p.name == info.name) {
            *xe = solution.x[i];
            map[j] = Some(i);
        }
    }
    let fitted: Vec<usize> = (0..extra.runs.len())
        .filter(|&r| extra.runs[r].fit)
        .collect();
    let r = run_factor(extra, &x_extra, &fitted)?;
    let info = r.transpose() * &r;
    // The SVD and eigen-decompositions below iterate without end on a NaN.
    if !info.iter().all(|v| v.is_finite()) {
        return Err(IdentifyError::Information(format!(
            "{}: the information of its runs is not finite",
            extra.session.machine_at
        )));
    }
    let kept: Vec<usize> = (0..map.len()).filter(|&j| map[j].is_some()).collect();
    let dropped: Vec<usize> = (0..map.len()).filter(|&j| map[j].is_none()).collect();
    let pick = |rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |a, b| info[(rows[a], cols[b])])
    };
    let mut schur = pick(&kept, &kept);
    if !dropped.is_empty() {
        let uu = pick(&dropped, &dropped);
        let ku = pick(&kept, &dropped);
        let tolerance = 1e-12 * uu.diagonal().max().max(f64::MIN_POSITIVE);
        let pinv = uu
            .pseudo_inverse(tolerance)
            .expect("a non-negative tolerance");
        schur -= &ku * pinv * ku.transpose();
    }
    // Added information on this study's parameters, as U Uᵀ.
    let mut added = DMatrix::zeros(n, n);
    for (a, &ja) in kept.iter().enumerate() {
        for (b, &jb) in kept.iter().enumerate() {
            added[(map[ja].unwrap_or(0), map[jb].unwrap_or(0))] = schur[(a, b)];
        }
    }
    let eig = nalgebra::SymmetricEigen::new(added);
    let top = eig.eigenvalues.max().max(0.0);
    let l = linearised(study, solution)?.l;
    let cols: Vec<usize> = (0..n)
        .filter(|&i| eig.eigenvalues[i] > 1e-12 * top && top > 0.0)
        .collect();
    let u = DMatrix::from_fn(n, cols.len(), |i, a| {
        eig.eigenvectors[(i, cols[a])] * eig.eigenvalues[cols[a]].sqrt()
    });
    let after = updated_variances(&l, &u)?;
    Ok((0..n)
        .filter(|&k| names[k].machine && solution.sigma[k].is_some())
        .map(|k| {
            (
                names[k].name.clone(),
                K95 * after[k].sqrt() * names[k].per_si,
            )
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `C − C U (𝟙 + Uᵀ C U)⁻¹ Uᵀ C` by the textbook formula, for a well-conditioned case.
    fn woodbury(c: &DMatrix<f64>, u: &DMatrix<f64>) -> Vec<f64> {
        let w = u.transpose() * c;
        let m = DMatrix::identity(u.ncols(), u.ncols()) + &w * u;
        let inv = m.try_inverse().unwrap();
        let after = c - w.transpose() * inv * &w;
        after.diagonal().iter().copied().collect()
    }

    #[test]
    fn the_factored_update_is_woodbury_also_for_a_singular_covariance() {
        // C of rank 2 in 3 parameters (the third direction unidentified), information on all
        // three directions.
        let l = DMatrix::from_row_slice(3, 2, &[1.0, 0.5, -0.3, 2.0, 0.7, 0.1]);
        let u = DMatrix::from_row_slice(3, 2, &[0.4, -1.0, 1.5, 0.2, 0.3, 0.9]);
        let c = &l * l.transpose();
        let got = updated_variances(&l, &u).unwrap();
        for (g, w) in got.iter().zip(woodbury(&c, &u)) {
            assert!((g - w).abs() < 1e-12 * c.diagonal().max(), "{g} vs {w}");
        }
        for k in 0..3 {
            assert!(got[k] <= c[(k, k)] && got[k] >= 0.0);
        }
    }

    #[test]
    fn an_ill_conditioned_covariance_gives_finite_variances_that_do_not_grow() {
        // Two parameters 10⁹ apart in scale and almost perfectly correlated: `Uᵀ C U` has
        // entries of 10¹⁸ that cancel to order 1, which the textbook formula cannot resolve.
        let l = DMatrix::from_row_slice(
            3,
            3,
            &[
                1e9,
                1.0,
                0.0,
                1e9 * (1.0 + 1e-12),
                -1.0,
                0.0,
                3.0,
                0.0,
                1e-9,
            ],
        );
        let u = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 2.0, -1.0, 1.0, 0.0, 0.5, 0.0, 1e6]);
        let before: Vec<f64> = (0..3).map(|k| l.row(k).norm_squared()).collect();
        let after = updated_variances(&l, &u).unwrap();
        for (b, a) in before.iter().zip(&after) {
            assert!(a.is_finite() && *a >= 0.0 && a <= b, "{b} → {a}");
        }
        // Nothing added: nothing changes.
        let none = updated_variances(&l, &DMatrix::zeros(3, 0)).unwrap();
        assert_eq!(none, before);
    }
}
