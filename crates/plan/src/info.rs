//! Information of planned runs on the machine parameters, and the choice of positions.
//!
//! Every unit of a plan (the fixed runs together; each candidate position with its runs) is
//! simulated noise-free and linearised at the nominal machine through the identification's own
//! [`FitProblem`]: `I_u = J_uᵀ J_u` (whitened, so each instrument counts by its σ) plus the
//! priors of the unit's set-up parameters. The unit's set-up parameters (ball, pivot, tool
//! length…) are its own, never shared with another unit, so they are eliminated by the Schur
//! complement, as [`mtcal_identify::information::what_if`] does for another session: what is
//! left is the unit's information on the machine parameters, and units add.
//!
//! The criterion is D-optimality on the wanted parameters: `log det C_WW`, the wanted block of
//! `C = (Σ_u I_u + Λ)⁻¹`, where `Λ` is a weak prior (σ = 1 mm or 1 mrad, the solver's own scale
//! of a plausible error) that keeps `C` finite while a parameter is still unidentified. Adding a
//! unit is the Woodbury update of `C` that `what_if` applies; here the matrices are small
//! (machine parameters only), so each trial inverts directly.

use crate::PlanError;
use mtcal_identify::{FitProblem, Study, param_specs_from};
use nalgebra::DMatrix;

/// σ of the weak prior on every machine parameter, SI.
pub const WEAK_PRIOR: f64 = 1e-3;

/// The machine parameters of a study (its estimated coefficients) and, per unit of runs, the
/// information on them.
#[derive(Clone, Debug)]
pub struct Informations {
    /// Coefficient labels (`EX0C`, `EXX.L2`…), in the study's order.
    pub names: Vec<String>,
    /// Unit of each (`um`, `urad`…) and its factor from SI.
    pub units: Vec<(String, f64)>,
    /// One `m × m` matrix per unit, in the order asked.
    pub units_info: Vec<DMatrix<f64>>,
}

/// Information of each group of runs (`units[u]`: run indices of `study`) on the study's
/// machine parameters, the units' set-up parameters eliminated.
pub fn unit_information(study: &Study, units: &[Vec<usize>]) -> Result<Informations, PlanError> {
    let n = study.layout().n_x();
    let machine: Vec<usize> = (0..n).filter(|&i| study.param_info(i).machine).collect();
    let x = study.initial_x();
    let mut specs = param_specs_from(study, &x);
    for s in &mut specs {
        s.prior = None;
        s.bounds = None;
    }
    let prior: Vec<f64> = (0..n)
        .map(|i| {
            study
                .param_info(i)
                .prior_sigma
                .map_or(0.0, |s| 1.0 / (s * s))
        })
        .collect();
    let mut out = Vec::with_capacity(units.len());
    for runs in units {
        let problem = FitProblem::for_runs(study, runs);
        let lin = mtcal_solve::linearize(&problem, &specs, &x, 0)
            .map_err(|e| PlanError::Information(e.to_string()))?;
        let r = DMatrix::from_row_slice(n, n, &lin.r);
        let mut info = r.transpose() * &r;
        // Only the unit's own set-up parameters: those its rows touch.
        let own: Vec<usize> = (0..n)
            .filter(|&i| !study.param_info(i).machine && info[(i, i)] > 0.0)
            .collect();
        for &i in &own {
            info[(i, i)] += prior[i];
        }
        out.push(schur(&info, &machine, &own));
    }
    Ok(Informations {
        names: machine.iter().map(|&i| study.param_info(i).name).collect(),
        units: machine
            .iter()
            .map(|&i| {
                let p = study.param_info(i);
                (p.unit, p.per_si)
            })
            .collect(),
        units_info: out,
    })
}

/// `I_kk − I_ku I_uu⁺ I_uk`.
fn schur(info: &DMatrix<f64>, keep: &[usize], drop: &[usize]) -> DMatrix<f64> {
    let pick = |rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |a, b| info[(rows[a], cols[b])])
    };
    let mut s = pick(keep, keep);
    if !drop.is_empty() {
        let uu = pick(drop, drop);
        let ku = pick(keep, drop);
        let tol = 1e-12 * uu.diagonal().max().max(f64::MIN_POSITIVE);
        if let Ok(p) = uu.pseudo_inverse(tol) {
            s -= &ku * p * ku.transpose();
        }
    }
    // Symmetrise what rounding left.
    (&s + s.transpose()) * 0.5
}

