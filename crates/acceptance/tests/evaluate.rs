//! Tolerances checked against evidence built by hand: which value each tolerance meets, the
//! verdicts by the rule, the reasons a check cannot be decided, curves over the stroke, the
//! coverage factor, the summary lines and the JSON.

use mtcal_acceptance::{
    CIRCULAR_DEVIATION, Check, CurveEvidence, Evidence, MetricEvidence, ParameterEvidence,
    Tolerances, Undetermined, Verdict, Zone, evaluate,
};
use mtcal_located::Source;
use std::path::Path;

fn tolerances(text: &str) -> Tolerances {
    Tolerances::parse(&Source::new(Path::new("acc.toml"), text.to_string())).unwrap()
}

fn metric(run: &str, name: &str, subject: &str, value: f64, u95: Option<f64>) -> MetricEvidence {
    MetricEvidence {
        run: run.into(),
        name: name.into(),
        subject: Some(subject.into()),
        value,
        u95,
        k: 2.0,
        unit: "um".into(),
    }
}

fn evidence() -> Evidence {
    Evidence {
        metrics: vec![
            metric("laser-x", "E (ISO 230-2)", "X", 7.0, Some(1.0)),
            metric("laser-x", "A (ISO 230-2)", "X", 11.5, Some(1.0)),
            metric("laser-x2", "E (ISO 230-2)", "X", 9.5, Some(1.0)),
            // A diagonal: about no axis.
            MetricEvidence {
                subject: None,
                ..metric("diag", "E (ISO 230-2)", "X", 1.0, Some(0.1))
            },
            metric("bb-xy", CIRCULAR_DEVIATION, "XY", 5.0, Some(2.0)),
            metric("bb-yz", CIRCULAR_DEVIATION, "YZ", 14.0, Some(2.0)),
            metric("bb-zx", CIRCULAR_DEVIATION, "ZX", 9.0, None),
        ],
        parameters: vec![
            ParameterEvidence {
                name: "EC0Y".into(),
                value: -12.0,
                u95: 3.0,
                k: 1.96,
                unit: "urad".into(),
            },
            ParameterEvidence {
                name: "EB0Z".into(),
                value: 25.0,
                u95: 3.0,
                k: 1.96,
                unit: "urad".into(),
            },
        ],
        curves: vec![CurveEvidence {
            name: "EXX".into(),
            unit: "um".into(),
            position_unit: "mm".into(),
            samples: vec![[-300.0, -2.0, 0.5], [0.0, 0.0, 0.2], [300.0, 3.2, 0.5]],
            k: 1.96,
        }],
        undetermined: vec![Undetermined {
            names: vec!["EZ0A".into(), "ball.tool_length".into()],
            why: "only their sum is observed".into(),
        }],
    }
}

fn find<'a>(checks: &'a [Check], item: &str, run: Option<&str>) -> &'a Check {
    checks
        .iter()
        .find(|c| c.item == item && c.run.as_deref() == run)
        .unwrap_or_else(|| panic!("no check {item} {run:?} in {checks:#?}"))
}

