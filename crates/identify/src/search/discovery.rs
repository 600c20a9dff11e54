//! What the search reports: each accepted [`Stage`] turned into a [`Discovery`] (parameters from
//! the final fit, the biases it corrected, where the residuals showed it, a sentence), the
//! candidates the data cannot tell from the fitted parameters ([`concealed`]), the measurements
//! that would separate them ([`separating_measurement`], [`telling_apart`]), and the search in
//! words ([`SearchFindings::summary`]). Reads the stages, the ranking and the final fit;
//! only the loop uses it.

use super::fitted::Fitted;
use super::rank::{CONCEALED, Ranked};
use super::step::Stage;
use crate::K95;
use crate::findings::{
    Concealed, Correction, Discovery, DiscoveryParameter, DiscoverySpan, Remains, Trial,
};
use crate::findings::{SearchFindings, SearchStop};
use crate::ids::ParamId;
use crate::report::Identification;
use crate::study::Study;
use mtcal_effects::{Candidate, Effect, EffectInfo};
use mtcal_solve::Solution;
use std::sync::Arc;

/// What would tell candidate `b` from `a` (both explain the data alike): a session in which
/// their drivers part, what their families say tells them apart, or another place.
pub(super) fn telling_apart(a: &Candidate, b: &Candidate) -> String {
    let (ca, cb) = (a.class(), b.class());
    let driver = |c: &Candidate| match c {
        Candidate::Effect(e) => e.info().driver.clone().unwrap_or_default(),
        Candidate::Model(_) => String::new(),
    };
    if ca == cb && driver(a) != driver(b) {
        return format!(
            "a session in which {} and {} do not follow each other (a pause, a cool-down, a \
             change of spindle speed)",
            driver(a),
            driver(b)
        );
    }
    if let Some(told) = mtcal_effects::telling_apart(ca, cb) {
        return told.to_string();
    }
    if ca == cb {
        return "measure with the set-up or path changed so the two targets move differently \
                (another ball position, another height)"
            .into();
    }
    separating_measurement(b, &[])
}

