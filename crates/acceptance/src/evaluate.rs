//! A tolerance file checked against an identification's [`Evidence`]: one [`Check`] per
//! toleranced quantity (per run for the instruments' values), each decided by the file's rule
//! ([`crate::rule::decide`]), and the overall verdict.

use crate::evidence::{CurveEvidence, Evidence, MetricEvidence, ParameterEvidence};
use crate::file::{ParameterTolerance, Tolerances};
use crate::rule::{self, Decision, DecisionRule, Verdict, Zone};
use serde::Serialize;
use std::fmt::Write as _;

/// The ISO 230-4 value the ball-bar's evaluation reports.
pub const CIRCULAR_DEVIATION: &str = "circular deviation G (ISO 230-4)";

/// The verdicts on every tolerance of a file (the identification JSON's `acceptance`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Acceptance {
    /// The tolerance file as the user named it.
    pub file: String,
    pub decision_rule: DecisionRule,
    /// The coverage factor the file asks for; absent: each uncertainty as reported.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage: Option<f64>,
    /// Fail if any check fails, else cannot decide if any cannot be decided, else pass.
    pub verdict: Verdict,
    pub checks: Vec<Check>,
}

/// One toleranced quantity checked.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Check {
    /// What is checked: `E (ISO 230-2) X`, `G (ISO 230-4) XY`, `EC0Y`, `EXX over the stroke`.
    pub item: String,
    /// The run it was measured in, for an instrument's value.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub run: Option<String>,
    /// The measured or identified value (for a curve: at its decisive point); absent when
    /// there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    /// The expanded uncertainty `U` the rule used; absent when there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<f64>,
    pub tolerance: f64,
    pub zone: Zone,
    pub unit: String,
    pub verdict: Verdict,
    /// Why it could not be decided, where a curve's value is, or that the simple rule decided.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Checks every tolerance of `tolerances` against `evidence`.
pub fn evaluate(tolerances: &Tolerances, evidence: &Evidence) -> Acceptance {
    let judge = Judge {
        rule: tolerances.rule,
        coverage: tolerances.coverage,
    };
    let mut checks = Vec::new();
    iso230_2(tolerances, evidence, &judge, &mut checks);
    iso230_4(tolerances, evidence, &judge, &mut checks);
    for p in &tolerances.parameters {
        checks.push(parameter(p, evidence, &judge));
    }
    Acceptance {
        file: tolerances.path.display().to_string(),
        decision_rule: tolerances.rule,
        coverage: tolerances.coverage,
        verdict: rule::overall(checks.iter().map(|c| c.verdict)),
        checks,
    }
}

/// The rule and the coverage factor of a file.
struct Judge {
    rule: DecisionRule,
    coverage: Option<f64>,
}

impl Judge {
    /// `U` for an uncertainty `u95` reported at coverage `k`: as reported, or rescaled to the
    /// file's coverage factor.
    fn expanded(&self, u95: Option<f64>, k: f64) -> Option<f64> {
        let u95 = u95?;
        Some(match self.coverage {
            Some(c) if k > 0.0 => u95 / k * c,
            _ => u95,
        })
    }

    fn decide(&self, value: f64, u: Option<f64>, limit: f64, zone: Zone) -> Decision {
        rule::decide(value, u, limit, zone, self.rule)
    }

    /// The check of one measured or identified value.
    fn check(&self, item: String, value: f64, u: Option<f64>, limit: f64, zone: Zone) -> Check {
        let d = self.decide(value, u, limit, zone);
        Check {
            item,
            run: None,
            value: Some(value),
            uncertainty: u,
            tolerance: limit,
            zone,
            unit: String::new(),
            verdict: d.verdict,
            note: d.note.map(str::to_string),
        }
    }
}

/// A check with no value: it cannot be decided, for the reason `why`.
fn undecided(item: String, limit: f64, zone: Zone, unit: &str, why: String) -> Check {
    Check {
        item,
        run: None,
        value: None,
        uncertainty: None,
        tolerance: limit,
        zone,
        unit: unit.to_string(),
        verdict: Verdict::CannotDecide,
        note: Some(why),
    }
}

fn metric_check(m: &MetricEvidence, item: String, limit: f64, judge: &Judge) -> Check {
    let u = judge.expanded(m.u95, m.k);
    Check {
        run: Some(m.run.clone()),
        unit: m.unit.clone(),
        ..judge.check(item, m.value, u, limit, Zone::Upper)
    }
}

