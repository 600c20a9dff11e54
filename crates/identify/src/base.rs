//! The model a session can identify: which parameters its runs determine (the *base
//! parameters*), which they see only in combination with those, and which they do not see.
//!
//! A user who brings a URDF and no `[identify] parameters` gets the full ISO 230-1 model: on a
//! five-axis trunnion 116 coefficients, of which an R-test and ball-bar session determines
//! perhaps half. Fitting them all leaves the solver stepping along directions the data barely
//! see (a cubic term of an axis the paths hardly move), where the second-order terms of the
//! model decide the step: the fit does not converge and prints numbers that mean nothing.
//!
//! Instead, before the fit, the problem is linearised once at the start and the parameters are
//! chosen greedily, in an order of physical priority, among the columns of the whitened
//! Jacobian scaled by each parameter's plausible range:
//! 1. set-up parameters (a ball's position, a tool length: every run needs them),
//! 2. location and squareness errors and the machine's set-up parameters,
//! 3. component errors by increasing order (a constant angular error, then the linear term —
//!    a scale —, then curvature…; Fourier harmonics likewise; tables and splines last).
//!
//! A parameter is taken when the part of its column the parameters already taken do not
//! explain would determine it to better than [`DETERMINED_SHARE`] of its plausible range (95 %
//! interval). A last check on the joint covariance of everything taken drops, lowest priority
//! first, any parameter whose interval is still too wide. Parameters not taken are *held*:
//! a set-up parameter at its start value; a machine coefficient stays in the fit with a prior
//! of `[identify] held_prior` (3 µm or µrad by default) about its start. The fit is then of
//! full rank and converges like any small linear problem, and the prior does two things a
//! hard hold cannot: a held coefficient's effect on the fitted runs is not forced onto the
//! taken ones (which would bias every prediction that sees the two differently — a validation
//! path, a compensation table), and predictions carry its uncertainty. The prior is an
//! assumption about the machine (its higher-order component errors are a few µm, as in a
//! machine in calibration); it never gives a held coefficient a number in the report.
//!
//! A held parameter whose column lies (to within the same threshold) in the span of the taken
//! ones is *aliased*: moving it changes the readings exactly as moving the taken ones by `κ`
//! times as much would. What the runs determine is then the combination `x_i + Σ κ_ij·x_j`
//! (first order), reported as such — value and interval from the fit — never as `x_i` alone. The choice of which parameter of a
//! combination carries the number follows the priority order: a ball's position absorbs the
//! first harmonic of C's radial error motion, squareness absorbs what of a straightness the
//! paths see as a slope.

use crate::fit::FitProblem;
use crate::ids::ParamId;
use crate::study::{Changes, Study};
use crate::{IdentifyError, param_specs};
use mtcal_kinematics::Term as BasisTerm;
use mtcal_solve::Options;
use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// A parameter is determined when its 95 % interval is at most this share of its plausible
/// range (a millimetre or milliradian for machine and set-up parameters: ±20 µm or µrad).
pub const DETERMINED_SHARE: f64 = 0.02;
/// Set-up parameters get more room: a ball's height known to ±100 µm still serves the fit.
pub const DETERMINED_SHARE_SETUP: f64 = 0.1;
/// A column whose scaled norm is below this is not seen by the runs at all.
const UNSEEN: f64 = 1e-6;
/// A held parameter is aliased when the part of its scaled column outside the span of the
/// taken ones is below this share of its norm (else it is seen, but too weakly).
const ALIASED: f64 = 1e-3;
/// Alias coefficients (file units per file unit) below this are left out of a combination.
pub const ALIAS_MIN: f64 = 1e-3;

/// Why a parameter is held.
#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum HeldWhy {
    /// The runs do not see it at all.
    NotObserved,
    /// The runs see it only as part of the combinations the taken parameters stand for.
    Aliased,
    /// The runs see it, but would determine it only to this 95 % interval (file units).
    TooWeak { u95: f64 },
}

/// A parameter the runs cannot determine (see the module doc for what holding it means).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Held {
    /// The parameter, for the code; `name` is for people.
    #[serde(skip)]
    pub id: crate::ids::ParamId,
    pub name: String,
    pub unit: String,
    pub why: HeldWhy,
}

/// One term `κ·x_j` of a combination.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Term {
    pub name: String,
    /// File units of the combination per file unit of `name`.
    pub coefficient: f64,
}