/// The discovery of one accepted step, with its parameters from the final fit.
pub(super) fn discovery(stage: &Stage, last: &Fitted) -> Discovery {
    let study = &last.study;
    let sol = &last.solution;
    let (info, parameters, spans, words) = match &stage.ranked.candidate {
        Candidate::Effect(e) => {
            // Find the effect in the final study by its label.
            let label = &e.info().label;
            let found = study.effects().iter().enumerate().find(|(_, fx)| {
                (fx.info().label == *label || fx.info().label.starts_with(&format!("{label} #")))
                    && stage_effect_matches(stage, fx)
            });
            let (fx, offset) = match found {
                Some((k, fx)) => (Arc::clone(fx), study.layout().effect_range(k).start),
                None => (Arc::clone(e), study.layout().effect_offset()),
            };
            let values: Vec<f64> = (0..fx.params().len()).map(|j| sol.x[offset + j]).collect();
            let u95: Vec<Option<f64>> = (0..fx.params().len())
                .map(|j| sol.sigma[offset + j].map(|s| K95 * s))
                .collect();
            let held: Vec<bool> = (0..fx.params().len())
                .map(|j| study.changes().hold.contains(&study.param_id(offset + j)))
                .collect();
            // The axis' states where its approach is unknown are fitted, not claimed.
            let params = fx
                .params()
                .iter()
                .enumerate()
                .filter(|(_, p)| !p.nuisance)
                .map(|(j, p)| DiscoveryParameter {
                    name: p.name.clone(),
                    value: values[j] * p.per_si,
                    unit: p.unit.clone(),
                    u95: u95[j].map(|u| u * p.per_si),
                    held: held[j],
                })
                .collect();
            let mut words = fx.describe(&values, &u95);
            let states = fx
                .params()
                .iter()
                .filter(|p| p.nuisance && p.kind == mtcal_effects::ParamKind::Shape)
                .count();
            if states > 0 {
                words.push_str(&format!(
                    " (the side the axis arrived from before its first motion fitted in \
                     {states} run{}: the approach is not in the files)",
                    if states == 1 { "" } else { "s" }
                ));
            }
            if held.iter().any(|&h| h) {
                // A held shape has no interval because it was not fitted, not because the
                // data confuse it with another parameter.
                words = words.replace(
                    "(not separable from the fitted parameters)",
                    "(held: these data do not determine it)",
                );
            }
            let spans = fx.spans().iter().map(DiscoverySpan::of).collect();
            (fx.info().clone(), params, spans, words)
        }
        Candidate::Model(m) => {
            let params: Vec<DiscoveryParameter> = (0..study.layout().n_machine())
                .filter_map(|i| {
                    let info = study.param_info(i);
                    let of_m =
                        matches!(study.param_id(i), ParamId::Machine(c) if c.param == m.param);
                    of_m.then(|| DiscoveryParameter {
                        name: info.name.clone(),
                        value: sol.x[i] * info.per_si,
                        unit: info.unit.clone(),
                        u95: sol.sigma[i].map(|s| K95 * s * info.per_si),
                        held: false,
                    })
                })
                .collect();
            let list: Vec<String> = params
                .iter()
                .map(|p| match p.u95 {
                    Some(u) => format!("{} = {:.3} ± {:.3} {}", p.name, p.value, u, p.unit),
                    None => format!("{} (not separable)", p.name),
                })
                .collect();
            let words = if m.extra_order == 0 {
                format!(
                    "the error {} the model left out: {}",
                    m.param,
                    list.join(", ")
                )
            } else {
                format!(
                    "{} needs {} more orders: {}",
                    m.param,
                    m.extra_order,
                    list.join(", ")
                )
            };
            let axis = m.param.axis().map(|a| a.as_char());
            (
                EffectInfo {
                    class: m.class,
                    axis,
                    component: Some(m.param.to_string()),
                    driver: axis.map(|a| a.to_string()),
                    label: m.label(),
                },
                params,
                Vec::new(),
                words,
            )
        }
    };
    let excess =
        (stage.before_solution.chi2 - stage.before_solution.dof as f64).max(f64::MIN_POSITIVE);
    let removed = stage.before_solution.chi2 - stage.after_solution.chi2;
    let share = (removed / excess).clamp(0.0, 1.0);
    let corrected = corrections(stage, study, sol);
    let location = locate(stage, &info);
    let validation = |id: &Identification| {
        let (mut ss, mut n) = (0.0, 0usize);
        for r in &id.validation {
            let k = r.channels.iter().map(|c| c.samples).sum::<usize>();
            ss += r.rms_um * r.rms_um * k as f64;
            n += k;
        }
        (n > 0).then(|| (ss / n as f64).sqrt())
    };
    let (val_before, val_after) = (validation(&stage.before_id), validation(&stage.after_id));
    let mut explanation = match &location {
        Some(loc) => where_words(loc, &stage.before_id),
        None => {
            "the residuals' structure tests did not show it (it hides below the noise or inside \
             the fitted parameters); the score test did"
                .to_string()
        }
    };
    explanation += &format!(
        "; {words} explains {:.0} % of the excess χ²; held-out RMS {:.3} → {:.3} µm",
        100.0 * share,
        stage.before_heldout.rms_um,
        stage.after_heldout.rms_um
    );
    if let (Some(a), Some(b)) = (val_before, val_after) {
        explanation += &format!(", validation RMS {a:.3} → {b:.3} µm");
    }
    if let Some(why) = &stage.simplified {
        explanation += &format!(" ({why})");
    }
    if stage.ranked.score.absorbed > 0.5 {
        let like: Vec<&str> = stage
            .ranked
            .mimics
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        explanation += &format!(
            "; {:.0} % of it looked like the fitted parameters{} (to separate them better: {})",
            100.0 * stage.ranked.score.absorbed,
            if like.is_empty() {
                String::new()
            } else {
                format!(", chiefly {}", like.join(", "))
            },
            separating_measurement(
                &stage.ranked.candidate,
                &stage
                    .ranked
                    .mimics
                    .iter()
                    .map(|(n, _)| n.clone())
                    .collect::<Vec<_>>()
            )
        );
    }
    if !stage.lookalikes.is_empty() {
        let others: Vec<String> = stage
            .lookalikes
            .iter()
            .map(|l| {
                format!(
                    "{} ({} by {:.1} in χ²)",
                    l.candidate,
                    if l.delta_chi2 >= 0.0 {
                        "worse"
                    } else {
                        "better"
                    },
                    l.delta_chi2.abs()
                )
            })
            .collect();
        explanation += &format!(
            "; THESE DATA CANNOT TELL IT FROM {} — neither is the answer; to tell them apart: {}",
            others.join(" or "),
            stage.lookalikes[0].measurement
        );
    }
    if !corrected.is_empty() {
        let list: Vec<String> = corrected
            .iter()
            .take(4)
            .map(|c| {
                format!(
                    "{} was biased by {:+.3} {} and is now {:.3} ± {:.3} {}",
                    c.name,
                    c.before - c.after,
                    c.unit,
                    c.after,
                    c.u95,
                    c.unit
                )
            })
            .collect();
        explanation += &format!("; {}", list.join(", "));
    }
    Discovery {
        effect: info.class.to_string(),
        axis: info.axis.map(|a| a.to_string()),
        component: info.component.clone(),
        driver: info.driver.clone(),
        label: info.label.clone(),
        parameters,
        spans,
        rms_before_um: stage.before_id.fit.rms_um,
        rms_after_um: stage.after_id.fit.rms_um,
        heldout_rms_before_um: stage.before_heldout.rms_um,
        heldout_rms_after_um: stage.after_heldout.rms_um,
        validation_rms_before_um: val_before,
        validation_rms_after_um: val_after,
        share_of_excess: share,
        statistic: stage.ranked.score.statistic,
        adjusted_p: stage.ranked.score.adjusted_p,
        absorbed: stage.ranked.score.absorbed,
        corrected,
        location,
        alternatives: stage.lookalikes.clone(),
        sentence: words,
        explanation,
    }
}