#[test]
fn each_tolerance_meets_its_values_and_is_decided_by_the_rule() {
    let t = tolerances(
        "[iso230_2.X]\nE_um = 9\nA_um = 12\n[iso230_2.Y]\nE_um = 9\n\
         [iso230_4]\nG_um = 15\n[iso230_4.YZ]\nG_um = 12\n\
         [parameters]\nEC0Y = { max_abs_urad = 15 }\nEB0Z = { max_abs_urad = 20 }\n\
         EZ0A = { max_abs_um = 10 }\nEXX = { max_abs_um = 4 }\n",
    );
    let a = evaluate(&t, &evidence());
    let c = &a.checks;
    // E of X in both runs along X (not the diagonal): 7 ± 1 ≤ 9 − 1 passes; 9.5 ± 1 is
    // beyond 9 by less than U.
    let e1 = find(c, "E (ISO 230-2) X", Some("laser-x"));
    assert_eq!(
        (e1.verdict, e1.value, e1.uncertainty),
        (Verdict::Pass, Some(7.0), Some(1.0))
    );
    assert_eq!(e1.zone, Zone::Upper);
    let e2 = find(c, "E (ISO 230-2) X", Some("laser-x2"));
    assert_eq!(e2.verdict, Verdict::CannotDecide);
    assert_eq!(c.iter().filter(|c| c.item == "E (ISO 230-2) X").count(), 2);
    // A: 11.5 ± 1 against 12, inside by less than U.
    assert_eq!(
        find(c, "A (ISO 230-2) X", Some("laser-x")).verdict,
        Verdict::CannotDecide
    );
    // No run along Y.
    let y = find(c, "E (ISO 230-2) Y", None);
    assert_eq!((y.verdict, y.value), (Verdict::CannotDecide, None));
    assert!(
        y.note
            .as_ref()
            .unwrap()
            .contains("no run of this session gives ISO 230-2 values along Y")
    );
    // G: every circle against 15 but YZ against its own 12: 5 ± 2 passes, 14 ± 2 lies on the
    // outer guard-band edge 12 + 2 (cannot decide), ZX without U goes by the simple rule.
    assert_eq!(
        find(c, "G (ISO 230-4) XY", Some("bb-xy")).verdict,
        Verdict::Pass
    );
    let yz = find(c, "G (ISO 230-4) YZ", Some("bb-yz"));
    assert_eq!((yz.verdict, yz.tolerance), (Verdict::CannotDecide, 12.0));
    let zx = find(c, "G (ISO 230-4) ZX", Some("bb-zx"));
    assert_eq!(zx.verdict, Verdict::Pass);
    assert_eq!(
        zx.note.as_deref(),
        Some("no uncertainty: simple acceptance")
    );
    // Parameters, two-sided: |−12| ± 3 ≤ 15 − 3 passes; 25 > 20 + 3 fails.
    let ec0y = find(c, "EC0Y", None);
    assert_eq!((ec0y.verdict, ec0y.zone), (Verdict::Pass, Zone::TwoSided));
    assert_eq!(find(c, "EB0Z", None).verdict, Verdict::Fail);
    // Not determined: cannot decide, with the reason.
    let ez0a = find(c, "EZ0A", None);
    assert_eq!((ez0a.verdict, ez0a.value), (Verdict::CannotDecide, None));
    assert_eq!(
        ez0a.note.as_deref(),
        Some("not determined by these runs: only their sum is observed")
    );
    // EXX at every point: 3.2 ± 0.5 at 300 mm is inside 4 by more than U: passes, shown there.
    let exx = find(c, "EXX over the stroke", None);
    assert_eq!((exx.verdict, exx.value), (Verdict::Pass, Some(3.2)));
    assert_eq!(
        exx.note.as_deref(),
        Some("decided at 300 mm (3 points over the stroke)")
    );
    // One failure fails it all.
    assert_eq!(a.verdict, Verdict::Fail);
    assert_eq!(c.len(), 11);
}

#[test]
fn a_curve_fails_at_one_point_beyond_and_is_undecided_near_its_limit() {
    let ev = evidence();
    let verdict = |limit: f64| {
        let t = tolerances(&format!("[parameters]\nEXX = {{ max_abs_um = {limit} }}\n"));
        let a = evaluate(&t, &ev);
        (a.checks[0].verdict, a.checks[0].value)
    };
    // 3.2 + 0.5 = 3.7: pass from there; 3.2 − 0.5 = 2.7: fail below it (shown at the point
    // furthest beyond); between, cannot decide.
    assert_eq!(verdict(3.7), (Verdict::Pass, Some(3.2)));
    assert_eq!(verdict(3.0), (Verdict::CannotDecide, Some(3.2)));
    assert_eq!(verdict(2.6), (Verdict::Fail, Some(3.2)));
    // Beyond at −300 too (|−2| > 1.4 + 0.5), but 300 mm is further beyond.
    assert_eq!(verdict(1.4), (Verdict::Fail, Some(3.2)));
}

#[test]
fn the_coverage_factor_rescales_every_uncertainty() {
    // k = 3: the instruments' U (k = 2) × 1.5, the parameters' (k = 1.96) × 3/1.96.
    let t = tolerances(
        "coverage = 3\n[iso230_2.X]\nE_um = 9\n[parameters]\nEC0Y = { max_abs_urad = 15 }\n",
    );
    let a = evaluate(&t, &evidence());
    let e1 = find(&a.checks, "E (ISO 230-2) X", Some("laser-x"));
    assert_eq!((e1.uncertainty, e1.verdict), (Some(1.5), Verdict::Pass));
    let ec0y = find(&a.checks, "EC0Y", None);
    assert!((ec0y.uncertainty.unwrap() - 3.0 / 1.96 * 3.0).abs() < 1e-12);
    // 12 + 4.59 > 15: no longer proven.
    assert_eq!(ec0y.verdict, Verdict::CannotDecide);
    assert_eq!(a.coverage, Some(3.0));
}

