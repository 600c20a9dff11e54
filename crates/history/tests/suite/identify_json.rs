//! `Campaign::from_identify_json` against the identification itself: the real pipeline's
//! typed result (not its JSON) says what every stored parameter must be. And the parts of the
//! format the shipped examples do not reach (combinations, held parameters, discoveries, a
//! verdict), and bad input.

use mtcal_history::{Campaign, ParameterStatus, parse_date};
use std::collections::HashSet;

fn identify(example: &str) -> mtcal_identify::Identification {
    let session = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(example)
        .join("session");
    mtcal_identify::identify_session(&session).unwrap().1
}

#[test]
fn every_parameter_of_the_examples_is_read_with_its_status() {
    let date = parse_date("2025-01-15T09:00:00Z").unwrap();
    for example in ["three-axis", "five-axis"] {
        let id = identify(example);
        let campaign = Campaign::from_identify_json(
            &mtcal_identify::report::IdentifyJson::of(&id).to_json(),
            "mill-7",
            date,
        )
        .unwrap();
        assert_eq!(campaign.machine.name, "mill-7");
        assert_eq!(campaign.date, date);
        let weak: HashSet<&str> = id
            .weakly_determined
            .iter()
            .flat_map(|w| w.parameters.iter().map(String::as_str))
            .collect();
        for p in &id.parameters {
            let stored = campaign
                .parameters
                .iter()
                .find(|s| s.name == p.name)
                .unwrap();
            assert_eq!(stored.value, Some(p.value), "{}", p.name);
            assert_eq!(stored.u95, Some(p.u95), "{}", p.name);
            assert_eq!(stored.unit.as_deref(), Some(p.unit.as_str()));
            assert_eq!(stored.kind.as_deref(), Some(p.kind.as_str()));
            let status = if weak.contains(p.name.as_str()) {
                ParameterStatus::WeaklyDetermined
            } else {
                ParameterStatus::Identified
            };
            assert_eq!(stored.status, status, "{}", p.name);
        }
        let unidentifiable: HashSet<&str> = id
            .unidentifiable
            .iter()
            .flat_map(|u| u.parameters.iter().map(String::as_str))
            .collect();
        for name in &unidentifiable {
            let stored = campaign
                .parameters
                .iter()
                .find(|s| s.name == *name)
                .unwrap();
            assert_eq!(stored.status, ParameterStatus::NotIdentifiable);
            assert_eq!((stored.value, stored.u95), (None, None));
        }
        assert_eq!(
            campaign.parameters.len(),
            id.parameters.len() + unidentifiable.len(),
            "{example}"
        );
        assert_eq!(campaign.fit.rms_um, id.fit.rms_um);
        assert_eq!(campaign.fit.chi2_reduced, Some(id.fit.chi2_reduced));
        assert_eq!(campaign.fit.dof, id.fit.dof as u64);
        assert_eq!(campaign.fit.runs, id.fit.runs.len() as u64);
        assert_eq!(campaign.fit.converged, id.solver.converged);
        let mut instruments: Vec<&str> = Vec::new();
        for run in id.fit.runs.iter().chain(&id.validation) {
            if !instruments.contains(&run.instrument.as_str()) {
                instruments.push(&run.instrument);
            }
        }
        assert_eq!(campaign.instruments, instruments);
        let validation: Vec<(&str, Option<f64>)> = campaign
            .validation
            .iter()
            .map(|v| (v.name.as_str(), v.rms_um))
            .collect();
        let expected: Vec<(&str, Option<f64>)> = id
            .validation
            .iter()
            .map(|v| (v.name.as_str(), Some(v.rms_um)))
            .collect();
        assert_eq!(validation, expected);
    }
    // The examples do reach both "weakly determined" and "not identifiable".
    assert!(!identify("three-axis").weakly_determined.is_empty());
    assert!(!identify("five-axis").unidentifiable.is_empty());
}