/// Whether `fx` (an effect of the final study) is the stage's effect: same label stem and
/// same starting shape.
fn stage_effect_matches(stage: &Stage, fx: &Arc<dyn Effect>) -> bool {
    let Candidate::Effect(e) = &stage.ranked.candidate else {
        return false;
    };
    // A static coupling and its lagged form share a label: the lag has a time constant more.
    e.params().len() == fx.params().len()
        && e.params()
            .iter()
            .zip(fx.params())
            .all(|(a, b)| a.name == b.name && a.initial == b.initial)
}

/// Machine parameters that moved by more than two standard deviations (of the final fit) when
/// the stage's effect was added: before is the fit without it, after the final fit.
fn corrections(stage: &Stage, study: &Study, sol: &Solution) -> Vec<Correction> {
    let mut out: Vec<(f64, Correction)> = (0..study.layout().n_machine())
        .filter_map(|i| {
            let info = study.param_info(i);
            let sigma = sol.sigma[i]? * info.per_si;
            let b = *stage.before_params.get(&study.param_id(i))?;
            let a = sol.x[i] * info.per_si;
            let z = (b - a).abs() / sigma;
            (z > 2.0).then_some((
                z,
                Correction {
                    name: info.name,
                    unit: info.unit,
                    before: b,
                    after: a,
                    u95: K95 * sigma,
                },
            ))
        })
        .collect();
    out.sort_by(|a, b| b.0.total_cmp(&a.0));
    out.into_iter().map(|(_, c)| c).collect()
}

/// The mismatch location (before the step) that matches the effect's driver best.
fn locate(stage: &Stage, info: &EffectInfo) -> Option<mtcal_mismatch::Location> {
    let m = &stage.before_id.mismatch;
    if !m.detected {
        return None;
    }
    let driver = info.driver.clone().unwrap_or_default();
    let matches = |along: &str| {
        along == driver
            || (driver.len() == 1 && along == format!("{driver} direction"))
            || (driver == "S^2" && along == "S")
            || (driver.contains('*') && driver.split('*').any(|d| d == along))
    };
    m.locations
        .iter()
        .find(|l| l.along.as_deref().is_some_and(matches))
        .or(m.locations.first())
        .cloned()
}

/// "run X's residuals are structured along t (lag-1 autocorrelation 0.93)".
fn where_words(loc: &mtcal_mismatch::Location, id: &Identification) -> String {
    let Some(along) = &loc.along else {
        return format!(
            "run {}'s channel {} is off by more than the noise",
            loc.run, loc.channel
        );
    };
    let ac = id.tests.iter().find(|t| {
        t.run == loc.run
            && t.channel == loc.channel
            && t.along.as_deref() == Some(along)
            && t.test == mtcal_mismatch::TestKind::LjungBox
    });
    let span = match (loc.from, loc.to) {
        (Some(a), Some(b)) if a != b => format!(" between {along} = {} and {}", num(a), num(b)),
        _ => String::new(),
    };
    let detail = ac.map_or_else(String::new, |t| {
        format!(" (lag-1 autocorrelation {:.2})", t.detail)
    });
    format!(
        "run {}'s {} residuals are structured along {along}{detail}, {:.0} % of their excess{span}",
        loc.run,
        loc.channel,
        100.0 * loc.share
    )
}

/// `x` with at most four decimals, trailing zeros dropped.
fn num(x: f64) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.to_string() }
}

