//! What the evaluation says: the screen ([`Evaluation::summary`]) and the JSON
//! ([`Evaluation::to_json`], schema [`SCHEMA`], docs/VOLUMETRIC.md).

use std::fmt::Write as _;

use serde::Serialize;

use crate::Evaluation;
use crate::stats::AxisSpread;
use crate::verdict::Verdict;

/// The JSON's schema name.
pub const SCHEMA: &str = "mtcal.volumetric/1";

const AXES: [char; 3] = ['X', 'Y', 'Z'];
const WIDTH: usize = 100;

impl Evaluation {
    /// The screen: the verdict first, then the table at its instant, then how it was found.
    pub fn summary(&self) -> String {
        let h = &self.homogeneity;
        let mut s = String::new();
        let headline = match h.verdict {
            Verdict::Uniform => "UNIFORM — ISO 230-3's single-point assumption holds here",
            Verdict::NotUniform => {
                "NOT UNIFORM — ISO 230-3's single-point assumption does not hold here"
            }
            Verdict::CannotDecide => "CANNOT DECIDE whether the deformation is uniform",
        };
        let _ = writeln!(s, "{headline}");
        s.push_str(&wrap(&h.sentence, WIDTH, ""));
        let k = h.instant;
        let _ = writeln!(
            s,
            "\nat {:.2} h (cycle {}): |mean| {:.2} µm [95 %: {:.2}–{:.2}], tolerance {:.0} % of it",
            h.t_s / 3600.0,
            k + 1,
            h.mean_magnitude_um,
            h.mean_magnitude_interval_um[0],
            h.mean_magnitude_interval_um[1],
            100.0 * h.tolerance_share
        );
        let _ = writeln!(
            s,
            "axis      mean µm   max−min µm [95 %]     floor   share [95 %]        std µm [95 %]        verdict"
        );
        for a in &h.axes {
            let _ = writeln!(s, "{}", axis_row(a.axis, &a.spread, a.verdict));
        }
        let _ = writeln!(s);
        let points = self.visits.points.len();
        let visits: usize = self.visits.points.iter().map(|p| p.visits.len()).sum();
        let _ = writeln!(
            s,
            "session    {} (machine {}, {points} points, {visits} visits)",
            self.visits.session.display(),
            self.visits.machine
        );
        s.push_str(&wrap(&self.cycles.describe(points), WIDTH, "cycles     "));
        s.push_str(&wrap(&self.time_base.why, WIDTH, "time base  "));
        s.push_str(&wrap(&self.noise.how(), WIDTH, "noise      "));
        s.push_str(&wrap(&self.phases_line(), WIDTH, "phases     "));
        for note in &self.notes {
            s.push_str(&wrap(note, WIDTH, "note       "));
        }
        s
    }

    fn phases_line(&self) -> String {
        let parts: Vec<String> = self
            .snapshots
            .iter()
            .map(|snap| {
                let (name, size) = snap
                    .points
                    .iter()
                    .map(|p| (p.name.as_str(), norm(p.deformation_um)))
                    .max_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap_or(("", 0.0));
                format!(
                    "{:.2} h (cycle {}): largest {name} {size:.1} µm",
                    snap.t_s / 3600.0,
                    snap.instant + 1
                )
            })
            .collect();
        parts.join("; ")
    }

    /// The JSON (`mtcal.volumetric/1`): every number of the evaluation.
    pub fn to_json(&self) -> String {
        let json = Json::from(self);
        let mut text = serde_json::to_string_pretty(&json).expect("plain data serialises");
        text.push('\n');
        text
    }
}

fn norm(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn axis_row(axis: char, a: &AxisSpread, verdict: Verdict) -> String {
    let pct = |x: f64| format!("{:.0}", 100.0 * x);
    let share = match (a.range_share, a.range_share_interval) {
        (Some(v), Some([lo, hi])) => format!("{} % [{}–{}]", pct(v), pct(lo), pct(hi)),
        _ => "—".into(),
    };
    let range = format!(
        "{:.2} [{:.2}–{:.2}]",
        a.range_um, a.range_interval_um[0], a.range_interval_um[1]
    );
    let std = format!(
        "{:.2} [{:.2}–{:.2}]",
        a.std_um, a.std_interval_um[0], a.std_interval_um[1]
    );
    format!(
        "{axis}    {:>9.2}   {range:<20} {:>6.2}   {share:<18}  {std:<20} {}",
        a.mean_um,
        a.range_floor_um,
        verdict.as_str()
    )
}

/// `text` broken into lines of at most `width` characters, the first after `lead`, the others
/// indented as deep.
fn wrap(text: &str, width: usize, lead: &str) -> String {
    let indent = " ".repeat(lead.chars().count());
    let mut out = String::new();
    let mut line = lead.to_string();
    let mut empty = true;
    for word in text.split_whitespace() {
        let len = line.chars().count() + word.chars().count() + usize::from(!empty);
        if !empty && len > width {
            out.push_str(line.trim_end());
            out.push('\n');
            line = indent.clone();
            empty = true;
        }
        if !empty {
            line.push(' ');
        }
        line.push_str(word);
        empty = false;
    }
    out.push_str(line.trim_end());
    out.push('\n');
    out
}

// ---------------------------------------------------------------------------------------------
// The JSON

#[derive(Serialize)]
struct Json<'a> {
    schema: &'static str,
    session: String,
    machine: &'a str,
    verdict: JsonVerdict<'a>,
    noise: JsonNoise,
    cycles: JsonCycles,
    time_base: JsonTimeBase<'a>,
    points: Vec<JsonPoint<'a>>,
    instants: Vec<JsonInstant>,
    phases: Vec<JsonPhase<'a>>,
    notes: &'a [String],
}