/// mtcal's additions the examples do not exercise, written from docs/FORMATS.md.
const RICH: &str = r#"{
  "schema": "mtcal.identify/1",
  "verdict": "the model does not explain the recordings: χ²/dof = 4.1",
  "parameters": [
    {"name": "EX0C", "value": 12.3, "unit": "um", "u95": 0.4, "kind": "machine"},
    {"name": "thermal-drift Z (t).tau_s", "value": 1800.0, "unit": "s", "u95": 200.0, "kind": "effect"}
  ],
  "combinations": [
    {"expression": "EC0Y − 0.5·EXX.P1", "name": "EC0Y",
     "terms": [{"name": "EXX.P1", "coefficient": -0.5}],
     "value": 7.5, "unit": "urad", "u95": 0.9, "kind": "machine"}
  ],
  "unidentifiable": [{"parameters": ["EC0Y", "EXX.P1"], "why": "aliased"}],
  "held": [{"name": "EXX.P1", "unit": "um", "why": {"kind": "aliased"}},
           {"name": "EZZ.P3", "unit": "um", "why": {"kind": "too-weak", "u95": 80.0}}],
  "fit": {"rms_um": 3.1, "chi2_reduced": 4.1, "chi2": 410.0, "dof": 100,
          "runs": [{"name": "bb-1", "instrument": "ballbar", "rms_um": 3.1}]},
  "validation": [{"name": "bb-2", "instrument": "ballbar", "rms_um": null}],
  "discoveries": [{"effect": "thermal-drift", "label": "thermal-drift Z (t)", "axis": "Z",
                   "sentence": "Z drifts by 3 µm with τ = 1800 s."},
                  {"effect": "reversal", "axis": "X"}],
  "solver": {"converged": true, "iterations": 7}
}"#;

#[test]
fn combinations_held_parameters_and_discoveries_are_read() {
    let date = parse_date("2025-01-15").unwrap();
    let campaign = Campaign::from_identify_json(RICH, "mill-7", date).unwrap();
    let statuses: Vec<(&str, ParameterStatus, Option<f64>, Option<&str>)> = campaign
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), p.status, p.value, p.unit.as_deref()))
        .collect();
    use ParameterStatus::*;
    assert_eq!(
        statuses,
        vec![
            ("EX0C", Identified, Some(12.3), Some("um")),
            (
                "thermal-drift Z (t).tau_s",
                Identified,
                Some(1800.0),
                Some("s")
            ),
            ("EC0Y", Combination, Some(7.5), Some("urad")),
            ("EXX.P1", NotIdentifiable, None, Some("um")),
            ("EZZ.P3", NotIdentifiable, None, Some("um")),
        ]
    );
    assert_eq!(
        campaign.parameters[2].expression.as_deref(),
        Some("EC0Y − 0.5·EXX.P1")
    );
    assert_eq!(
        campaign.fit.verdict.as_deref(),
        Some("the model does not explain the recordings: χ²/dof = 4.1")
    );
    assert_eq!(campaign.validation[0].rms_um, None);
    assert_eq!(campaign.instruments, vec!["ballbar"]);
    let discoveries: Vec<(&str, &str, Option<&str>)> = campaign
        .discoveries
        .iter()
        .map(|d| (d.effect.as_str(), d.label.as_str(), d.sentence.as_deref()))
        .collect();
    assert_eq!(
        discoveries,
        vec![
            (
                "thermal-drift",
                "thermal-drift Z (t)",
                Some("Z drifts by 3 µm with τ = 1800 s.")
            ),
            ("reversal", "reversal", None),
        ]
    );
}

#[test]
fn bad_identify_json_is_a_clear_error() {
    let date = parse_date("2025-01-15").unwrap();
    let cases = [
        ("{", "identify JSON"),
        (r#"{"schema": "mtcal.identify/2"}"#, "mtcal.identify/2"),
        (&RICH.replace(r#""dof": 100,"#, ""), "missing field `dof`"),
        (&RICH.replace(r#""converged": true"#, r#""converged": "yes""#), "solver.converged"),
        (&RICH.replace(r#""value": 12.3"#, r#""value": null"#), "EX0C's value is missing"),
        (&RICH.replace(r#""rms_um": 3.1, "chi2_reduced""#, r#""rms_um": null, "chi2_reduced""#), "fit.rms_um"),
        (&RICH.replace(r#""u95": 0.4"#, r#""u95": -0.4"#), "negative"),
        (
            &RICH.replace(r#""combinations": ["#, r#""combinations": [{"expression": "x", "name": "EX0C", "value": 1.0, "unit": "um", "u95": 1.0},"#),
            "EX0C has two values",
        ),
    ];
    for (json, why) in cases {
        let error = Campaign::from_identify_json(json, "mill-7", date)
            .unwrap_err()
            .to_string();
        assert!(error.contains(why), "{why}: {error}");
    }
}
