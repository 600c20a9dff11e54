//! The HTML report's model ([`mtcal_report::Report`]) of an identification: the fit, the
//! physics search, the study's runs and the machine model gathered into the numbers the page
//! shows (`mtcal identify --report DIR`). Everything here gathers what the identification
//! computed; the page itself is `mtcal_report`'s. Instrument-specific views come from the
//! plugins' hooks ([`mtcal_instrument::InstrumentPlugin::polar_view`]): no instrument is named.

use crate::IdentifyError;
use crate::findings::SearchFindings;
use crate::report::Identification;
use crate::search::Searched;
use crate::study::Study;
use mtcal_instrument::PolarView;
use mtcal_kinematics::volmap::{Grid, MapOptions, volumetric_map};
use mtcal_kinematics::{AxisKind, Machine};
use mtcal_report as rep;
use mtcal_solve::Solution;
use std::path::Path;

/// Points per axis of a volumetric map slice.
const SLICE_POINTS: usize = 21;

/// The model before the physics search: the session as loaded and its fit.
struct Before<'a> {
    study: Study,
    id: &'a Identification,
    predictions: Vec<Option<Vec<f64>>>,
}

/// The report of the identification `id` (its `study` and `solution`) of `session`; after a
/// physics search (`searched`) the page compares the fit before it with the final one.
pub fn report(
    session: &Path,
    study: &Study,
    solution: &Solution,
    id: &Identification,
    searched: Option<&Searched>,
    verdicts: Option<&mtcal_acceptance::Acceptance>,
) -> Result<rep::Report, IdentifyError> {
    let before = match searched {
        Some(searched) => {
            // The search started from the session as loaded: that study for its predictions.
            let study = study.as_loaded()?;
            (study.layout().n_x() == searched.before_x.len()).then(|| {
                let predictions = predictions(&study, &searched.before_x);
                Before {
                    study,
                    id: &searched.before,
                    predictions,
                }
            })
        }
        None => None,
    };
    let findings = searched.map(|s| &s.findings);
    let after = predictions(study, &solution.x);
    Ok(rep::Report {
        title: format!("mtcal identification — {}", session_name(session)),
        summary: summary(session, study, id, before.as_ref()),
        polar: polar_runs(study, &after, id, before.as_ref()),
        diagnostics: id.diagnostics.iter().map(diagnosis_table).collect(),
        residuals: residuals(study, &after, before.as_ref()),
        components: components(study, id),
        volumetric: volumetric(study, solution)?,
        parameters: parameters(study, solution, id),
        identifiability: identifiability(id, findings),
        search: findings.map(search),
        acceptance: verdicts.map(acceptance),
        location_series: location_series(id),
        conventions: id
            .conventions
            .rows()
            .into_iter()
            .map(|(key, value)| (key.to_string(), value))
            .collect(),
    })
}

/// The location errors cycle by cycle, those a thermal model changes or that depart from the
/// model first.
fn location_series(id: &Identification) -> Vec<rep::LocationSeriesPlot> {
    let mut series: Vec<&crate::series::LocationSeries> = id.location_series.iter().collect();
    series.sort_by_key(|l| !(l.modelled || l.departs));
    series
        .into_iter()
        .map(|l| rep::LocationSeriesPlot {
            name: l.parameter.clone(),
            unit: l.unit.clone(),
            caption: format!("{}: {}", l.parameter, l.agreement()),
            cycles: l
                .cycles
                .iter()
                .map(|c| rep::SeriesPoint {
                    t_h: 0.5 * (c.t_first_h + c.t_last_h),
                    value: c.value,
                    u95: c.u95,
                    model: c.model,
                    validation: c.validation,
                })
                .collect(),
        })
        .collect()
}

/// A circle pair's diagnostics as the page tables them.
fn diagnosis_table(d: &crate::diagnostics::DiagnosisReport) -> rep::DiagnosisTable {
    rep::DiagnosisTable {
        instrument: d.instrument.clone(),
        title: format!("{} {}: {}", d.instrument, d.subject, d.runs.join(" + ")),
        circularity_um: d.circularity_um,
        rows: d
            .items
            .iter()
            .map(|i| rep::DiagnosisRow {
                rank: i.rank,
                name: i.name.clone(),
                about: i.about.clone(),
                value: i.value,
                u95: i.u95,
                unit: i.unit.clone(),
                share_of_circularity: i.share_of_circularity,
                model: i.model,
                behind: i
                    .behind
                    .iter()
                    .map(|b| format!("{} {:.0} %", b.name, 100.0 * b.share))
                    .collect::<Vec<_>>()
                    .join(", "),
            })
            .collect(),
        notes: d.notes.clone(),
    }
}