#[derive(Serialize)]
struct JsonVerdict<'a> {
    overall: &'static str,
    sentence: &'a str,
    tolerance_share: f64,
    cycle: usize,
    t_s: f64,
    mean_um: [f64; 3],
    mean_magnitude_um: f64,
    mean_magnitude_interval_um: [f64; 2],
    deciding_axis: String,
    axes: Vec<JsonAxisVerdict<'a>>,
}

#[derive(Serialize)]
struct JsonAxisVerdict<'a> {
    axis: String,
    verdict: &'static str,
    why: &'a str,
    #[serde(flatten)]
    spread: JsonSpread,
    follows_visit_order_um: Option<f64>,
}

#[derive(Serialize)]
struct JsonSpread {
    mean_um: f64,
    mean_u95_um: f64,
    range_um: f64,
    range_interval_um: [f64; 2],
    range_floor_um: f64,
    range_share: Option<f64>,
    range_share_interval: Option<[f64; 2]>,
    std_um: f64,
    std_interval_um: [f64; 2],
    std_floor_um: f64,
    std_share: Option<f64>,
    std_share_interval: Option<[f64; 2]>,
}

impl From<&AxisSpread> for JsonSpread {
    fn from(a: &AxisSpread) -> Self {
        JsonSpread {
            mean_um: a.mean_um,
            mean_u95_um: a.mean_u95_um,
            range_um: a.range_um,
            range_interval_um: a.range_interval_um,
            range_floor_um: a.range_floor_um,
            range_share: a.range_share,
            range_share_interval: a.range_share_interval,
            std_um: a.std_um,
            std_interval_um: a.std_interval_um,
            std_floor_um: a.std_floor_um,
            std_share: a.std_share,
            std_share_interval: a.std_share_interval,
        }
    }
}

#[derive(Serialize)]
struct JsonNoise {
    sigma_um: [f64; 3],
    phi: f64,
    phi_estimated: bool,
    residuals_per_axis: usize,
    cycles_used: usize,
    stated_sigma_um: Option<[f64; 2]>,
    how: String,
}

#[derive(Serialize)]
struct JsonCycles {
    count: usize,
    complete: usize,
    incomplete: Vec<JsonIncomplete>,
    cut_by_return: usize,
    cut_by_pause: usize,
    median_pause_s: f64,
    span_s: f64,
    between_s: Option<f64>,
    phases_between: bool,
    found: String,
}

#[derive(Serialize)]
struct JsonIncomplete {
    cycle: usize,
    missing: Vec<String>,
}

#[derive(Serialize)]
struct JsonTimeBase<'a> {
    method: &'static str,
    why: &'a str,
}

#[derive(Serialize)]
struct JsonPoint<'a> {
    name: &'a str,
    setup: &'a str,
    rotary_deg: Vec<(String, f64)>,
    position_mm: [f64; 3],
    visits: Vec<JsonVisit<'a>>,
}

#[derive(Serialize)]
struct JsonVisit<'a> {
    t_s: f64,
    cycle: usize,
    run: &'a str,
    reading_um: [f64; 3],
    deformation_um: [f64; 3],
    u95_um: [f64; 3],
}

#[derive(Serialize)]
struct JsonInstant {
    cycle: usize,
    t_s: f64,
    complete: bool,
    mean_magnitude_um: f64,
    mean_magnitude_interval_um: [f64; 2],
    axes: Vec<JsonAxis>,
    /// `[point][axis]`, the points' order.
    deformation_um: Vec<[f64; 3]>,
    u95_um: Vec<[f64; 3]>,
}

#[derive(Serialize)]
struct JsonAxis {
    axis: String,
    #[serde(flatten)]
    spread: JsonSpread,
}

#[derive(Serialize)]
struct JsonPhase<'a> {
    requested_h: Option<f64>,
    cycle: usize,
    t_s: f64,
    points: Vec<JsonPhasePoint<'a>>,
}