/// The covariance `(Σ info + Λ)⁻¹` of a selection.
pub fn covariance(base: &DMatrix<f64>, chosen: &[&DMatrix<f64>]) -> DMatrix<f64> {
    let m = base.nrows();
    let mut total = base.clone();
    for c in chosen {
        total += *c;
    }
    for k in 0..m {
        total[(k, k)] += 1.0 / (WEAK_PRIOR * WEAK_PRIOR);
    }
    // Scale to unit diagonal before the factorisation (µm and µrad information differ by
    // orders of magnitude).
    let d: Vec<f64> = (0..m).map(|k| 1.0 / total[(k, k)].sqrt()).collect();
    let scaled = DMatrix::from_fn(m, m, |a, b| total[(a, b)] * d[a] * d[b]);
    let inv = match scaled.clone().cholesky() {
        Some(c) => c.inverse(),
        None => scaled
            .pseudo_inverse(1e-14)
            .unwrap_or_else(|_| DMatrix::identity(m, m)),
    };
    DMatrix::from_fn(m, m, |a, b| inv[(a, b)] * d[a] * d[b])
}

/// `log det C_WW` of a selection: the D-criterion on the wanted parameters (smaller is better).
pub fn criterion(base: &DMatrix<f64>, chosen: &[&DMatrix<f64>], wanted: &[usize]) -> f64 {
    let c = covariance(base, chosen);
    let w = DMatrix::from_fn(wanted.len(), wanted.len(), |a, b| c[(wanted[a], wanted[b])]);
    // Scaled by the weak prior so the numbers stay O(1).
    let w = w / (WEAK_PRIOR * WEAK_PRIOR);
    match w.cholesky() {
        Some(ch) => 2.0 * ch.l().diagonal().iter().map(|v| v.ln()).sum::<f64>(),
        None => f64::INFINITY,
    }
}

/// Up to this many selections the planner tries them all.
pub const EXHAUSTIVE_LIMIT: usize = 2000;

/// Which candidates may be chosen and how many from each group.
#[derive(Clone, Debug)]
pub struct Choice<'a> {
    /// Information of the runs that are planned anyway.
    pub base: &'a DMatrix<f64>,
    /// Per candidate: its group and its information.
    pub candidates: Vec<(usize, &'a DMatrix<f64>)>,
    /// Per group, how many to choose.
    pub budget: Vec<usize>,
    /// Candidates that must not be chosen (a collision, out of reach).
    pub excluded: Vec<bool>,
    pub wanted: &'a [usize],
}

