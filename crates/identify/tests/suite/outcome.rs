//! What `identify` returns is composed of parts, each built once: the final fit's report, the
//! search's findings, the information account and the acceptance verdicts. The JSON is a view
//! of them, in the keys and order FORMATS.md's `mtcal.identify/1` has always had; the report of
//! the fit alone holds none of the other parts.

use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use mtcal_identify::report::IdentifyJson;
use mtcal_solve::Silent;
use mtcal_testkit::repo;

/// The top-level keys of a JSON document, in the order written.
fn keys(json: &str) -> Vec<String> {
    let value: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str::<serde_json::Value>(json)
            .unwrap()
            .as_object()
            .unwrap()
            .clone();
    // serde_json's map keeps no order without its feature: read the order from the text.
    let mut found: Vec<(usize, String)> = value
        .keys()
        .map(|k| (json.find(&format!("\n  \"{k}\": ")).unwrap(), k.clone()))
        .collect();
    found.sort();
    found.into_iter().map(|(_, k)| k).collect()
}

#[test]
fn the_json_is_a_view_of_the_outcome_s_parts() {
    let example = repo().join("examples/three-axis");
    let tolerances =
        mtcal_acceptance::Tolerances::read(&repo().join("examples/acceptance/three-axis.toml"))
            .unwrap();
    let options = PipelineOptions {
        acceptance: Some(tolerances),
        ..Default::default()
    };
    let outcome = Prepared::load(&example.join("session"), options)
        .unwrap()
        .run(&mut Silent)
        .unwrap();
    let json = outcome.to_json();
    let written = keys(&json);
    let expected = [
        "schema",
        "parameters",
        "component_errors",
        "unidentifiable",
        "fit",
        "validation",
        "mismatch",
        "mismatch_tests",
        "discoveries",
        "solver",
        "information",
        "conventions",
        "acceptance",
    ];
    // Optional keys (combinations, held, noise, diagnostics…) come in between when present;
    // the fixed ones keep their order, the acceptance last.
    let fixed: Vec<&String> = written
        .iter()
        .filter(|k| expected.contains(&k.as_str()))
        .collect();
    assert_eq!(fixed, expected, "{written:?}");
    assert_eq!(written.last().map(String::as_str), Some("acceptance"));
    assert!(
        !written.contains(&"search".to_string()),
        "no search was run"
    );
    // Each part is in the JSON as the outcome holds it.
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(
        value["information"]["parameters"].as_array().unwrap().len(),
        outcome.information.parameters.len()
    );
    let verdicts = outcome
        .acceptance
        .as_ref()
        .expect("a tolerance file was given");
    assert_eq!(value["acceptance"]["verdict"], verdicts.verdict.as_str());
    // The fit's report alone holds none of the other parts, and the screen shows the verdicts.
    let alone = keys(&IdentifyJson::of(&outcome.identification).to_json());
    for part in ["information", "acceptance", "search"] {
        assert!(!alone.contains(&part.to_string()), "{alone:?}");
    }
    assert_eq!(
        alone,
        written
            .iter()
            .filter(|k| !["information", "acceptance"].contains(&k.as_str()))
            .cloned()
            .collect::<Vec<_>>()
    );
    let screen = outcome.screen(false);
    assert!(screen.contains(verdicts.summary().trim()), "{screen}");
}