#[derive(Serialize)]
struct JsonPhasePoint<'a> {
    name: &'a str,
    position_mm: [f64; 3],
    deformation_um: [f64; 3],
    u95_um: [f64; 3],
}

impl<'a> From<&'a Evaluation> for Json<'a> {
    fn from(e: &'a Evaluation) -> Self {
        let h = &e.homogeneity;
        Json {
            schema: SCHEMA,
            session: e.visits.session.display().to_string(),
            machine: &e.visits.machine,
            verdict: JsonVerdict {
                overall: h.verdict.key(),
                sentence: &h.sentence,
                tolerance_share: h.tolerance_share,
                cycle: h.instant + 1,
                t_s: h.t_s,
                mean_um: h.mean_um,
                mean_magnitude_um: h.mean_magnitude_um,
                mean_magnitude_interval_um: h.mean_magnitude_interval_um,
                deciding_axis: h.deciding_axis.to_string(),
                axes: h
                    .axes
                    .iter()
                    .map(|a| JsonAxisVerdict {
                        axis: a.axis.to_string(),
                        verdict: a.verdict.key(),
                        why: &a.why,
                        spread: JsonSpread::from(&a.spread),
                        follows_visit_order_um: a.follows_visit_order_um,
                    })
                    .collect(),
            },
            noise: JsonNoise {
                sigma_um: e.noise.sigma_um,
                phi: e.noise.phi,
                phi_estimated: e.noise.phi_estimated,
                residuals_per_axis: e.noise.residuals,
                cycles_used: e.noise.cycles_used,
                stated_sigma_um: e.noise.stated_sigma_um.map(|(a, b)| [a, b]),
                how: e.noise.how(),
            },
            cycles: cycles_json(e),
            time_base: JsonTimeBase {
                method: e.time_base.method.as_str(),
                why: &e.time_base.why,
            },
            points: points_json(e),
            instants: instants_json(e),
            phases: phases_json(e),
            notes: &e.notes,
        }
    }
}

fn cycles_json(e: &Evaluation) -> JsonCycles {
    let c = &e.cycles;
    JsonCycles {
        count: c.len(),
        complete: c.complete_count(),
        incomplete: c
            .incomplete
            .iter()
            .map(|i| JsonIncomplete {
                cycle: i.cycle,
                missing: i.missing.clone(),
            })
            .collect(),
        cut_by_return: c.cut.by_return,
        cut_by_pause: c.cut.by_pause,
        median_pause_s: c.median_pause_s,
        span_s: c.span_s,
        between_s: c.between_s,
        phases_between: c.phases_between,
        found: c.describe(e.visits.points.len()),
    }
}

fn points_json(e: &Evaluation) -> Vec<JsonPoint<'_>> {
    e.visits
        .points
        .iter()
        .zip(&e.series)
        .map(|(p, s)| JsonPoint {
            name: &p.name,
            setup: &p.setup,
            rotary_deg: p
                .rotary_deg
                .iter()
                .map(|(a, d)| (a.to_string(), *d))
                .collect(),
            position_mm: p.position_mm,
            visits: p
                .visits
                .iter()
                .zip(&s.values)
                .map(|(v, d)| JsonVisit {
                    t_s: v.t_s,
                    cycle: d.cycle + 1,
                    run: &v.run,
                    reading_um: v.reading_um,
                    deformation_um: d.deformation_um,
                    u95_um: d.u95_um,
                })
                .collect(),
        })
        .collect()
}

fn instants_json(e: &Evaluation) -> Vec<JsonInstant> {
    e.instants
        .iter()
        .map(|i| JsonInstant {
            cycle: i.cycle + 1,
            t_s: i.t_s,
            complete: i.complete,
            mean_magnitude_um: i.mean_magnitude_um,
            mean_magnitude_interval_um: i.mean_magnitude_interval_um,
            axes: i
                .axes
                .iter()
                .zip(AXES)
                .map(|(a, axis)| JsonAxis {
                    axis: axis.to_string(),
                    spread: JsonSpread::from(a),
                })
                .collect(),
            deformation_um: i.points_um.clone(),
            u95_um: i.points_u95_um.clone(),
        })
        .collect()
}

fn phases_json(e: &Evaluation) -> Vec<JsonPhase<'_>> {
    e.snapshots
        .iter()
        .map(|s| JsonPhase {
            requested_h: s.requested_h,
            cycle: s.instant + 1,
            t_s: s.t_s,
            points: s
                .points
                .iter()
                .map(|p| JsonPhasePoint {
                    name: &p.name,
                    position_mm: p.position_mm,
                    deformation_um: p.deformation_um,
                    u95_um: p.u95_um,
                })
                .collect(),
        })
        .collect()
}