fn iso230_2(t: &Tolerances, evidence: &Evidence, judge: &Judge, out: &mut Vec<Check>) {
    for tol in &t.iso230_2 {
        let name = tol.value.metric_name();
        let item = format!("{name} {}", tol.axis);
        let found: Vec<&MetricEvidence> = evidence
            .metrics
            .iter()
            .filter(|m| m.name == name && m.subject.as_deref() == Some(tol.axis.as_str()))
            .collect();
        if found.is_empty() {
            out.push(undecided(
                item.clone(),
                tol.limit_um,
                Zone::Upper,
                "um",
                format!(
                    "no run of this session gives ISO 230-2 values along {} (a laser `linear` \
                     run moving {} alone, approaching each target at least twice from each side)",
                    tol.axis, tol.axis
                ),
            ));
        }
        for m in found {
            out.push(metric_check(m, item.clone(), tol.limit_um, judge));
        }
    }
}

fn iso230_4(t: &Tolerances, evidence: &Evidence, judge: &Judge, out: &mut Vec<Check>) {
    if t.iso230_4.is_empty() {
        return;
    }
    // A circle's own plane's tolerance, else the one for every circle.
    let tolerance_of = |plane: Option<&str>| {
        let own = t
            .iso230_4
            .iter()
            .position(|c| c.plane.is_some() && c.plane.as_deref() == plane);
        own.or_else(|| t.iso230_4.iter().position(|c| c.plane.is_none()))
    };
    let mut used = vec![false; t.iso230_4.len()];
    let circles: Vec<&MetricEvidence> = evidence
        .metrics
        .iter()
        .filter(|m| m.name == CIRCULAR_DEVIATION)
        .collect();
    for m in circles.iter().copied() {
        let Some(k) = tolerance_of(m.subject.as_deref()) else {
            continue;
        };
        used[k] = true;
        let item = match &m.subject {
            Some(plane) => format!("G (ISO 230-4) {plane}"),
            None => "G (ISO 230-4)".to_string(),
        };
        out.push(metric_check(m, item, t.iso230_4[k].limit_um, judge));
    }
    // A tolerance no circle met cannot be decided; the one for every circle only when there is
    // no circle at all (otherwise the planes' own tolerances took them all).
    for (tol, _) in t.iso230_4.iter().zip(used).filter(|(_, used)| !used) {
        let (item, where_) = match &tol.plane {
            Some(p) => (format!("G (ISO 230-4) {p}"), format!("in plane {p}")),
            None if circles.is_empty() => ("G (ISO 230-4)".to_string(), "at all".to_string()),
            None => continue,
        };
        out.push(undecided(
            item,
            tol.limit_um,
            Zone::Upper,
            "um",
            format!("no ball-bar circle of this session {where_}"),
        ));
    }
}

fn parameter(p: &ParameterTolerance, evidence: &Evidence, judge: &Judge) -> Check {
    let unit = p.unit.as_str();
    if let Some(e) = evidence.parameters.iter().find(|e| e.name == p.name) {
        return parameter_check(p, e, judge);
    }
    if let Some(c) = evidence.curves.iter().find(|c| c.name == p.name) {
        return curve_check(p, c, judge);
    }
    let why = evidence
        .undetermined
        .iter()
        .find(|u| u.names.contains(&p.name))
        .map_or_else(
            || "these runs give it no value".to_string(),
            |u| format!("not determined by these runs: {}", u.why),
        );
    undecided(p.name.clone(), p.limit, Zone::TwoSided, unit, why)
}

fn parameter_check(p: &ParameterTolerance, e: &ParameterEvidence, judge: &Judge) -> Check {
    if e.unit != p.unit.as_str() {
        return undecided(
            p.name.clone(),
            p.limit,
            Zone::TwoSided,
            p.unit.as_str(),
            format!(
                "its value is in {}, its tolerance in {}",
                e.unit,
                p.unit.as_str()
            ),
        );
    }
    let u = judge.expanded(Some(e.u95), e.k);
    Check {
        unit: e.unit.clone(),
        ..judge.check(p.name.clone(), e.value, u, p.limit, Zone::TwoSided)
    }
}