/// The model a session identifies ([`select`]).
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct BaseModel {
    /// The parameters held, in the session's parameter order.
    pub held: Vec<Held>,
    /// Per taken parameter (by name) that stands for a combination: the held parameters it
    /// absorbs, largest first.
    pub aliases: Vec<(String, Vec<Term>)>,
    /// Per validation run (by name) that depends on held parameters beyond what the taken ones
    /// carry of them: those parameters, the largest first, each with the RMS change of the
    /// run's readings per unit of it (µm per µm or µrad).
    pub validation: Vec<(String, Vec<Term>)>,
}

impl BaseModel {
    /// The terms a taken parameter's estimate also carries (empty: it is itself).
    pub fn aliases_of(&self, name: &str) -> &[Term] {
        self.aliases
            .iter()
            .find(|(n, _)| n == name)
            .map_or(&[], |(_, t)| t.as_slice())
    }
}

/// Physical priority of parameter `i` (lower is taken first); `None`: always estimated (an
/// effect's parameters, a set-up parameter with a prior).
fn priority(study: &Study, i: usize) -> Option<(u32, usize)> {
    if i >= study.layout().effect_offset() {
        return None;
    }
    let ParamId::Machine(coeff) = study.param_id(i) else {
        return study.param_info(i).prior_sigma.is_none().then_some((0, i));
    };
    let class = match coeff.term {
        // Location, squareness, tool and workpiece set-up: single values.
        None => 1,
        Some(BasisTerm::Legendre(order) | BasisTerm::Cos(order) | BasisTerm::Sin(order)) => {
            2 + order as u32
        }
        // Table knots and spline control points: after every polynomial order that matters.
        Some(BasisTerm::Knot(_) | BasisTerm::Control(_)) => 10,
    };
    Some((class, i))
}

/// Chooses the parameters `study`'s runs determine (see the module doc). `study` is as loaded:
/// every parameter of its model estimated.
pub fn select(study: &Study, options: &Options) -> Result<BaseModel, IdentifyError> {
    let specs = param_specs(study);
    let problem = FitProblem::new(study);
    let lin = mtcal_solve::linearize(&problem, &specs, &study.initial_x(), options.threads)?;
    let n = study.layout().n_x();
    let range: Vec<f64> = specs.iter().map(|s| s.scale.unwrap_or(1.0)).collect();
    // Columns of the factor (Rᵀ R = Jᵀ J), each scaled by its parameter's plausible range: a
    // column's norm is then how many standard deviations of the readings a move over the
    // whole range makes.
    let col = |j: usize| DVector::from_fn(n, |i, _| lin.r[i * n + j] * range[j]);
    let share = |i: usize| {
        if study.param_info(i).machine {
            DETERMINED_SHARE
        } else {
            DETERMINED_SHARE_SETUP
        }
    };
    let mut forced = Vec::new();
    let mut order = Vec::new();
    for i in 0..n {
        match priority(study, i) {
            None => forced.push(i),
            Some(p) => order.push(p),
        }
    }
    order.sort_unstable();
    // Greedy Gram–Schmidt (twice, for orthogonality) in priority order.
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut taken = forced.clone();
    let project_out = |v: &mut DVector<f64>, basis: &[DVector<f64>]| {
        for _ in 0..2 {
            for q in basis {
                let d = q.dot(v);
                v.axpy(-d, q, 1.0);
            }
        }
    };
    for &i in &forced {
        let mut v = col(i);
        project_out(&mut v, &basis);
        let norm = v.norm();
        if norm > UNSEEN {
            basis.push(v / norm);
        }
    }
    for &(_, i) in &order {
        let c = col(i);
        let mut v = c.clone();
        project_out(&mut v, &basis);
        let norm = v.norm();
        // 95 % interval in plausible ranges if it were taken: 1.96/‖residual column‖. A
        // quick test first; then the joint covariance: a parameter is taken only if every
        // parameter taken so far stays within its share, so that a group of weakly seen
        // higher orders never pushes out the location error they all resemble.
        if norm <= 1e-9 * c.norm() || crate::K95 / norm > share(i) {
            continue;
        }
        taken.push(i);
        let fits = covariance(&taken, &col).is_some_and(|cov| {
            taken.iter().enumerate().all(|(k, &p)| {
                forced.contains(&p) || crate::K95 * cov[(k, k)].max(0.0).sqrt() <= share(p)
            })
        });
        if fits {
            basis.push(v / norm);
        } else {
            taken.pop();
        }
    }
    taken.sort_unstable();
    Ok(describe(study, &taken, &col, &range))
}