impl Choice<'_> {
    pub fn value(&self, chosen: &[usize]) -> f64 {
        let infos: Vec<&DMatrix<f64>> = chosen.iter().map(|&c| self.candidates[c].1).collect();
        criterion(self.base, &infos, self.wanted)
    }

    fn allowed(&self, c: usize) -> bool {
        !self.excluded.get(c).copied().unwrap_or(false)
    }

    /// Per group, how many it can give (its budget, or fewer allowed candidates).
    pub fn effective_budget(&self) -> Vec<usize> {
        self.budget
            .iter()
            .enumerate()
            .map(|(g, &k)| {
                let n = (0..self.candidates.len())
                    .filter(|&c| self.candidates[c].0 == g && self.allowed(c))
                    .count();
                k.min(n)
            })
            .collect()
    }

    /// The selection the planner makes: the exhaustive optimum when there are at most
    /// [`EXHAUSTIVE_LIMIT`] selections, else [`Choice::greedy`].
    pub fn choose(&self) -> Vec<usize> {
        self.exhaustive(EXHAUSTIVE_LIMIT)
            .unwrap_or_else(|| self.greedy())
    }

    /// Greedy sequential D-optimal selection, then single exchanges within each group until no
    /// exchange lowers the criterion. Returns the chosen candidates, sorted.
    pub fn greedy(&self) -> Vec<usize> {
        let budget = self.effective_budget();
        let mut taken = vec![0; budget.len()];
        let mut chosen: Vec<usize> = Vec::new();
        loop {
            let mut best: Option<(f64, usize)> = None;
            for c in 0..self.candidates.len() {
                let g = self.candidates[c].0;
                if !self.allowed(c) || chosen.contains(&c) || taken[g] >= budget[g] {
                    continue;
                }
                chosen.push(c);
                let v = self.value(&chosen);
                chosen.pop();
                if best.is_none_or(|(b, _)| v < b) {
                    best = Some((v, c));
                }
            }
            let Some((_, c)) = best else { break };
            taken[self.candidates[c].0] += 1;
            chosen.push(c);
        }
        self.exchange(&mut chosen);
        chosen.sort_unstable();
        chosen
    }

    /// Fedorov exchange: swap a chosen candidate for an unchosen one of its group while that
    /// lowers the criterion.
    fn exchange(&self, chosen: &mut [usize]) {
        let mut current = self.value(chosen);
        for _ in 0..50 {
            let mut improved = false;
            for slot in 0..chosen.len() {
                let old = chosen[slot];
                let g = self.candidates[old].0;
                for c in 0..self.candidates.len() {
                    if self.candidates[c].0 != g || !self.allowed(c) || chosen.contains(&c) {
                        continue;
                    }
                    chosen[slot] = c;
                    let v = self.value(chosen);
                    if v < current - 1e-12 * current.abs().max(1.0) {
                        current = v;
                        improved = true;
                    } else {
                        chosen[slot] = old;
                    }
                    if chosen[slot] != old {
                        break;
                    }
                }
            }
            if !improved {
                break;
            }
        }
    }

    /// Every selection within the budgets, the best one (for small sets and tests). `None` if
    /// there are more than `limit` selections.
    pub fn exhaustive(&self, limit: usize) -> Option<Vec<usize>> {
        let budget = self.effective_budget();
        let groups: Vec<Vec<usize>> = (0..budget.len())
            .map(|g| {
                (0..self.candidates.len())
                    .filter(|&c| self.candidates[c].0 == g && self.allowed(c))
                    .collect()
            })
            .collect();
        let per_group: Vec<Vec<Vec<usize>>> = groups
            .iter()
            .zip(&budget)
            .map(|(members, &k)| combinations(members, k))
            .collect();
        let total = per_group
            .iter()
            .try_fold(1usize, |acc, s| acc.checked_mul(s.len()))?;
        if total > limit {
            return None;
        }
        let mut best: Option<(f64, Vec<usize>)> = None;
        let mut index = vec![0; per_group.len()];
        loop {
            let mut sel: Vec<usize> = index
                .iter()
                .zip(&per_group)
                .flat_map(|(&i, s)| s[i].iter().copied())
                .collect();
            sel.sort_unstable();
            let v = self.value(&sel);
            if best.as_ref().is_none_or(|(b, _)| v < *b) {
                best = Some((v, sel));
            }
            // Next combination, odometer style.
            let mut g = 0;
            loop {
                if g == index.len() {
                    return best.map(|(_, s)| s);
                }
                index[g] += 1;
                if index[g] < per_group[g].len() {
                    break;
                }
                index[g] = 0;
                g += 1;
            }
        }
    }
}

/// Every `k`-subset of `items`, in lexicographic order.
pub fn combinations(items: &[usize], k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    let mut cur = Vec::with_capacity(k);
    fn rec(
        items: &[usize],
        k: usize,
        start: usize,
        cur: &mut Vec<usize>,
        out: &mut Vec<Vec<usize>>,
    ) {
        if cur.len() == k {
            out.push(cur.clone());
            return;
        }
        for i in start..items.len() {
            if items.len() - i < k - cur.len() {
                break;
            }
            cur.push(items[i]);
            rec(items, k, i + 1, cur, out);
            cur.pop();
        }
    }
    rec(items, k, 0, &mut cur, &mut out);
    out
}

/// The 95 % half-widths (report units) of every machine parameter for a selection; `None`
/// where the data leave a parameter unidentified (its variance is more than a quarter of the
/// weak prior's: the data do not even halve the prior's σ).
pub fn intervals(
    infos: &Informations,
    base: &DMatrix<f64>,
    chosen: &[&DMatrix<f64>],
) -> Vec<Option<f64>> {
    let c = covariance(base, chosen);
    (0..infos.names.len())
        .map(|k| {
            let v = c[(k, k)];
            (v < 0.25 * WEAK_PRIOR * WEAK_PRIOR)
                .then(|| mtcal_identify::report::K95 * v.max(0.0).sqrt() * infos.units[k].1)
        })
        .collect()
}