/// The verdicts against the tolerance file, as the page's table.
fn acceptance(a: &mtcal_acceptance::Acceptance) -> rep::AcceptanceSection {
    rep::AcceptanceSection {
        file: a.file.clone(),
        rule: a.rule_text(),
        verdict: a.verdict.as_str().to_string(),
        rows: a
            .checks
            .iter()
            .map(|c| rep::AcceptanceRow {
                item: c.item.clone(),
                run: c.run.clone().unwrap_or_default(),
                value: c.value,
                uncertainty: c.uncertainty,
                tolerance: c.zone_text(),
                unit: c.unit.clone(),
                verdict: c.verdict.as_str().to_string(),
                note: c.note.clone().unwrap_or_default(),
            })
            .collect(),
    }
}

fn session_name(session: &Path) -> String {
    let dir = if session.extension().is_some_and(|e| e == "toml") {
        session.parent().unwrap_or(session)
    } else {
        session
    };
    let parts: Vec<String> = dir
        .components()
        .rev()
        .take(2)
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    parts.into_iter().rev().collect::<Vec<_>>().join("/")
}

/// Predicted readings of every run with readings.
fn predictions(study: &Study, x: &[f64]) -> Vec<Option<Vec<f64>>> {
    crate::predict_runs(study, x, |r| study.runs[r].readings.is_some())
}

fn summary(
    session: &Path,
    study: &Study,
    id: &Identification,
    before: Option<&Before<'_>>,
) -> rep::Summary {
    let samples: usize = study.runs.iter().map(|r| r.len()).sum();
    let fit = |id: &Identification| {
        format!(
            "RMS {:.3} µm, χ²/dof {:.3} ({} degrees of freedom)",
            id.fit.rms_um, id.fit.chi2_reduced, id.fit.dof
        )
    };
    let mut facts = vec![format!(
        "{} runs, {} samples; {} parameters ({} machine coefficients)",
        study.runs.len(),
        samples,
        study.layout().n_x(),
        study.layout().n_machine()
    )];
    if let Some(b) = before {
        facts.push(format!("fit before the physics search: {}", fit(b.id)));
        facts.push(format!("fit after the physics search: {}", fit(id)));
    } else {
        facts.push(format!("fit: {}", fit(id)));
    }
    let s = &id.solver;
    facts.push(format!(
        "solver: {} iterations, {}; rank {} of {} parameters, condition number {:.3e}",
        s.iterations,
        if s.converged {
            "converged"
        } else {
            "NOT converged"
        },
        s.rank,
        s.parameters,
        s.condition_number
    ));
    facts.push(if id.mismatch.detected {
        "mismatch: the residuals of the fitted runs are not noise (family-wise α = 5 %)".into()
    } else {
        "mismatch: none found — every fitted run's residuals pass the structure tests".into()
    });
    let runs = id
        .fit
        .runs
        .iter()
        .map(|r| (r, "fit"))
        .chain(id.validation.iter().map(|r| (r, "validate")))
        .map(|(r, role)| rep::RunRow {
            name: r.name.clone(),
            instrument: r.instrument.clone(),
            role: role.into(),
            rms_before_um: before.and_then(|b| {
                let all = b.id.fit.runs.iter().chain(&b.id.validation);
                all.clone().find(|x| x.name == r.name).map(|x| x.rms_um)
            }),
            rms_um: r.rms_um,
        })
        .collect();
    rep::Summary {
        session: session.display().to_string(),
        machine: format!(
            "{} ({})",
            study.machine.machine.name(),
            study.machine.source
        ),
        facts,
        runs,
    }
}

/// Channel `c` of run `r` in its file unit: `(readings, predictions)` of every sample.
fn channel_values(study: &Study, r: usize, pred: &[f64], c: usize) -> Option<(Vec<f64>, Vec<f64>)> {
    let run = &study.runs[r];
    let readings = run.readings.as_ref()?;
    let channels = study.channels(r);
    let per = channels.get(c)?.unit.per_si();
    let nch = channels.len();
    let measured = (0..run.len()).map(|i| readings.get(i, c) * per).collect();
    let model = pred.iter().skip(c).step_by(nch).map(|x| x * per).collect();
    Some((measured, model))
}