/// `(AᵀA)⁻¹` of the scaled columns `taken`, or `None` when they are (numerically) dependent.
fn covariance(taken: &[usize], col: &dyn Fn(usize) -> DVector<f64>) -> Option<DMatrix<f64>> {
    let a = a_matrix(taken, col)?;
    (a.transpose() * &a).cholesky().map(|c| c.inverse())
}

fn a_matrix(taken: &[usize], col: &dyn Fn(usize) -> DVector<f64>) -> Option<DMatrix<f64>> {
    let cols: Vec<DVector<f64>> = taken.iter().map(|&i| col(i)).collect();
    if cols.is_empty() {
        return None;
    }
    Some(DMatrix::from_columns(&cols))
}

/// Held parameters, why, and the combinations the taken ones stand for.
fn describe(
    study: &Study,
    taken: &[usize],
    col: &dyn Fn(usize) -> DVector<f64>,
    range: &[f64],
) -> BaseModel {
    let n = study.layout().n_x();
    let a = a_matrix(taken, col);
    let chol = a.as_ref().and_then(|a| (a.transpose() * a).cholesky());
    let mut held = Vec::new();
    let mut terms: Vec<Vec<Term>> = vec![Vec::new(); taken.len()];
    // Per seen held parameter: how the taken ones stand in for it (SI per SI), least squares.
    let mut stand_in: Vec<(usize, Vec<f64>)> = Vec::new();
    for j in 0..n {
        if taken.contains(&j) || j >= study.layout().effect_offset() {
            continue;
        }
        let info = study.param_info(j);
        let c = col(j);
        let norm = c.norm();
        let why = match (&a, &chol) {
            _ if norm <= UNSEEN => HeldWhy::NotObserved,
            (Some(a), Some(chol)) => {
                let beta = chol.solve(&(a.transpose() * &c));
                let outside = (&c - a * &beta).norm();
                stand_in.push((
                    j,
                    taken
                        .iter()
                        .enumerate()
                        .map(|(k, &i)| beta[k] * range[i] / range[j])
                        .collect(),
                ));
                if outside <= ALIASED * norm {
                    for (k, &i) in taken.iter().enumerate() {
                        // x̂_i absorbs κ·x_j with κ = β·range_i/range_j (SI), the same in file
                        // units up to the units' ratio.
                        let per_si_i = study.param_info(i).per_si;
                        let kappa = beta[k] * range[i] / range[j] * per_si_i / info.per_si;
                        if kappa.abs() >= ALIAS_MIN {
                            terms[k].push(Term {
                                name: info.name.clone(),
                                coefficient: kappa,
                            });
                        }
                    }
                    HeldWhy::Aliased
                } else {
                    HeldWhy::TooWeak {
                        u95: crate::K95 / outside * range[j] * info.per_si,
                    }
                }
            }
            _ => HeldWhy::TooWeak {
                u95: crate::K95 / norm * range[j] * info.per_si,
            },
        };
        held.push(Held {
            id: study.param_id(j),
            name: info.name,
            unit: info.unit,
            why,
        });
    }
    let aliases = taken
        .iter()
        .zip(terms)
        .filter(|(_, t)| !t.is_empty())
        .map(|(&i, mut t)| {
            t.sort_by(|x, y| y.coefficient.abs().total_cmp(&x.coefficient.abs()));
            (study.param_info(i).name, t)
        })
        .collect();
    let validation = validation_dependence(study, taken, &stand_in);
    BaseModel {
        held,
        aliases,
        validation,
    }
}

/// A held parameter is named for a validation run when, at the size of its prior
/// ([`Study::held_prior`]), it would move the run's prediction (RMS, beyond what the taken
/// parameters carry of it) by at least this share of the run's noise σ.
pub const VALIDATION_DEPENDENCE_SHARE: f64 = 0.5;
/// At most this many held parameters are named per validation run.
const VALIDATION_DEPENDENCE_NAMED: usize = 6;