/// Structure the final model `id` leaves in its residuals (its mismatch analysis), at most
/// three places, each with its shape in words and the candidates that came closest (the final
/// ranking's strongest, with why each was not kept): what remains is reported, not explained
/// by stacking candidates onto it.
pub(super) fn remains(
    id: &Identification,
    ranking: &[Ranked],
    steps: &[Vec<Trial>],
) -> Vec<Remains> {
    if !id.mismatch.detected {
        return Vec::new();
    }
    let closest: Vec<String> = ranking
        .iter()
        .take(3)
        .map(|r| {
            let label = r.candidate.label();
            let tried = steps
                .iter()
                .rev()
                .flat_map(|t| t.iter())
                .find(|t| t.candidate.starts_with(&label) && !t.accepted);
            match tried {
                Some(t) => format!(
                    "{} [{}]: not kept, {}",
                    r.name(),
                    r.candidate.class(),
                    t.why
                ),
                None if r.score.significant => format!(
                    "{} [{}]: χ² would drop by {:.1}, not refitted",
                    r.name(),
                    r.candidate.class(),
                    r.score.statistic
                ),
                None => format!(
                    "{} [{}]: χ² would drop by {:.1}, not significant (adjusted p = {:.2})",
                    r.name(),
                    r.candidate.class(),
                    r.score.statistic,
                    r.score.adjusted_p
                ),
            }
        })
        .collect();
    id.mismatch
        .locations
        .iter()
        .take(3)
        .map(|loc| Remains {
            location: loc.clone(),
            shape: shape_words(loc, &id.tests),
            closest: closest.clone(),
        })
        .collect()
}

/// The shape of the structure at `loc` in words, from the variable that orders it and the
/// tests that saw it.
fn shape_words(loc: &mtcal_mismatch::Location, tests: &[mtcal_mismatch::TestRecord]) -> String {
    let Some(along) = &loc.along else {
        return "excess spread evenly over the run: no recorded variable orders it".into();
    };
    let span = match (loc.from, loc.to) {
        (Some(a), Some(b)) if a != b => format!(
            ", {:.0} % of its excess between {along} = {} and {}",
            100.0 * loc.share,
            num(a),
            num(b)
        ),
        _ => String::new(),
    };
    if along == "t" {
        return format!("a change in time{span}");
    }
    if let Some(axis) = along.strip_suffix(" direction") {
        return format!(
            "a difference between the directions of motion of {axis}: it flips where {axis} \
             reverses"
        );
    }
    if along.starts_with("T_") || along == "S" {
        return format!("it follows {along}{span}");
    }
    let periodic = tests.iter().find(|t| {
        t.run == loc.run
            && t.channel == loc.channel
            && t.along.as_deref() == Some(along.as_str())
            && t.test == mtcal_mismatch::TestKind::LombScargle
            && t.rejected
    });
    if let Some(t) = periodic {
        return format!("periodic along {along} with a period of {}", num(t.detail));
    }
    if loc.share > 0.5 && !span.is_empty() {
        format!("a local shape along {along}{span}")
    } else {
        format!("a shape along {along}{span}")
    }
}

/// Candidates the data cannot tell from the fitted parameters (more than 99 % absorbed), one per
/// effect class and target, most absorbed first. A candidate that hides behind an effect of its
/// own label already fitted (the same drift at another starting τ) is that effect, not a
/// concealed one.
pub(super) fn concealed(ranking: &[Ranked]) -> Vec<Concealed> {
    let mut out: Vec<Concealed> = Vec::new();
    let mut seen: Vec<(String, Option<String>, Option<char>)> = Vec::new();
    let mut sorted: Vec<&Ranked> = ranking
        .iter()
        .filter(|r| r.score.absorbed > CONCEALED && !r.mimics.is_empty())
        .filter(|r| {
            // One that hides behind an effect of its own class and target already in the
            // model (the same drift at another τ, a reversal that also changes along the
            // stroke) is that effect in another form.
            let own = r.candidate.label();
            let own_kind = own.split(" (").next().unwrap_or(&own);
            !r.mimics.iter().any(|(n, _)| {
                n.starts_with(&format!("{own}."))
                    || n.starts_with(&format!("{own} #"))
                    || n.split(" (").next() == Some(own_kind) && n.contains(").")
            })
        })
        .collect();
    sorted.sort_by(|a, b| b.score.absorbed.total_cmp(&a.score.absorbed));
    for r in sorted {
        let key = match &r.candidate {
            Candidate::Effect(e) => (
                e.info().class.to_string(),
                e.info().component.clone(),
                e.info().axis,
            ),
            Candidate::Model(m) => (m.class.to_string(), Some(m.param.to_string()), None),
        };
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let names: Vec<String> = r.mimics.iter().map(|(n, _)| n.clone()).collect();
        out.push(Concealed {
            candidate: r.name(),
            effect: r.candidate.class().to_string(),
            absorbed: r.score.absorbed,
            measurement: separating_measurement(&r.candidate, &names),
            hides_behind: names,
        });
        if out.len() == 12 {
            break;
        }
    }
    out
}

