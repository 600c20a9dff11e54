//! The history page (`cargo xtask history report`): one self-contained HTML page in the
//! identification report's style, with the fleet table (machine, campaigns, last check, the
//! parameters beyond their tolerances, the drift rates) and one trend plot per parameter: every
//! campaign's value with its 95 % interval, the drift line with its band, the tolerance lines.
//! Renders only: the numbers are the history's, given as this page's own model
//! ([`FleetEntry`], [`TrendPlot`]) so that the report (and the identification that writes
//! one) links no database.

use crate::escape::{display_unit, escape};
use crate::page::{READY, figure, head, none};
use crate::{FleetEntry, ReportError, TrendPlot};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the history page shows.
#[derive(Debug, Clone, Default)]
pub struct HistoryPage {
    /// `mtcal history — mill-3`, `mtcal history — fleet`.
    pub title: String,
    /// Where the history is (the SQLite file, the server without its password).
    pub source: String,
    pub fleet: Vec<FleetEntry>,
    /// Per machine of the fleet table, the drift rates shown in it: (parameter, text).
    pub drifts: Vec<(String, Vec<(String, String)>)>,
    /// The trend plots, one per parameter.
    pub trends: Vec<TrendPlot>,
}

/// The page's HTML.
pub fn render_history(p: &HistoryPage) -> Result<String, ReportError> {
    let mut h = String::with_capacity(1 << 18);
    head(&mut h, &p.title);
    let _ = write!(
        h,
        "<p>history <code>{}</code></p></header>\n<nav><a href=\"#fleet\">Fleet</a>\
         <a href=\"#trends\">Trends</a></nav>\n<main>\n",
        escape(&p.source)
    );
    let _ = write!(
        h,
        "<section id=\"fleet\">\n<h2>Fleet</h2>\n{}</section>\n",
        fleet(p)
    );
    let _ = write!(
        h,
        "<section id=\"trends\">\n<h2>Trends</h2>\n{}</section>\n",
        trends(&p.trends)?
    );
    let _ = write!(h, "</main>\n<script>{READY}</script>\n</body>\n</html>\n");
    Ok(h)
}

/// Renders `page` and writes it to `dir/index.html` (creating `dir`), atomically.
pub fn write_history(dir: &Path, page: &HistoryPage) -> Result<PathBuf, ReportError> {
    let html = render_history(page)?;
    crate::write_page(dir, &html)
}

fn fleet(p: &HistoryPage) -> String {
    if p.fleet.is_empty() {
        return none("The history has no machine yet.");
    }
    let mut h = String::from(
        "<table id=\"fleet-table\">\n<tr><th>machine</th><th>campaigns</th><th>last check</th>\
         <th>beyond tolerance</th><th>cannot decide</th><th>drift</th></tr>\n",
    );
    for line in &p.fleet {
        let drift = p
            .drifts
            .iter()
            .find(|(m, _)| *m == line.machine)
            .map(|(_, d)| {
                d.iter()
                    .map(|(name, text)| format!("{}: {}", escape(name), escape(text)))
                    .collect::<Vec<_>>()
                    .join("<br>")
            })
            .unwrap_or_default();
        let _ = writeln!(
            h,
            "<tr data-machine=\"{m}\"><td>{m}</td><td class=\"n\">{}</td><td>{}</td>\
             <td class=\"nid\">{}</td><td>{}</td><td>{drift}</td></tr>",
            line.campaigns,
            escape(&line.last_check_day),
            escape(&line.out_of_tolerance.join(", ")),
            escape(&line.cannot_decide.join(", ")),
            m = escape(&line.machine),
        );
    }
    h.push_str("</table>\n");
    h
}

fn trends(views: &[TrendPlot]) -> Result<String, ReportError> {
    if views.is_empty() {
        return Ok(none("No parameter was asked for (history report NAME)."));
    }
    let mut h = String::from("<div class=\"plots\">\n");
    for v in views {
        let svg = crate::plots::trend(v)?;
        let caption = match (&v.trend, &v.not_analysed) {
            (Some(t), _) => format!(
                "{} of {}: drift {:+.4} ± {:.4} {}/day, {}",
                escape(&v.parameter),
                escape(&v.machine),
                t.drift.rate_per_day,
                t.drift.rate_u95_per_day,
                escape(display_unit(v.unit.as_deref().unwrap_or(""))),
                match t.verdict {
                    mtcal_trend::Verdict::NoChange => "no significant change",
                    mtcal_trend::Verdict::Drift => "a steady drift",
                    mtcal_trend::Verdict::Step => "a step change",
                }
            ),
            (None, Some(why)) => format!("{}: {}", escape(&v.parameter), escape(why)),
            (None, None) => escape(&v.parameter),
        };
        h.push_str(&figure("trend", &v.parameter, &svg, &caption));
    }
    h.push_str("</div>\n");
    Ok(h)
}