/// Which held parameters each validation run depends on in a way the fitted runs do not
/// determine: the run's sensitivity to held parameter `j` minus the sensitivity to what the
/// taken parameters absorb of it (`stand_in`). A validation path the fit runs determine has
/// none; one that does (a ball-bar circle at a C angle no fitted run visited, say) can be
/// predicted only as well as those parameters happen to be zero.
fn validation_dependence(
    study: &Study,
    taken: &[usize],
    stand_in: &[(usize, Vec<f64>)],
) -> Vec<(String, Vec<Term>)> {
    let x0 = study.initial_x();
    let mut out = Vec::new();
    for (r, run) in study.runs.iter().enumerate() {
        if run.fit || stand_in.is_empty() {
            continue;
        }
        let channels = study.channels(r);
        let nch = channels.len();
        // Sensitivities (SI per SI) of the run's predictions by central differences, one
        // micrometre or microradian either side: the model is linear far beyond that.
        let h = 1e-6;
        let mut x = x0.clone();
        let mut sensitivity = |i: usize| -> Vec<f64> {
            x[i] = x0[i] + h;
            let up = crate::fit::predict_run(study, r, &x);
            x[i] = x0[i] - h;
            let down = crate::fit::predict_run(study, r, &x);
            x[i] = x0[i];
            up.iter()
                .zip(&down)
                .map(|(a, b)| (a - b) / (2.0 * h))
                .collect()
        };
        let g_taken: Vec<Vec<f64>> = taken.iter().map(|&i| sensitivity(i)).collect();
        let mut terms = Vec::new();
        for (j, alpha) in stand_in {
            let mut delta = sensitivity(*j);
            for (g, a) in g_taken.iter().zip(alpha) {
                for (d, gi) in delta.iter_mut().zip(g) {
                    *d -= a * gi;
                }
            }
            // RMS in reading units per unit of the parameter.
            let info = study.param_info(*j);
            let ss: f64 = delta
                .iter()
                .enumerate()
                .map(|(s, d)| (d * channels[s % nch].unit.per_si() / info.per_si).powi(2))
                .sum();
            let rms = (ss / delta.len().max(1) as f64).sqrt();
            // The run's noise (its smallest channel σ) in reading units; the prior in the
            // parameter's.
            let noise = channels
                .iter()
                .map(|c| c.sigma * c.unit.per_si())
                .fold(f64::INFINITY, f64::min);
            if rms * study.held_prior * info.per_si >= VALIDATION_DEPENDENCE_SHARE * noise {
                terms.push(Term {
                    name: info.name,
                    coefficient: rms,
                });
            }
        }
        if terms.is_empty() {
            continue;
        }
        terms.sort_by(|a, b| b.coefficient.total_cmp(&a.coefficient));
        terms.truncate(VALIDATION_DEPENDENCE_NAMED);
        out.push((run.name.clone(), terms));
    }
    out
}

/// The study with the parameters its runs cannot determine held ([`select`]), or `study`
/// itself (and `None`) when the session names the parameters to estimate (`[identify]
/// parameters`: the user's choice stands, and what it cannot determine is reported as null
/// combinations) or nothing needs holding.
pub fn identifiable_study(
    study: Study,
    options: &Options,
) -> Result<(Study, Option<BaseModel>), IdentifyError> {
    if study.session.identify.contains_key("parameters") {
        return Ok((study, None));
    }
    let base = select(&study, options)?;
    if base.held.is_empty() {
        return Ok((study, Some(base)));
    }
    let changes = Changes {
        hold: base.held.iter().map(|h| h.id.clone()).collect(),
        ..study.changes().clone()
    };
    let reduced = study.rebuild(changes)?;
    Ok((reduced, Some(base)))
}

/// `name + 0.5·A − 2·B` with the coefficients in 3 significant digits.
pub fn expression(name: &str, terms: &[Term]) -> String {
    let mut s = name.to_string();
    for t in terms {
        let sign = if t.coefficient < 0.0 { '−' } else { '+' };
        let c = t.coefficient.abs();
        if (c - 1.0).abs() < 5e-4 {
            s.push_str(&format!(" {sign} {}", t.name));
        } else {
            s.push_str(&format!(" {sign} {}·{}", significant(c, 3), t.name));
        }
    }
    s
}