/// A component error against `|E(q)| ≤ T` at every sampled position: it fails if one point
/// proves non-conformance, passes if every point proves conformance, else cannot be decided.
/// The check shows the decisive point: the one furthest beyond the zone when it fails, else
/// the one closest to failing (largest `|E| + U`).
fn curve_check(p: &ParameterTolerance, c: &CurveEvidence, judge: &Judge) -> Check {
    let item = format!("{} over the stroke", p.name);
    if c.unit != p.unit.as_str() || c.samples.is_empty() {
        return undecided(
            item,
            p.limit,
            Zone::TwoSided,
            p.unit.as_str(),
            format!(
                "its curve is in {}, its tolerance in {}",
                c.unit,
                p.unit.as_str()
            ),
        );
    }
    let points: Vec<([f64; 3], Option<f64>, Decision)> = c
        .samples
        .iter()
        .map(|s| {
            let u = judge.expanded(Some(s[2]), c.k);
            (*s, u, judge.decide(s[1], u, p.limit, Zone::TwoSided))
        })
        .collect();
    let verdict = rule::overall(points.iter().map(|(_, _, d)| d.verdict));
    let guard = |u: Option<f64>| match judge.rule {
        DecisionRule::Iso14253_1 => u.unwrap_or(0.0),
        DecisionRule::Simple => 0.0,
    };
    let key = |(s, u, _): &([f64; 3], Option<f64>, Decision)| match verdict {
        Verdict::Fail => s[1].abs() - guard(*u),
        _ => s[1].abs() + guard(*u),
    };
    let decisive = points
        .iter()
        .max_by(|a, b| key(a).total_cmp(&key(b)))
        .expect("a curve has samples");
    let (s, u, _) = decisive;
    Check {
        item,
        run: None,
        value: Some(s[1]),
        uncertainty: *u,
        tolerance: p.limit,
        zone: Zone::TwoSided,
        unit: c.unit.clone(),
        verdict,
        note: Some(format!(
            "decided at {} {} ({} points over the stroke)",
            trim(s[0], 1),
            c.position_unit,
            c.samples.len()
        )),
    }
}

/// `x` with at most `decimals` decimals, without trailing zeros.
fn trim(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}

impl Acceptance {
    /// The block `mtcal identify` prints after the parameters: one line per check (value ± U
    /// against the tolerance, the verdict and why) and the overall verdict.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "\nacceptance against {} ({}):",
            self.file,
            self.rule_text()
        );
        for c in &self.checks {
            let _ = writeln!(s, "  {}", c.line());
        }
        let count = |v: Verdict| self.checks.iter().filter(|c| c.verdict == v).count();
        let _ = writeln!(
            s,
            "overall: {} ({} pass, {} fail, {} cannot decide)",
            self.verdict.as_str().to_uppercase(),
            count(Verdict::Pass),
            count(Verdict::Fail),
            count(Verdict::CannotDecide)
        );
        s
    }
}

impl Acceptance {
    /// The decision rule and the coverage in words.
    pub fn rule_text(&self) -> String {
        match (self.decision_rule, self.coverage) {
            (DecisionRule::Simple, _) => {
                "simple acceptance: the tolerance itself decides, U is shown only".to_string()
            }
            (DecisionRule::Iso14253_1, k) => format!(
                "ISO 14253-1: pass only inside the tolerance by U, fail only beyond it by U; {}",
                match k {
                    Some(k) => format!("U = {} u", trim(k, 3)),
                    None => "U as reported (parameters k = 1.96, instruments k = 2)".into(),
                }
            ),
        }
    }
}

impl Check {
    /// `E (ISO 230-2) X [laser-x]   8.639 ± 1.020 um   ≤ 12 um   pass`.
    pub fn line(&self) -> String {
        let label = match &self.run {
            Some(run) => format!("{} [{run}]", self.item),
            None => self.item.clone(),
        };
        let value = match (self.value, self.uncertainty) {
            (Some(v), Some(u)) => format!("{v:.3} ± {u:.3} {}", self.unit),
            (Some(v), None) => format!("{v:.3} {}", self.unit),
            (None, _) => "no value".to_string(),
        };
        let note = self
            .note
            .as_ref()
            .map_or(String::new(), |n| format!(": {n}"));
        format!(
            "{label:<34} {value:<24} {:<18} {}{note}",
            self.tolerance_text(),
            self.verdict.as_str()
        )
    }

    /// `≤ 12 um` or `|·| ≤ 20 urad`.
    pub fn tolerance_text(&self) -> String {
        format!("{} {}", self.zone_text(), self.unit)
    }

    /// The zone without its unit: `≤ 12` or `|·| ≤ 20`.
    pub fn zone_text(&self) -> String {
        let bound = format!("≤ {}", trim(self.tolerance, 4));
        match self.zone {
            Zone::Upper => bound,
            Zone::TwoSided => format!("|·| {bound}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::trim;

    #[test]
    fn numbers_lose_their_trailing_zeros() {
        assert_eq!(trim(12.0, 4), "12");
        assert_eq!(trim(12.5, 4), "12.5");
        assert_eq!(trim(-0.00001, 1), "0");
        assert_eq!(trim(300.04, 1), "300");
    }
}