/// The measurement that would separate a concealed candidate from the parameters it hides
/// behind.
pub fn separating_measurement(candidate: &Candidate, hides_behind: &[String]) -> String {
    if let Some(said) = mtcal_effects::separating_measurement(candidate.class()) {
        return said.to_string();
    }
    let setup = hides_behind.iter().any(|n| {
        n.contains("tool_length")
            || n.contains("ball_")
            || n.contains("pivot")
            || n.contains("TOOL")
    });
    if setup {
        "a second ball height (or a second tool length): set-up offsets then no longer move \
         with the axis like this error"
            .into()
    } else {
        "a second ball position at another radius or height, and the axis over its whole \
         stroke"
            .into()
    }
}

impl SearchFindings {
    /// The physics search in words: what was added and why, what was tried and not kept,
    /// what the data cannot tell apart.
    pub fn summary(&self) -> String {
        self.summary_with(true)
    }

    /// [`Self::summary`]; without `verbose` only what a person reads first: how the search
    /// ended, each discovery with its values, its evidence, the parameters it had biased and
    /// its look-alikes, and a few of what the data cannot tell apart (every trial, every
    /// concealed candidate and the remaining candidates' tests are in the JSON and with
    /// `verbose`).
    pub fn summary_with(&self, verbose: bool) -> String {
        use std::fmt::Write as _;
        let report = &self.report;
        let mut s = String::new();
        let added = match self.discoveries.len() {
            0 if report.stopped == SearchStop::BaseNotConverged => String::new(),
            0 => "nothing added; ".to_string(),
            1 => "1 effect added; then ".to_string(),
            n => format!("{n} effects added; then "),
        };
        let _ = writeln!(
            s,
            "physics search: {} candidates scored (family-wise α = 5 %); {added}{}",
            report.candidates, report.stopped
        );
        if verbose {
            for (k, trials) in report.steps.iter().enumerate() {
                for t in trials {
                    let _ = writeln!(
                        s,
                        "  step {}: {} [{}] {}: {}",
                        k + 1,
                        if t.accepted { "added" } else { "not kept" },
                        t.effect,
                        t.candidate,
                        t.why
                    );
                }
            }
        }
        if self.discoveries.is_empty() {
            let _ = writeln!(s, "discoveries: none");
        } else {
            let _ = writeln!(s, "discoveries:");
            for d in &self.discoveries {
                if verbose {
                    let _ = writeln!(s, "  {} — {}", d.label, d.explanation);
                } else {
                    s.push_str(&d.in_brief());
                }
            }
        }
        if !report.withdrawn.is_empty() {
            let _ = writeln!(
                s,
                "withdrawn (added at a step, not kept by the final model):"
            );
            for w in &report.withdrawn {
                let _ = writeln!(s, "  - {} [{}]: {}", w.candidate, w.effect, w.why);
            }
        }
        if !report.remains.is_empty() {
            let _ = writeln!(
                s,
                "REMAINS UNEXPLAINED (no candidate explains it; nothing is claimed for it):"
            );
            for r in report.remains.iter().take(if verbose { 3 } else { 2 }) {
                let _ = writeln!(
                    s,
                    "  run {}, channel {}: {}",
                    r.location.run, r.location.channel, r.shape
                );
            }
            if let Some(first) = report.remains.first() {
                for c in first.closest.iter().take(if verbose { 3 } else { 2 }) {
                    let _ = writeln!(s, "    closest: {c}");
                }
            }
        }
        let shown = if verbose { report.concealed.len() } else { 3 };
        if !report.concealed.is_empty() {
            let _ = writeln!(
                s,
                "concealed (these data cannot tell them from the fitted parameters):"
            );
            for c in report.concealed.iter().take(shown) {
                let _ = writeln!(
                    s,
                    "  {} ({:.1} % like {}): {}",
                    c.candidate,
                    100.0 * c.absorbed,
                    c.hides_behind.join(", "),
                    c.measurement
                );
            }
            if report.concealed.len() > shown {
                let _ = writeln!(
                    s,
                    "  … {} more in the JSON (`search.concealed`) and with --verbose",
                    report.concealed.len() - shown
                );
            }
        }
        if verbose && !report.ranking.is_empty() {
            let _ = writeln!(s, "strongest remaining candidates:");
            for line in &report.ranking {
                let _ = writeln!(s, "  {line}");
            }
        }
        s
    }
}