/// `x` with `digits` significant digits, without trailing zeros.
fn significant(x: f64, digits: i32) -> String {
    if x == 0.0 || !x.is_finite() {
        return "0".into();
    }
    let magnitude = x.abs().log10().floor() as i32;
    let decimals = (digits - 1 - magnitude).max(0) as usize;
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The error-model configuration (`.errors.toml`, `mtcal_machine::config`) of the parameters
/// `study` estimates: what a session like this one identifies. A component error is kept when
/// any of its coefficients is, with its basis cut to the highest order kept (a lower order the
/// runs could not determine comes along and is held again by [`select`]).
pub fn suggested_model(study: &Study, base: Option<&BaseModel>) -> String {
    use std::collections::BTreeMap;
    use std::fmt::Write as _;
    let mut components: BTreeMap<String, (char, u32)> = BTreeMap::new();
    let mut locations = Vec::new();
    let mut setup = Vec::new();
    let mut order_of = Vec::new();
    let held: Vec<&str> = base.map_or(Vec::new(), |b| {
        b.held.iter().map(|h| h.name.as_str()).collect()
    });
    for &k in study.layout().estimated() {
        let label = &study.coeff_labels[k];
        if held.contains(&label.as_str()) {
            continue;
        }
        match label.split_once('.') {
            Some((name, term)) => {
                let kind = term.chars().next().unwrap_or('P');
                let order = term[1..].parse::<u32>().unwrap_or(0);
                if !components.contains_key(name) {
                    order_of.push(name.to_string());
                }
                let e = components.entry(name.to_string()).or_insert((kind, 0));
                e.1 = e.1.max(order);
            }
            None if label.starts_with("TOOL_") || label.starts_with("WP_") => {
                setup.push(label.clone())
            }
            None => locations.push(label.clone()),
        }
    }
    let list = |v: &[String]| {
        v.iter()
            .map(|n| format!("\"{n}\""))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# The error model this session's runs identify, suggested by `mtcal identify \
         --suggest-model`\n# from {} ({} coefficients of the machine's model, {} of the \
         session's parameters not determined).\n# Keep it beside the URDF as <stem>.errors.toml. Format: \
         crates/machine/src/config.rs.\nschema = \"mtcal.errors/1\"",
        study.session.manifest.display(),
        study.layout().n_machine(),
        base.map_or(0, |b| b.held.len()),
    );
    let _ = writeln!(s, "components = [{}]", list(&order_of));
    let _ = writeln!(s, "locations = [{}]", list(&locations));
    let _ = writeln!(s, "setup = [{}]", list(&setup));
    for name in &order_of {
        let (kind, order) = components[name];
        match kind {
            'P' => {
                let _ = writeln!(
                    s,
                    "\n[component.{name}]\nkind = \"legendre\"\ndegree = {order}"
                );
            }
            'C' | 'S' => {
                let _ = writeln!(
                    s,
                    "\n[component.{name}]\nkind = \"fourier\"\nharmonics = {order}"
                );
            }
            // Tables and splines keep the machine's own configuration of their knots.
            _ => {}
        }
    }
    s
}

/// The covariance of the estimated parameters if the held machine coefficients were known
/// exactly (at their start values): `C_TT − C_TH·C_HH⁻¹·C_HT` of the fit's covariance — what
/// the runs alone determine, the interval a reduced model without them would print.
pub(crate) struct ConditionalCovariance {
    /// Parameter index → row of `cov` (the parameters that are not held and have a σ).
    row: std::collections::HashMap<usize, usize>,
    cov: DMatrix<f64>,
}

impl ConditionalCovariance {
    pub(crate) fn new(
        study: &Study,
        solution: &mtcal_solve::Solution,
        held: &[&str],
        index: &std::collections::HashMap<String, usize>,
    ) -> Self {
        let with_sigma = |i: &usize| solution.sigma[*i].is_some_and(|s| s > 0.0);
        let h: Vec<usize> = held
            .iter()
            .filter_map(|n| index.get(*n).copied())
            .filter(|i| with_sigma(i) && study.param_info(*i).machine)
            .collect();
        let t: Vec<usize> = (0..study.layout().n_x())
            .filter(|i| with_sigma(i) && !h.contains(i))
            .collect();
        let block = |a: &[usize], b: &[usize]| {
            DMatrix::from_fn(a.len(), b.len(), |r, c| solution.cov(a[r], b[c]))
        };
        let ctt = block(&t, &t);
        let cov = if h.is_empty() {
            ctt
        } else {
            let cth = block(&t, &h);
            match block(&h, &h).cholesky() {
                Some(chol) => ctt - &cth * chol.solve(&cth.transpose()),
                None => ctt,
            }
        };
        Self {
            row: t.iter().enumerate().map(|(r, &i)| (i, r)).collect(),
            cov,
        }
    }

    /// 95 % interval of `Σ w·x` (SI weights into file units) given the held ones; `None` when
    /// nothing is held or a member has no row (it is held itself: fixed, no variance).
    pub(crate) fn u95(&self, weights: &[(usize, f64)]) -> Option<f64> {
        if self.row.is_empty() {
            return None;
        }
        let rows: Vec<(usize, f64)> = weights
            .iter()
            .filter_map(|&(i, w)| self.row.get(&i).map(|&r| (r, w)))
            .collect();
        let var: f64 = rows
            .iter()
            .flat_map(|&(a, wa)| rows.iter().map(move |&(b, wb)| wa * wb * self.cov[(a, b)]))
            .sum();
        Some(crate::K95 * var.max(0.0).sqrt())
    }
}