#[test]
fn the_simple_rule_decides_at_the_limit() {
    let t =
        tolerances("decision_rule = \"simple\"\n[iso230_2.X]\nE_um = 9\n[iso230_4.XY]\nG_um = 4\n");
    let a = evaluate(&t, &evidence());
    assert_eq!(
        find(&a.checks, "E (ISO 230-2) X", Some("laser-x")).verdict,
        Verdict::Pass
    );
    assert_eq!(
        find(&a.checks, "E (ISO 230-2) X", Some("laser-x2")).verdict,
        Verdict::Fail
    );
    // Only XY has a tolerance: the other circles are not checked.
    assert_eq!(
        find(&a.checks, "G (ISO 230-4) XY", Some("bb-xy")).verdict,
        Verdict::Fail
    );
    assert_eq!(a.checks.len(), 3);
    assert!(a.checks.iter().all(|c| c.note.is_none()));
}

#[test]
fn a_plane_without_circles_cannot_be_decided() {
    let t = tolerances("[iso230_4]\nG_um = 20\n[iso230_4.XY]\nG_um = 8\n");
    let a = evaluate(&t, &Evidence::default());
    let notes: Vec<(&str, Option<&str>)> = a
        .checks
        .iter()
        .map(|c| (c.item.as_str(), c.note.as_deref()))
        .collect();
    assert_eq!(
        notes,
        [
            (
                "G (ISO 230-4)",
                Some("no ball-bar circle of this session at all")
            ),
            (
                "G (ISO 230-4) XY",
                Some("no ball-bar circle of this session in plane XY")
            ),
        ]
    );
    assert_eq!(a.verdict, Verdict::CannotDecide);
    // Every circle taken by its plane's own tolerance: the one for all is not a check.
    let mut ev = evidence();
    ev.metrics
        .retain(|m| m.name != CIRCULAR_DEVIATION || m.subject.as_deref() == Some("XY"));
    let a = evaluate(&t, &ev);
    let items: Vec<&str> = a.checks.iter().map(|c| c.item.as_str()).collect();
    assert_eq!(items, ["G (ISO 230-4) XY"]);
}

#[test]
fn the_summary_has_a_line_per_check_and_the_overall_verdict() {
    let t = tolerances("[iso230_2.X]\nE_um = 9\n[parameters]\nEC0Y = { max_abs_urad = 15 }\n");
    let a = evaluate(&t, &evidence());
    let s = a.summary();
    let lines: Vec<&str> = s.lines().collect();
    assert_eq!(lines[0], "");
    assert!(
        lines[1].starts_with("acceptance against acc.toml (ISO 14253-1: "),
        "{s}"
    );
    assert_eq!(
        lines[2],
        "  E (ISO 230-2) X [laser-x]          7.000 ± 1.000 um         ≤ 9 um             pass"
    );
    assert!(lines[3].ends_with("cannot decide"), "{s}");
    assert_eq!(
        lines[4],
        "  EC0Y                               -12.000 ± 3.000 urad     |·| ≤ 15 urad      pass"
    );
    assert_eq!(
        lines[5],
        "overall: CANNOT DECIDE (2 pass, 0 fail, 1 cannot decide)"
    );
    assert_eq!(lines.len(), 6);
}

#[test]
fn the_json_names_every_field() {
    let t = tolerances("[parameters]\nEZ0A = { max_abs_um = 10 }\nEC0Y = { max_abs_urad = 15 }\n");
    let a = evaluate(&t, &evidence());
    let json = serde_json::to_value(&a).unwrap();
    assert_eq!(json["file"], "acc.toml");
    assert_eq!(json["decision_rule"], "iso14253-1");
    assert_eq!(json["verdict"], "cannot decide");
    assert!(json.get("coverage").is_none());
    let checks = json["checks"].as_array().unwrap();
    assert_eq!(checks[0]["item"], "EC0Y");
    assert_eq!(checks[0]["value"], -12.0);
    assert_eq!(checks[0]["uncertainty"], 3.0);
    assert_eq!(checks[0]["tolerance"], 15.0);
    assert_eq!(checks[0]["zone"], "two-sided");
    assert_eq!(checks[0]["unit"], "urad");
    assert_eq!(checks[0]["verdict"], "pass");
    assert_eq!(checks[1]["item"], "EZ0A");
    assert!(checks[1].get("value").is_none() && checks[1].get("uncertainty").is_none());
    assert_eq!(checks[1]["verdict"], "cannot decide");
}