/// The polar plots of the runs whose instrument draws them so ([`PolarView`]): readings and
/// predictions of the view's channel at its angles.
fn polar_runs(
    study: &Study,
    after: &[Option<Vec<f64>>],
    id: &Identification,
    before: Option<&Before<'_>>,
) -> Vec<rep::PolarRun> {
    let mut out = Vec::new();
    for (r, run) in study.runs.iter().enumerate() {
        let Some(pred) = after[r].as_deref() else {
            continue;
        };
        let Some(view) = polar_view(study, r) else {
            continue;
        };
        let Some((measured, model)) = channel_values(study, r, pred, view.channel) else {
            continue;
        };
        let model_before = before.and_then(|b| {
            let rb = b.study.runs.iter().position(|x| x.name == run.name)?;
            let p = b.predictions.get(rb)?.as_deref()?;
            channel_values(&b.study, rb, p, view.channel).map(|(_, m)| m)
        });
        let metrics = id
            .fit
            .runs
            .iter()
            .chain(&id.validation)
            .find(|f| f.name == run.name)
            .map(|f| {
                let m = f.metrics.iter();
                m.map(|m| (m.name.clone(), m.value, m.unit.clone()))
                    .collect()
            })
            .unwrap_or_default();
        out.push(rep::PolarRun {
            name: run.name.clone(),
            instrument: study.setups[study.runs[r].setup].plugin.name.to_string(),
            plane: view.plane,
            radius_mm: view.radius * 1e3,
            angles_deg: view.angles.iter().map(|a| a.to_degrees()).collect(),
            measured_um: measured,
            model_um: model,
            model_before_um: model_before,
            metrics,
        });
    }
    out
}

/// Run `r` as its instrument draws it on a circle, if it does (and the run has readings).
fn polar_view(study: &Study, r: usize) -> Option<PolarView> {
    let view = study.setups[study.runs[r].setup].plugin.polar_view?;
    study.with_evaluation(r, view).flatten()
}

/// What a context column is and its unit (the run files' units).
fn describe_variable(name: &str) -> (String, String) {
    let (what, unit) = match name {
        "t" => ("time since the session started".to_string(), "s"),
        "S" => ("spindle speed".to_string(), "rpm"),
        "F" => ("feed rate".to_string(), "mm/min"),
        _ => match name.split_once('_') {
            Some(("T", rest)) => (format!("temperature ({rest})"), "°C"),
            Some(("P", rest)) => (format!("air pressure ({rest})"), "hPa"),
            Some(("H", rest)) => (format!("relative humidity ({rest})"), "%"),
            _ => (String::new(), ""),
        },
    };
    (what, unit.to_string())
}

/// Residuals (reading − model) of every run with readings against `t` and every context
/// column, in the channels' unit when they share one, else whitened (σ).
fn residuals(
    study: &Study,
    after: &[Option<Vec<f64>>],
    before: Option<&Before<'_>>,
) -> Vec<rep::ResidualPlot> {
    let units: std::collections::BTreeSet<&str> = (0..study.runs.len())
        .filter(|&r| study.runs[r].readings.is_some())
        .flat_map(|r| study.channels(r).iter().map(|c| c.unit.as_str()))
        .collect();
    let whiten = units.len() != 1;
    let residual_unit = match units.iter().next() {
        Some(u) if !whiten => (*u).to_string(),
        _ => "σ".to_string(),
    };
    let mut variables = vec!["t".to_string()];
    for run in study.runs.iter() {
        for (name, _) in &run.context {
            if !variables.contains(name) {
                variables.push(name.clone());
            }
        }
    }
    variables
        .into_iter()
        .map(|variable| {
            let (description, unit) = describe_variable(&variable);
            let before = before.map(|b| along(&b.study, &b.predictions, &variable, whiten));
            rep::ResidualPlot {
                after: along(study, after, &variable, whiten),
                before,
                variable,
                description,
                unit,
                residual_unit: residual_unit.clone(),
            }
        })
        .collect()
}

/// `(variable, residual)` of every sample and channel of the runs that have the variable.
fn along(
    study: &Study,
    predictions: &[Option<Vec<f64>>],
    variable: &str,
    whiten: bool,
) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for (r, run) in study.runs.iter().enumerate() {
        let (Some(readings), Some(Some(pred))) = (&run.readings, predictions.get(r)) else {
            continue;
        };
        let xs = if variable == "t" {
            &run.t
        } else {
            match run.context_column(variable) {
                Some(v) => v,
                None => continue,
            }
        };
        let channels = study.channels(r);
        let nch = channels.len();
        for i in 0..run.len() {
            let x = xs.get(i);
            for (c, ch) in channels.iter().enumerate() {
                let d = readings.get(i, c) - pred[i * nch + c];
                let scale = if whiten {
                    1.0 / ch.sigma
                } else {
                    ch.unit.per_si()
                };
                out.push((x, d * scale));
            }
        }
    }
    out
}

