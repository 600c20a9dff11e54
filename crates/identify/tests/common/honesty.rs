//! The honesty rules every search result must hold (`search_honesty.rs`, and the independent
//! simulator's sessions of `search_real_shapes.rs`): a discovery is a determined, physical
//! effect of the final fit, none comes from a fit that did not converge, and the search's
//! first line agrees with its discoveries.

#![allow(dead_code)]

use mtcal_identify::param_specs;
use mtcal_identify::search::SearchResult;

/// Every honesty rule on `result` (see the module docs); `Err` says which failed.
pub fn honest(result: &SearchResult) -> Result<(), String> {
    let id = &result.identification;
    let found = &result.findings;
    let summary = found.summary();
    let first = summary.lines().next().unwrap_or_default();
    let n = found.discoveries.len();
    let says = match n {
        0 if !result.initial.solver.converged => "did not converge".to_string(),
        0 => "nothing added".to_string(),
        1 => "1 effect added".to_string(),
        n => format!("{n} effects added"),
    };
    if !first.contains(&says) {
        return Err(format!("{n} discoveries, but the first line says: {first}"));
    }
    if n == 0 {
        return Ok(());
    }
    if !result.initial.solver.converged || !id.solver.converged {
        return Err(format!(
            "discoveries on a fit that did not converge:\n{summary}"
        ));
    }
    let study = &result.study;
    let specs = param_specs(study);
    let index = |name: &str| (0..study.layout().n_x()).find(|&i| study.param_info(i).name == name);
    for d in &found.discoveries {
        let mut amplitudes = Vec::new();
        for p in &d.parameters {
            let full = if d.effect == "omitted-parameter" || d.effect == "component-order" {
                p.name.clone()
            } else {
                format!("{}.{}", d.label, p.name)
            };
            let i = index(&full).ok_or_else(|| format!("{full} is not in the final model"))?;
            let per_si = study.param_info(i).per_si;
            if p.held {
                if specs[i].bounds.is_none() || p.u95.is_some() {
                    return Err(format!("{}: {full} is held but not a shape", d.label));
                }
                continue;
            }
            let Some(u95) = p.u95 else {
                return Err(format!("{}: {full} has no interval\n{summary}", d.label));
            };
            if specs[i].bounds.is_some() {
                if u95 >= p.value.abs() {
                    return Err(format!("{}: shape {full} = {} ± {u95}", d.label, p.value));
                }
                continue;
            }
            amplitudes.push(i);
            if let Some(range) = specs[i].scale {
                let range = range * per_si;
                if p.value.abs() > range || u95 > range {
                    return Err(format!(
                        "{}: {full} = {} ± {u95} against a plausible range of ±{range}",
                        d.label, p.value
                    ));
                }
            }
        }
        if !amplitudes.is_empty() {
            let (w, limit) = wald(&result.solution, &amplitudes);
            if w <= limit {
                return Err(format!(
                    "{}: its amplitudes are within their 95 % region of zero (Wald {w:.1} ≤ \
                     {limit:.1})\n{summary}",
                    d.label
                ));
            }
        }
        refinements_determined(result, d)?;
    }
    Ok(())
}

/// A discovery's refinement — an amplitude without which its effect is a simpler one of its
/// family (a backlash's change along the stroke) — is determined on its own: one within its
/// interval of zero claims more than the data show.
fn refinements_determined(
    result: &SearchResult,
    d: &mtcal_identify::search::Discovery,
) -> Result<(), String> {
    let study = &result.study;
    let Some(k) = study
        .effects()
        .iter()
        .position(|e| e.info().label == d.label)
    else {
        return Ok(());
    };
    let effect = &study.effects()[k];
    let start = study.layout().effect_range(k).start;
    for (j, p) in effect.params().iter().enumerate() {
        if effect.without(j).is_none() {
            continue;
        }
        let i = start + j;
        let sigma = result.solution.sigma[i].filter(|_| result.solution.identified[i]);
        let value = result.solution.x[i];
        if !sigma.is_some_and(|s| mtcal_identify::K95 * s < value.abs()) {
            return Err(format!(
                "{}: {} = {} ± {:?} (SI) is within its interval of zero, and without it the \
                 effect is {}",
                d.label,
                p.name,
                value,
                sigma.map(|s| mtcal_identify::K95 * s),
                effect.without(j).unwrap().info().label
            ));
        }
    }
    Ok(())
}

/// `xᵀC⁺x` of the parameters `idx` of `solution` and the χ² 95 % quantile of its rank.
fn wald(solution: &mtcal_solve::Solution, idx: &[usize]) -> (f64, f64) {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let k = idx.len();
    let c = nalgebra::DMatrix::from_fn(k, k, |a, b| solution.cov(idx[a], idx[b]));
    let x = nalgebra::DVector::from_iterator(k, idx.iter().map(|&i| solution.x[i]));
    let eps = 1e-12 * c.norm();
    let rank = c
        .clone()
        .svd(false, false)
        .singular_values
        .iter()
        .filter(|&&s| s > eps)
        .count();
    let pinv = c.pseudo_inverse(eps).unwrap();
    let w = (x.transpose() * pinv * &x)[(0, 0)];
    (
        w,
        ChiSquared::new(rank.max(1) as f64)
            .unwrap()
            .inverse_cdf(0.95),
    )
}
