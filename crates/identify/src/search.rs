//! The physics search, first piece: which parameters of the machine's full error model that the
//! fit held out would explain what the fit leaves (FORMATS.md effect `omitted-parameter`),
//! each scored against the solution without refitting ([`mtcal_solve::score_candidates`]):
//! the predicted drop in χ², a p-value corrected for the number of candidates, the share of the
//! candidate the fitted parameters absorb (concealment) and which fitted parameters it would
//! move, in their own standard deviations.
//!
//! A candidate's columns are the readings' derivatives with respect to its coefficients, through
//! the full model at the solution (held-out parameters are zero there, so the pose is the
//! fit's).

use crate::IdentifyError;
use crate::fit::{FitProblem, RowTarget, SampleEval};
use crate::study::Study;
use mtcal_kinematics::Workspace;
use mtcal_solve::{EvalError, Problem, Score, ScoreSink, ScoredProblem, Solution};

/// A candidate effect: a name for people and the model coefficients it adds.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// FORMATS.md effect name (`omitted-parameter`).
    pub effect: &'static str,
    /// The ISO 230-1 parameter (`EZC`, `EX0C`).
    pub name: String,
    /// Its coefficients in the full model (`Study::model`).
    coeffs: Vec<usize>,
}

/// A candidate and its test.
#[derive(Debug, Clone)]
pub struct Ranked {
    pub candidate: Candidate,
    pub score: Score,
    /// Fitted parameters the candidate would move by more than one of their standard
    /// deviations, largest first: name and shift in σ.
    pub biased: Vec<(String, f64)>,
}

impl Ranked {
    /// One sentence for the report.
    pub fn describe(&self) -> String {
        let s = &self.score;
        let mut text = format!(
            "{} ({}): χ² would drop by {:.1} ({} degrees of freedom, adjusted p = {:.2e}){}",
            self.candidate.name,
            self.candidate.effect,
            s.statistic,
            s.df,
            s.adjusted_p,
            if s.significant { ", significant" } else { "" }
        );
        let names: Vec<&str> = self.biased.iter().map(|(n, _)| n.as_str()).collect();
        if s.absorbed > 0.99 && !names.is_empty() {
            // Concealed: only its sliver outside the fitted span is tested, and fitting it
            // would trade it against those parameters.
            text += &format!(
                "; {:.1} % of it looks like {}: these data cannot tell it from them",
                100.0 * s.absorbed,
                names.join(", ")
            );
            return text;
        }
        if s.absorbed > 0.5 {
            text += &format!(
                "; {:.0} % of it looks like the fitted parameters",
                100.0 * s.absorbed
            );
        }
        if s.significant && !self.biased.is_empty() {
            let moved: Vec<String> = self
                .biased
                .iter()
                .map(|(n, z)| format!("{n} by {z:+.1} σ"))
                .collect();
            text += &format!("; fitting it moves {}", moved.join(", "));
        }
        text
    }
}

/// Every parameter of the full error model none of whose coefficients the fit estimates.
pub fn omitted_parameters(study: &Study) -> Vec<Candidate> {
    let mut estimated = vec![false; study.model.n_coeffs()];
    for &k in &study.estimated {
        estimated[k] = true;
    }
    study
        .model
        .errors()
        .params()
        .iter()
        .filter(|p| !(p.offset..p.offset + p.len).any(|k| estimated[k]))
        .map(|p| Candidate {
            effect: "omitted-parameter",
            name: p.name.to_string(),
            coeffs: (p.offset..p.offset + p.len).collect(),
        })
        .collect()
}

/// Scores `candidates` against `solution` (the fit of `study`), Holm's correction at
/// family-wise level `alpha`; strongest first.
pub fn rank(
    study: &Study,
    solution: &Solution,
    candidates: Vec<Candidate>,
    alpha: f64,
) -> Result<Vec<Ranked>, IdentifyError> {
    if candidates.is_empty() {
        return Ok(Vec::new());
    }
    let problem = Scoring {
        fit: FitProblem::new(study),
        study,
        coeffs: candidates.iter().flat_map(|c| c.coeffs.clone()).collect(),
        widths: candidates.iter().map(|c| c.coeffs.len()).collect(),
    };
    let specs = crate::param_specs(study);
    let scores = mtcal_solve::score_candidates(&problem, &specs, solution, alpha, 0)?;
    let mut ranked: Vec<Ranked> = candidates
        .into_iter()
        .zip(scores)
        .map(|(candidate, score)| {
            let mut biased: Vec<(String, f64)> = score
                .shift
                .iter()
                .enumerate()
                .filter_map(|(i, d)| {
                    let z = d / solution.sigma[i]?;
                    (z.abs() > 1.0).then(|| (study.param_info(i).name, z))
                })
                .collect();
            biased.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
            biased.truncate(3);
            Ranked {
                candidate,
                score,
                biased,
            }
        })
        .collect();
    ranked.sort_by(|a, b| b.score.statistic.total_cmp(&a.score.statistic));
    Ok(ranked)
}

/// The fit's rows with the candidates' columns.
struct Scoring<'a> {
    fit: FitProblem<'a>,
    study: &'a Study,
    /// The candidates' coefficients in the full model, concatenated.
    coeffs: Vec<usize>,
    widths: Vec<usize>,
}

impl ScoredProblem for Scoring<'_> {
    fn n_params(&self) -> usize {
        self.study.n_x
    }
    fn candidate_widths(&self) -> Vec<usize> {
        self.widths.clone()
    }
    fn n_blocks(&self) -> usize {
        self.fit.n_blocks()
    }
    fn eval_block(&self, b: usize, x: &[f64], sink: &mut ScoreSink<'_>) -> Result<(), EvalError> {
        let model = &self.study.model;
        let mut target = Target {
            sink,
            study: self.study,
            coeffs: &self.coeffs,
            full: self.study.coeffs_from(x),
            ws: model.workspace(),
            jac: Vec::new(),
            extra: vec![0.0; self.coeffs.len()],
        };
        self.fit.walk_rows(b, x, &mut target)
    }
}

/// Adds the candidate columns to the fit's rows.
struct Target<'a, 's> {
    sink: &'a mut ScoreSink<'s>,
    study: &'a Study,
    coeffs: &'a [usize],
    /// The full model's coefficients at the solution.
    full: Vec<f64>,
    ws: Workspace,
    /// The sample's readings' derivatives by every full-model coefficient (channels × n).
    jac: Vec<f64>,
    extra: Vec<f64>,
}

impl RowTarget for Target<'_, '_> {
    fn columns(&mut self, cols: &[usize]) {
        self.sink.columns(cols);
    }

    fn row(&mut self, res: f64, row: &[f64], eval: &SampleEval<'_>, sample: usize, channel: usize) {
        let model = &self.study.model;
        let n = model.n_coeffs();
        if channel == 0 {
            let run = &self.study.runs[eval.run];
            let na = model.machine().n_axes();
            let q = &run.q[sample * na..(sample + 1) * na];
            model.tool_pose_for_jacobian(q, &self.full, &mut self.ws);
            self.jac.resize(eval.d_pose.len() * n, 0.0);
            // The pose rows are whitened already: so are these columns.
            model.project_tool_jacobian(&self.ws, &eval.d_pose, &mut self.jac);
        }
        let jac = &self.jac[channel * n..(channel + 1) * n];
        for (e, &k) in self.extra.iter_mut().zip(self.coeffs) {
            *e = jac[k];
        }
        self.sink.row(res, row, &self.extra);
    }
}