/// The identification's component curves with their units.
fn components(study: &Study, id: &Identification) -> Vec<rep::ComponentCurve> {
    let params = study.model.errors().params();
    id.component_errors
        .iter()
        .map(|c| {
            let name = params
                .iter()
                .map(|p| p.name)
                .find(|n| n.to_string() == c.name);
            let rotary = name.and_then(|n| n.axis()).is_some_and(|a| a.is_rotary());
            rep::ComponentCurve {
                name: c.name.clone(),
                position_unit: if rotary { "deg" } else { "mm" }.into(),
                value_unit: name.map_or("um", |n| n.unit()).into(),
                samples: c
                    .samples
                    .iter()
                    .map(|s| rep::CurvePoint {
                        position: s[0],
                        value: s[1],
                        u95: s[2],
                    })
                    .collect(),
            }
        })
        .collect()
}

/// Slices of the first-order volumetric map through the middle of the stroke, one per pair of
/// linear axes (at most three), rotary axes at 0.
fn volumetric(study: &Study, solution: &Solution) -> Result<rep::Volumetric, IdentifyError> {
    let machine = study.model.machine();
    let coeffs = study.coeffs_from(&solution.x);
    let n_linear = Grid::new(machine, 1)
        .map_err(IdentifyError::MapGrid)?
        .linear()
        .len();
    let mut slices = Vec::new();
    for a in 0..n_linear {
        for b in a + 1..n_linear {
            if slices.len() == 3 {
                break;
            }
            let mut counts = vec![1; n_linear];
            counts[a] = SLICE_POINTS;
            counts[b] = SLICE_POINTS;
            let grid = Grid::with_counts(machine, &counts).map_err(IdentifyError::MapGrid)?;
            let map = volumetric_map(&study.model, &coeffs, &grid, &MapOptions::default());
            slices.push(slice(machine, &grid, map.magnitudes_um(), a, b));
        }
    }
    let rotary: Vec<String> = machine
        .axes()
        .iter()
        .filter(|ax| ax.kind() == AxisKind::Rotary)
        .map(|ax| format!("{} = 0°", ax.letter().as_char()))
        .collect();
    let mut note = String::from(
        "|Δ|, the tool point's position error relative to the workpiece, from the identified \
         machine parameters (first-order model) on planes through the middle of the strokes",
    );
    if !rotary.is_empty() {
        note.push_str(&format!(", {}", rotary.join(", ")));
    }
    note.push_str(
        ". Parameters the data cannot separate enter as the fit left them (see below), so the \
         map is only as good as the identifiability section says.",
    );
    Ok(rep::Volumetric { slices, note })
}

/// The slice of linear axes `a` (horizontal) and `b` of a grid with one point on every other
/// linear axis: grid order has `a` slower than `b`.
fn slice(machine: &Machine, grid: &Grid, mags: &[f64], a: usize, b: usize) -> rep::MapSlice {
    let lin = grid.linear();
    let values = |r: &mtcal_kinematics::volmap::AxisRange| -> Vec<f64> {
        (0..r.n)
            .map(|i| machine.axes()[r.axis].kind().to_file(r.value(i)))
            .collect()
    };
    let (xs, ys) = (values(&lin[a]), values(&lin[b]));
    let (nx, ny) = (xs.len(), ys.len());
    let mut v = vec![0.0; nx * ny];
    for i in 0..nx {
        for j in 0..ny {
            v[j * nx + i] = mags[i * ny + j];
        }
    }
    let held: Vec<String> = lin
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != a && *k != b)
        .map(|(_, r)| {
            let mm = machine.axes()[r.axis].kind().to_file(r.value(0));
            format!("{} = {:.0} mm", r.letter, mm).replace('-', "−")
        })
        .collect();
    let title = if held.is_empty() {
        format!("{}–{}", lin[a].letter, lin[b].letter)
    } else {
        format!("{}–{} at {}", lin[a].letter, lin[b].letter, held.join(", "))
    };
    rep::MapSlice {
        title,
        x_label: format!("{} (mm)", lin[a].letter),
        y_label: format!("{} (mm)", lin[b].letter),
        xs,
        ys,
        values_um: v,
    }
}

/// Every parameter in the fit's order: its value, or "not identifiable" (never a number).
fn parameters(study: &Study, solution: &Solution, id: &Identification) -> Vec<rep::ParameterRow> {
    let mut rows = Vec::new();
    for i in 0..study.layout().n_x() {
        let info = study.param_info(i);
        if let Some(p) = id.parameters.iter().find(|p| p.name == info.name) {
            rows.push(rep::ParameterRow {
                name: p.name.clone(),
                group: p.kind.clone(),
                unit: p.unit.clone(),
                estimate: rep::Estimate::Value {
                    value: p.value,
                    u95: p.u95,
                },
            });
        } else if !solution.identified.get(i).copied().unwrap_or(true) {
            rows.push(rep::ParameterRow {
                name: info.name,
                group: study.param_group(i),
                unit: info.unit,
                estimate: rep::Estimate::NotIdentifiable,
            });
        }
    }
    rows
}

