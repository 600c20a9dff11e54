//! The HTML page: head with style and the error recorder, contents, the sections of the crate
//! documentation in order, the closing script.

use crate::escape::{display_unit, escape, num, with_interval};
use crate::plots::{self, BEFORE, MEASURED, MODEL};
use crate::{DiagnosisTable, Estimate, PolarRun, Report, ReportError};
use mtcal_instrument::capability::{PolarSection, declared};
use std::fmt::Write as _;

/// Section ids and headings, in page order; the polar views' section, the plugin's, comes after
/// the summary ([`polar_section`]).
pub(crate) const SECTIONS: [(&str, &str); 7] = [
    ("summary", "Summary"),
    ("residuals", "Residuals along the context"),
    ("components", "Component errors"),
    ("volumetric", "Volumetric error map"),
    ("parameters", "Parameters"),
    ("identifiability", "What the data cannot separate"),
    ("discoveries", "Discoveries"),
];

pub(crate) const STYLE: &str = "
body{font:15px/1.45 system-ui,-apple-system,'Segoe UI',sans-serif;color:#222;margin:0;background:#fafafa}
header,main,nav{max-width:1100px;margin:0 auto;padding:0 20px}
header{padding-top:18px}h1{font-size:26px;margin:0 0 4px}h2{border-bottom:2px solid #1F77B4;padding-bottom:3px;margin-top:34px}
nav{position:sticky;top:0;background:#fafafa;border-bottom:1px solid #ddd;padding-top:6px;padding-bottom:6px;z-index:1}
nav a{margin-right:14px;color:#1F77B4;text-decoration:none;white-space:nowrap}
.plots{display:flex;flex-wrap:wrap;gap:14px}
figure.plot{margin:0;background:#fff;border:1px solid #ddd;border-radius:4px;padding:6px;max-width:100%;box-sizing:border-box}
figure.plot svg{display:block;width:100%;height:auto}
figcaption{font-size:13px;color:#444;padding:4px 2px}
table{border-collapse:collapse;background:#fff}td,th{border:1px solid #ddd;padding:3px 8px;text-align:left}
td.n{text-align:right;font-variant-numeric:tabular-nums}td.nid{font-style:italic;color:#a33}
.key{display:inline-block;width:22px;height:4px;vertical-align:middle;margin:0 4px 0 10px}
.none{color:#666;font-style:italic}.discovery{background:#fff;border-left:4px solid #1F77B4;padding:6px 12px;margin:10px 0}
.discovery h3{margin:4px 0}.numbers{color:#444;font-size:14px}
#script-errors{background:#fdd;color:#800;white-space:pre-wrap;padding:8px;margin:0}
";

/// Records every script error into `#script-errors` (or a queue until the body exists).
pub(crate) const ERROR_RECORDER: &str = "
window.__reportErrors = [];
window.onerror = function (message, source, line) {
  var text = String(message) + (line ? ' (line ' + line + ')' : '');
  var box = document.getElementById('script-errors');
  if (box) { box.hidden = false; box.textContent += text + '\\n'; }
  else { window.__reportErrors.push(text); }
  return false;
};
";

/// Flushes queued errors, counts each section's plots into the contents, marks the page ready.
pub(crate) const READY: &str = "
(function () {
  var box = document.getElementById('script-errors');
  for (var i = 0; i < window.__reportErrors.length; i++) {
    box.hidden = false; box.textContent += window.__reportErrors[i] + '\\n';
  }
  var links = document.querySelectorAll('nav a');
  for (var k = 0; k < links.length; k++) {
    var section = document.getElementById(links[k].getAttribute('href').slice(1));
    var n = section ? section.querySelectorAll('figure.plot svg').length : 0;
    if (n > 0) { links[k].textContent += ' (' + n + ')'; }
  }
  document.body.setAttribute('data-plots', String(document.querySelectorAll('figure.plot svg').length));
  document.body.setAttribute('data-report-ready', 'yes');
})();
";

/// The acceptance section's id and heading; on the page after the summary, only when the
/// report has one.
pub(crate) const ACCEPTANCE: (&str, &str) = ("acceptance", "Acceptance");

/// The location errors' section; on the page after the component errors, only when the
/// report has series.
pub(crate) const SERIES: (&str, &str) = ("series", "Location errors cycle by cycle");

pub(crate) fn page(r: &Report) -> Result<String, ReportError> {
    let polar = polar_sections(r)?;
    let bodies = [
        summary(r),
        residuals(r)?,
        components(r)?,
        volumetric(r)?,
        parameters(r),
        identifiability(r),
        discoveries(r),
    ];
    let mut h = String::with_capacity(1 << 20);
    head(&mut h, &r.title);
    let _ = write!(
        h,
        "<p>session <code>{}</code> · machine {}</p></header>\n<nav>",
        escape(&r.summary.session),
        escape(&r.summary.machine),
    );
    let mut sections: Vec<Section<'_>> = SECTIONS.into_iter().zip(bodies).collect();
    for (k, section) in polar.into_iter().enumerate() {
        sections.insert(1 + k, section);
    }
    if !r.location_series.is_empty() {
        let at = sections
            .iter()
            .position(|((id, _), _)| *id == "components")
            .map_or(sections.len(), |k| k + 1);
        sections.insert(at, (SERIES, location_series(r)?));
    }
    if let Some(a) = &r.acceptance {
        sections.insert(1, (ACCEPTANCE, acceptance(a)));
    }
    for ((id, heading), _) in &sections {
        let _ = write!(h, "<a href=\"#{id}\">{heading}</a>");
    }
    h.push_str("</nav>\n<main>\n");
    for ((id, heading), body) in sections {
        let _ = write!(
            h,
            "<section id=\"{id}\">\n<h2>{heading}</h2>\n{body}</section>\n"
        );
    }
    let _ = write!(h, "</main>\n<script>{READY}</script>\n</body>\n</html>\n");
    Ok(h)
}

/// `<figure class="plot">` around an SVG, as wide as the SVG says (at most the page's width),
/// so its caption wraps under the plot.
pub(crate) fn figure(kind: &str, name: &str, svg: &str, caption: &str) -> String {
    let width = svg
        .split("width=\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .and_then(|w| w.parse::<u32>().ok())
        .map_or(String::new(), |w| format!(" style=\"width:{}px\"", w + 14));
    format!(
        "<figure class=\"plot\" data-plot=\"{kind}\" data-name=\"{}\"{width}>\n{svg}<figcaption>{caption}</figcaption></figure>\n",
        escape(name)
    )
}

fn key(color: plotters::style::RGBColor, label: &str) -> String {
    format!(
        "<span class=\"key\" style=\"background:#{:02X}{:02X}{:02X}\"></span>{label}",
        color.0, color.1, color.2
    )
}

pub(crate) fn none(text: &str) -> String {
    format!("<p class=\"none\">{}</p>\n", escape(text))
}

fn summary(r: &Report) -> String {
    let s = &r.summary;
    let mut h = String::from("<ul>\n");
    for f in &s.facts {
        let _ = writeln!(h, "<li>{}</li>", escape(f));
    }
    h.push_str("</ul>\n");
    if s.runs.is_empty() {
        return h;
    }
    let before = s.runs.iter().any(|r| r.rms_before_um.is_some());
    h.push_str("<table id=\"runs\">\n<tr><th>run</th><th>instrument</th><th>use</th>");
    if before {
        h.push_str("<th>RMS before the search (µm)</th><th>RMS after (µm)</th>");
    } else {
        h.push_str("<th>RMS (µm)</th>");
    }
    h.push_str("</tr>\n");
    for run in s.runs.iter() {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td>",
            escape(&run.name),
            escape(&run.instrument),
            escape(&run.role)
        );
        if before {
            let b = run.rms_before_um.map_or(String::new(), |v| num(v, 3));
            let _ = write!(h, "<td class=\"n\">{b}</td>");
        }
        let _ = writeln!(h, "<td class=\"n\">{}</td></tr>", num(run.rms_um, 3));
    }
    h.push_str("</table>\n");
    h
}

fn acceptance(a: &crate::AcceptanceSection) -> String {
    let mut h = format!(
        "<p>Against <code>{}</code> ({}): <b class=\"verdict\" data-verdict=\"{}\" \
         style=\"color:{}\">{}</b>.</p>\n",
        escape(&a.file),
        escape(&a.rule),
        escape(&a.verdict),
        verdict_colour(&a.verdict),
        escape(&a.verdict.to_uppercase())
    );
    if a.rows.is_empty() {
        return h;
    }
    h.push_str(
        "<table id=\"acceptance-table\">\n<tr><th>checked</th><th>run</th><th>value</th>\
         <th>± U</th><th>tolerance</th><th>verdict</th><th>why</th></tr>\n",
    );
    for row in &a.rows {
        let value = match (row.value, row.uncertainty) {
            (Some(v), Some(u)) => {
                let (v, u) = with_interval(v, u);
                format!("<td class=\"n\">{v}</td><td class=\"n\">{u}</td>")
            }
            (Some(v), None) => format!("<td class=\"n\">{}</td><td></td>", num(v, 3)),
            (None, _) => "<td class=\"nid\" colspan=\"2\">no value</td>".to_string(),
        };
        let _ = writeln!(
            h,
            "<tr data-verdict=\"{verdict}\"><td>{}</td><td>{}</td>{value}<td>{} {}</td>\
             <td class=\"verdict\" style=\"color:{}\">{verdict}</td><td>{}</td></tr>",
            escape(&row.item),
            escape(&row.run),
            escape(&row.tolerance),
            escape(display_unit(&row.unit)),
            verdict_colour(&row.verdict),
            escape(&row.note),
            verdict = escape(&row.verdict),
        );
    }
    h.push_str("</table>\n");
    h
}

/// Green for a pass, red for a fail, amber for what cannot be decided.
fn verdict_colour(verdict: &str) -> &'static str {
    match verdict {
        "pass" => "#1a7f37",
        "fail" => "#b00020",
        _ => "#9a6700",
    }
}

/// A section of the page: its id and heading, its body.
type Section<'a> = ((&'a str, &'a str), String);

/// A section per instrument whose runs are drawn on circles, id and heading as its plugin
/// declares them ([`PolarSection`], in the order of their names), each with that instrument's
/// runs and diagnostics; none when no linked plugin declares one.
fn polar_sections(r: &Report) -> Result<Vec<Section<'static>>, ReportError> {
    declared::<PolarSection>()
        .into_iter()
        .map(|section| {
            let runs: Vec<&PolarRun> = r
                .polar
                .iter()
                .filter(|p| p.instrument == section.instrument)
                .collect();
            let diagnostics = r
                .diagnostics
                .iter()
                .filter(|d| d.instrument == section.instrument);
            let body = polar_views(&runs, diagnostics, section.none)?;
            Ok(((section.instrument, section.heading), body))
        })
        .collect()
}

/// Every polar view's plot (`none` when there is none) and the diagnostics under them.
fn polar_views<'a>(
    runs: &[&PolarRun],
    diagnostics: impl Iterator<Item = &'a DiagnosisTable>,
    none_text: &str,
) -> Result<String, ReportError> {
    if runs.is_empty() {
        return Ok(none(none_text));
    }
    let with_before = runs.iter().any(|b| b.model_before_um.is_some());
    let mut h = format!(
        "<p>The bar-length deviation <i>dr</i> around each circle, magnified about a reference \
         circle: the thick grey ring is <i>dr</i> = 0, the thin rings the scale written on \
         them. {}{}{}</p>\n<div class=\"plots\">\n",
        key(MEASURED, "measured"),
        if with_before {
            key(BEFORE, "model before the physics search")
        } else {
            String::new()
        },
        key(MODEL, "identified model"),
    );
    for run in runs {
        let svg = plots::polar(run)?;
        let mut caption = format!(
            "<b>{}</b> — plane {}, bar {} mm, {} samples",
            escape(&run.name),
            escape(&run.plane),
            num(run.radius_mm, 1),
            run.angles_deg.len()
        );
        for (name, value, unit) in &run.metrics {
            let _ = write!(
                caption,
                "; {} {} {}",
                escape(name),
                num(*value, 3),
                escape(display_unit(unit))
            );
        }
        h.push_str(&figure("polar", &run.name, &svg, &caption));
    }
    h.push_str("</div>\n");
    for (k, d) in diagnostics.enumerate() {
        h.push_str(&diagnosis(k, d));
    }
    Ok(h)
}

/// A circle pair's diagnostics as the shop reads them: ranked by their contribution to
/// circularity, each with what the identified model says of it; the values within the noise
/// greyed and unranked.
fn diagnosis(k: usize, d: &crate::DiagnosisTable) -> String {
    let mut h = format!(
        "<h3>Diagnostics — {} (circularity {} µm)</h3>\n<table class=\"diagnostics\" \
         id=\"diagnostics-{k}\">\n<tr><th>rank</th><th>diagnostic</th><th>value</th><th>± U</th>\
         <th>unit</th><th>of circularity</th><th>model</th><th>behind it</th></tr>\n",
        escape(&d.title),
        num(d.circularity_um, 2)
    );
    for row in &d.rows {
        let (v, u) = with_interval(row.value, row.u95);
        let rank = row.rank.map_or("–".to_string(), |r| r.to_string());
        let style = if row.rank.is_some() {
            ""
        } else {
            " style=\"color:#777\""
        };
        let behind = if row.behind.is_empty() {
            "not in the model".to_string()
        } else {
            escape(&row.behind)
        };
        let _ = writeln!(
            h,
            "<tr data-determined=\"{}\"{style} title=\"{}\"><td class=\"n\">{rank}</td><td>{}</td>\
             <td class=\"n\">{v}</td><td class=\"n\">{u}</td><td>{}</td><td class=\"n\">{} %</td>\
             <td class=\"n\">{}</td><td>{behind}</td></tr>",
            row.rank.is_some(),
            escape(&row.about),
            escape(&row.name),
            escape(display_unit(&row.unit)),
            num(100.0 * row.share_of_circularity, 0),
            num(row.model, 2),
        );
    }
    h.push_str("</table>\n");
    for note in &d.notes {
        let _ = writeln!(h, "<p class=\"none\">not evaluated: {}</p>", escape(note));
    }
    h
}

fn residuals(r: &Report) -> Result<String, ReportError> {
    if r.residuals.is_empty() {
        return Ok(none(
            "No run with readings: nothing to compare the model with.",
        ));
    }
    let mut h = String::from(
        "<p>Reading − model for every channel of every run with readings (fitted and \
         validation runs), against each variable the runs recorded. Structure left of the \
         model — a trend in time, a step with temperature — shows as a pattern; after a \
         successful search only noise should remain.</p>\n<div class=\"plots\">\n",
    );
    for p in &r.residuals {
        let svg = plots::residuals(p)?;
        let n = p.after.len();
        let k = plots::stride(n);
        let mut caption = format!(
            "<b>along {}</b>{}: {n} residuals",
            escape(&p.variable),
            if p.description.is_empty() {
                String::new()
            } else {
                format!(" ({})", escape(&p.description))
            }
        );
        if k > 1 {
            let _ = write!(caption, ", one in {k} drawn");
        }
        h.push_str(&figure("residuals", &p.variable, &svg, &caption));
    }
    h.push_str("</div>\n");
    Ok(h)
}

fn components(r: &Report) -> Result<String, ReportError> {
    if r.components.is_empty() {
        return Ok(none(
            "No component error with a curve was estimated in this session (only location, \
             squareness or set-up parameters, or components the data cannot separate).",
        ));
    }
    let mut h = format!(
        "<p>Each estimated component error along its axis: {} and its 95 % band (shaded).</p>\n\
         <div class=\"plots\">\n",
        key(MODEL, "identified value")
    );
    for c in &r.components {
        let svg = plots::component(c)?;
        let widest = c.samples.iter().map(|p| p.u95.abs()).fold(0.0, f64::max);
        let caption = format!(
            "<b>{}</b> — {} samples; widest 95 % half-width {} {}",
            escape(&c.name),
            c.samples.len(),
            num(widest, 3),
            escape(display_unit(&c.value_unit))
        );
        h.push_str(&figure("component", &c.name, &svg, &caption));
    }
    h.push_str("</div>\n");
    Ok(h)
}

fn location_series(r: &Report) -> Result<String, ReportError> {
    let mut h = format!(
        "<p>Each location error's change from the fit's constant, cycle by cycle: each cycle's \
         own value from its readings alone (dots, hollow for a withheld cycle) with its 95 % \
         interval (bars), and {} (line).</p>\n<div class=\"plots\">\n",
        key(MODEL, "the model's change")
    );
    for p in &r.location_series {
        let svg = plots::location_series(p)?;
        h.push_str(&figure("series", &p.name, &svg, &escape(&p.caption)));
    }
    h.push_str("</div>\n");
    Ok(h)
}

fn volumetric(r: &Report) -> Result<String, ReportError> {
    let v = &r.volumetric;
    if v.slices.is_empty() {
        return Ok(none(
            "No volumetric map: the machine has fewer than two linear axes.",
        ));
    }
    let largest = v
        .slices
        .iter()
        .flat_map(|s| s.values_um.iter())
        .filter(|x| x.is_finite())
        .fold(0.0f64, |m, &x| m.max(x));
    let vmax = plots::nice_ceil(largest.max(1e-6));
    let mut h = format!(
        "<p>{} All slices share one colour scale, 0 … {} µm.</p>\n<div class=\"plots\">\n",
        escape(&v.note),
        plots::tick(&vmax)
    );
    for s in &v.slices {
        let svg = plots::map_slice(s, vmax)?;
        let max = s
            .values_um
            .iter()
            .filter(|x| x.is_finite())
            .fold(0.0f64, |m, &x| m.max(x));
        let caption = format!(
            "<b>{}</b> — {} × {} points, largest |Δ| {} µm",
            escape(&s.title),
            s.xs.len(),
            s.ys.len(),
            num(max, 2)
        );
        h.push_str(&figure("map", &s.title, &svg, &caption));
    }
    h.push_str("</div>\n");
    Ok(h)
}

fn parameters(r: &Report) -> String {
    if r.parameters.is_empty() {
        return none("No parameter was estimated.");
    }
    let mut h = String::from(
        "<p>Values with 95 % intervals. A parameter the data cannot separate from others has no \
         value: see the next section for what it moves with.</p>\n<table id=\"parameter-table\">\n\
         <tr><th>parameter</th><th>group</th><th>value</th><th>± 95 %</th><th>unit</th></tr>\n",
    );
    for p in &r.parameters {
        let cells = match p.estimate {
            Estimate::Value { value, u95 } => {
                let (v, u) = with_interval(value, u95);
                format!("<td class=\"n\">{v}</td><td class=\"n\">{u}</td>")
            }
            Estimate::NotIdentifiable => {
                "<td class=\"nid\" colspan=\"2\">not identifiable</td>".to_string()
            }
        };
        let _ = writeln!(
            h,
            "<tr data-param=\"{name}\"><td>{name}</td><td>{}</td>{cells}<td>{}</td></tr>",
            escape(&p.group),
            escape(display_unit(&p.unit)),
            name = escape(&p.name),
        );
    }
    h.push_str("</table>\n");
    h.push_str(&conventions(&r.conventions));
    h
}

/// The convention card under the parameter table: what the numbers mean.
fn conventions(rows: &[(String, String)]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut h = String::from("<h3>What the numbers mean</h3>\n<table id=\"conventions\">\n");
    for (key, value) in rows {
        let _ = writeln!(
            h,
            "<tr><th>{}</th><td>{}</td></tr>",
            escape(key),
            escape(value)
        );
    }
    h.push_str("</table>\n");
    h
}

fn list(names: &[String]) -> String {
    let names: Vec<String> = names.iter().map(|n| escape(n)).collect();
    match names.as_slice() {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

fn identifiability(r: &Report) -> String {
    let id = &r.identifiability;
    if id.combinations.is_empty() && id.concealed.is_empty() && id.weakly_determined.is_empty() {
        return "<p>These data separate every estimated parameter.</p>\n".into();
    }
    let mut h = String::new();
    if !id.combinations.is_empty() {
        h.push_str("<h3>Parameters that move together</h3>\n<ul class=\"combinations\">\n");
        for c in &id.combinations {
            let _ = writeln!(
                h,
                "<li><b>{}</b>: moving them together changes no reading, so these data see only \
                 combinations of them; none of them gets a value.<details><summary>how they \
                 move together</summary>{}</details></li>",
                list(&c.parameters),
                escape(&c.why)
            );
        }
        h.push_str("</ul>\n");
    }
    if !id.weakly_determined.is_empty() {
        h.push_str("<h3>Parameters these data barely determine</h3>\n<ul class=\"weak\">\n");
        for c in &id.weakly_determined {
            let _ = writeln!(
                h,
                "<li><b>{}</b>: the value in the table means little: {}.</li>",
                list(&c.parameters),
                escape(&c.why)
            );
        }
        h.push_str("</ul>\n");
    }
    if !id.concealed.is_empty() {
        h.push_str("<h3>Effects hidden behind fitted parameters</h3>\n<ul class=\"concealed\">\n");
        for c in &id.concealed {
            let _ = writeln!(
                h,
                "<li><b>{}</b> looks to these data like {}: the fit cannot tell whether it is \
                 there. To tell them apart: {}.</li>",
                escape(&c.effect),
                list(&c.hides_behind),
                escape(&c.measurement)
            );
        }
        h.push_str("</ul>\n");
    }
    h
}

fn discoveries(r: &Report) -> String {
    let Some(s) = &r.search else {
        return none(
            "The physics search did not run (cargo xtask identify --search looks for thermal \
             drift, backlash, cyclic errors and omitted parameters).",
        );
    };
    let mut h = format!(
        "<p>The physics search scored {} candidate effects and added {}. It stopped: {}.</p>\n",
        s.candidates,
        match s.discoveries.len() {
            0 => "none".to_string(),
            1 => "one".to_string(),
            n => n.to_string(),
        },
        escape(&s.stopped)
    );
    for d in &s.discoveries {
        let mut numbers = format!(
            "fit RMS {} → {} µm · held-out RMS {} → {} µm",
            num(d.rms_before_um, 3),
            num(d.rms_after_um, 3),
            num(d.heldout_rms_before_um, 3),
            num(d.heldout_rms_after_um, 3)
        );
        if let Some((a, b)) = d.validation_rms_um {
            let _ = write!(
                numbers,
                " · validation RMS {} → {} µm",
                num(a, 3),
                num(b, 3)
            );
        }
        let _ = writeln!(
            h,
            "<article class=\"discovery\"><h3>{}</h3><p>{}</p><p class=\"numbers\">{numbers}</p></article>",
            escape(&d.label),
            escape(&d.explanation)
        );
    }
    if !s.not_kept.is_empty() {
        h.push_str("<details><summary>Candidates tried and not kept</summary><ul>\n");
        for t in &s.not_kept {
            let _ = writeln!(h, "<li>{}</li>", escape(t));
        }
        h.push_str("</ul></details>\n");
    }
    h
}

/// The start of a page up to its title heading: the document head (style, the script-error
/// recorder, a policy that allows nothing from outside) and `<header><h1>title</h1>`.
pub(crate) fn head(h: &mut String, title: &str) {
    let title = escape(title);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; \
         style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n\
         <title>{title}</title>\n<style>{STYLE}</style>\n<script>{ERROR_RECORDER}</script>\n\
         </head>\n<body>\n<pre id=\"script-errors\" hidden></pre>\n<header><h1>{title}</h1>\n"
    );
}