fn identifiability(id: &Identification, findings: Option<&SearchFindings>) -> rep::Identifiability {
    rep::Identifiability {
        combinations: id
            .unidentifiable
            .iter()
            .map(|u| rep::Combination {
                parameters: u.parameters.clone(),
                why: u.why.clone(),
            })
            .collect(),
        concealed: findings
            .iter()
            .flat_map(|f| &f.report.concealed)
            .map(|c| rep::ConcealedEffect {
                // The candidate's name already says its family, e.g. `ECZ (omitted-parameter)`.
                effect: c.candidate.clone(),
                hides_behind: c.hides_behind.clone(),
                measurement: c.measurement.clone(),
            })
            .collect(),
        weakly_determined: id
            .weakly_determined
            .iter()
            .map(|w| rep::Combination {
                parameters: w.parameters.clone(),
                why: w.why.clone(),
            })
            .collect(),
    }
}

fn search(findings: &SearchFindings) -> rep::SearchOutcome {
    let s = &findings.report;
    let discoveries = findings
        .discoveries
        .iter()
        .map(|d| rep::DiscoveryText {
            label: d.label.clone(),
            explanation: d.explanation.clone(),
            rms_before_um: d.rms_before_um,
            rms_after_um: d.rms_after_um,
            heldout_rms_before_um: d.heldout_rms_before_um,
            heldout_rms_after_um: d.heldout_rms_after_um,
            validation_rms_um: d.validation_rms_before_um.zip(d.validation_rms_after_um),
        })
        .collect();
    let not_kept = s
        .steps
        .iter()
        .enumerate()
        .flat_map(|(k, trials)| {
            trials
                .iter()
                .filter(|t| !t.accepted)
                .map(move |t| format!("step {}: {}: {}", k + 1, t.candidate, t.why))
        })
        .collect();
    rep::SearchOutcome {
        candidates: s.candidates,
        stopped: s.stopped.to_string(),
        discoveries,
        not_kept,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_machine::topology::{Reading, nominal_machine, parse_code};

    #[test]
    fn the_title_names_the_session_by_its_last_two_folders() {
        assert_eq!(
            session_name(Path::new("examples/five-axis/session")),
            "five-axis/session"
        );
        assert_eq!(
            session_name(Path::new("/data/run7/session/session.toml")),
            "run7/session"
        );
        assert_eq!(session_name(Path::new("session")), "session");
    }

    #[test]
    fn context_columns_are_described_with_their_units() {
        let d = |name: &str| {
            let (what, unit) = describe_variable(name);
            format!("{what} [{unit}]")
        };
        assert_eq!(d("t"), "time since the session started [s]");
        assert_eq!(d("S"), "spindle speed [rpm]");
        assert_eq!(d("T_spindle"), "temperature (spindle) [°C]");
        assert_eq!(d("P_air"), "air pressure (air) [hPa]");
        assert_eq!(d("H_air"), "relative humidity (air) [%]");
        assert_eq!(d("load"), " []");
    }

    #[test]
    fn a_slice_is_the_grid_transposed_with_the_held_axis_in_its_title() {
        let code = parse_code("ZFYX", Reading::FromTool).unwrap();
        let machine = nominal_machine(&code, "ZFYX").unwrap();
        // X with 3 points, Y held at its middle, Z with 2: grid order X slowest, Z fastest.
        let grid = Grid::with_counts(&machine, &[3, 1, 2]).unwrap();
        let mags: Vec<f64> = (0..6).map(f64::from).collect();
        let s = slice(&machine, &grid, &mags, 0, 2);
        assert_eq!(s.xs.len(), 3);
        assert_eq!(s.ys.len(), 2);
        // values_um[j·nx + i] is X point i, Z point j.
        assert_eq!(s.values_um, vec![0.0, 2.0, 4.0, 1.0, 3.0, 5.0]);
        let y = grid.linear()[1].value(0) * 1e3;
        let held = format!("Y = {y:.0} mm").replace('-', "−");
        assert_eq!(s.title, format!("X–Z at {held}"));
        assert_eq!(
            (s.x_label.as_str(), s.y_label.as_str()),
            ("X (mm)", "Z (mm)")
        );
    }
}
