//! The tolerance file read typed, and every broken file refused at its line and column with
//! what was expected.

use mtcal_acceptance::{
    AcceptanceError, AxisTolerance, CircleTolerance, DecisionRule, Iso230_2Value, ParameterUnit,
    Tolerances,
};
use mtcal_located::Source;
use std::path::Path;

fn parse(text: &str) -> Result<Tolerances, AcceptanceError> {
    Tolerances::parse(&Source::new(Path::new("acc.toml"), text.to_string()))
}

/// The located message of a file that must be refused.
fn refused(text: &str) -> String {
    match parse(text) {
        Ok(t) => panic!("accepted: {t:?}"),
        Err(e) => e.to_string(),
    }
}

const FULL: &str = r#"schema = "mtcal.acceptance/1"
decision_rule = "simple"
coverage = 2

[iso230_2.Y]
E_um = 8
A_uni_um = 10.5

[iso230_2.X]
A_um = 12
R_um = 5

[iso230_4]
G_um = 15

[iso230_4.ZX]
G_um = 12

[parameters]
EC0Y = { max_abs_urad = 20 }
"EXX" = { max_abs_um = 4.5 }
"#;

#[test]
fn a_file_is_read_into_its_tolerances() {
    let t = parse(FULL).unwrap();
    assert_eq!(t.rule, DecisionRule::Simple);
    assert_eq!(t.coverage, Some(2.0));
    let axis = |axis: &str, value, limit_um| AxisTolerance {
        axis: axis.into(),
        value,
        limit_um,
    };
    // Axes in file order; a `_uni_` tolerance limits both directions.
    assert_eq!(
        t.iso230_2,
        [
            axis("Y", Iso230_2Value::E, 8.0),
            axis("Y", Iso230_2Value::AUp, 10.5),
            axis("Y", Iso230_2Value::ADown, 10.5),
            axis("X", Iso230_2Value::A, 12.0),
            axis("X", Iso230_2Value::R, 5.0),
        ]
    );
    assert_eq!(
        t.iso230_4,
        [
            CircleTolerance {
                plane: None,
                limit_um: 15.0
            },
            CircleTolerance {
                plane: Some("ZX".into()),
                limit_um: 12.0
            },
        ]
    );
    let names: Vec<(&str, f64, ParameterUnit, usize, usize)> = t
        .parameters
        .iter()
        .map(|p| (p.name.as_str(), p.limit, p.unit, p.at.line, p.at.column))
        .collect();
    assert_eq!(
        names,
        [
            ("EC0Y", 20.0, ParameterUnit::Urad, 20, 1),
            ("EXX", 4.5, ParameterUnit::Um, 21, 1),
        ]
    );
    assert_eq!(t.iso230_2[0].value.metric_name(), "E (ISO 230-2)");
    // The defaults: ISO 14253-1, each uncertainty as reported.
    let t = parse("[iso230_4]\nG_um = 15\n").unwrap();
    assert_eq!((t.rule, t.coverage), (DecisionRule::Iso14253_1, None));
}

#[test]
fn unknown_keys_are_refused_where_they_are_with_the_keys_expected() {
    assert_eq!(
        refused("[iso230_4]\nG_um = 15\n\n[iso230_2.X]\nE_um = 8\nEE_um = 3\n"),
        "acc.toml:6:1: unknown key `EE_um` in [iso230_2.X]; expected one of: A_um, E_um, R_um, \
         M_um, B_um, A_uni_um, E_uni_um, R_uni_um"
    );
    assert_eq!(
        refused("[iso230_2.Q]\nE_um = 8\n"),
        "acc.toml:1:11: unknown key `Q` in [iso230_2]; expected one of: X, Y, Z, U, V, W"
    );
    assert_eq!(
        refused("decision = \"simple\"\n[iso230_4]\nG_um = 1\n"),
        "acc.toml:1:1: unknown key `decision` at the top level; expected one of: schema, \
         decision_rule, coverage, iso230_2, iso230_4, parameters"
    );
    assert_eq!(
        refused("[iso230_4.XZ]\nG_um = 1\n"),
        "acc.toml:1:11: unknown key `XZ` in [iso230_4]; expected one of: G_um, XY, YZ, ZX"
    );
    assert_eq!(
        refused("[parameters]\nEC0Y = { max_urad = 20 }\n"),
        "acc.toml:2:10: unknown key `max_urad` in a [parameters] entry; expected one of: \
         max_abs_um, max_abs_urad"
    );
}

#[test]
fn wrong_values_are_refused_at_the_value() {
    assert_eq!(
        refused("[iso230_2.X]\nE_um = \"8\"\n"),
        "acc.toml:2:8: `iso230_2.X.E_um` must be a number (a tolerance ≥ 0), found a string"
    );
    assert_eq!(
        refused("[iso230_2.X]\nE_um = -8\n"),
        "acc.toml:2:8: `iso230_2.X.E_um` must be a tolerance ≥ 0 (an upper limit), found -8"
    );
    assert_eq!(
        refused("[iso230_4.XY]\nG_um = nan\n"),
        "acc.toml:2:8: `iso230_4.XY.G_um` must be a tolerance ≥ 0 (an upper limit), found nan"
    );
    assert_eq!(
        refused("decision_rule = \"guard\"\n[iso230_4]\nG_um = 1\n"),
        "acc.toml:1:17: decision_rule \"guard\" is not known; expected \"iso14253-1\" (guard \
         bands of U, the default) or \"simple\" (no guard band)"
    );
    assert_eq!(
        refused("coverage = 0\n[iso230_4]\nG_um = 1\n"),
        "acc.toml:1:12: coverage must be a coverage factor k from above 0 to 10 (2 for about \
         95 %), found 0"
    );
    assert_eq!(
        refused("schema = \"mtcal.tolerances/1\"\n[iso230_4]\nG_um = 1\n"),
        "acc.toml:1:10: schema \"mtcal.tolerances/1\" is not supported: this version of mtcal \
         reads \"mtcal.acceptance/1\""
    );
    assert_eq!(
        refused("[parameters]\nEC0Y = { max_abs_um = 1, max_abs_urad = 20 }\n"),
        "acc.toml:2:41: [parameters] `EC0Y` gives both max_abs_um and max_abs_urad; a parameter \
         has one unit"
    );
    assert_eq!(
        refused("[parameters]\nEC0Y = {}\n"),
        "acc.toml:2:8: [parameters] `EC0Y` needs its tolerance: max_abs_um (a length) or \
         max_abs_urad (an angle)"
    );
    assert_eq!(
        refused("[parameters]\nEC0Y = 20\n"),
        "acc.toml:2:8: a [parameters] entry must be a table such as { max_abs_urad = 20 }, found \
         an integer"
    );
}

#[test]
fn a_file_without_tolerances_or_not_toml_is_refused() {
    assert_eq!(
        refused("decision_rule = \"simple\"\n"),
        "acc.toml:1:1: this acceptance file sets no tolerance: give [iso230_2.<axis>] values, \
         [iso230_4] G_um or [parameters] (docs/ACCEPTANCE.md)"
    );
    assert_eq!(
        refused("[iso230_2.X]\n"),
        "acc.toml:1:1: [iso230_2.X] sets no tolerance; give one or more of: A_um, E_um, R_um, \
         M_um, B_um, A_uni_um, E_uni_um, R_uni_um"
    );
    assert!(refused("[iso230_4\nG_um = 1\n").starts_with("acc.toml:1:10: "));
    let missing = Tolerances::read(Path::new("/nonexistent/acc.toml")).unwrap_err();
    assert!(
        missing
            .to_string()
            .starts_with("/nonexistent/acc.toml: cannot read"),
        "{missing}"
    );
}

#[test]
fn parameter_names_are_checked_against_the_model_at_their_place() {
    let t =
        parse("[parameters]\nEC0Y = { max_abs_urad = 20 }\nEXX = { max_abs_urad = 3 }\n").unwrap();
    let model = |name: &str| match name {
        "EC0Y" => Some("urad".to_string()),
        "EXX" | "EXX.P1" => Some("um".to_string()),
        _ => None,
    };
    assert_eq!(
        t.check_parameters(&model).unwrap_err().to_string(),
        "acc.toml:3:1: [parameters] `EXX` is in um, its tolerance `max_abs_urad` in urad; use \
         max_abs_um"
    );
    let t = parse("[parameters]\nEC0X = { max_abs_urad = 20 }\n").unwrap();
    let e = t.check_parameters(&model).unwrap_err().to_string();
    assert!(
        e.starts_with("acc.toml:2:1: [parameters] `EC0X` is not a parameter of this session's"),
        "{e}"
    );
    let t = parse("[parameters]\nEC0Y = { max_abs_urad = 20 }\n").unwrap();
    assert!(t.check_parameters(&model).is_ok());
}

#[test]
fn the_shipped_examples_are_read() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/acceptance");
    let mut read = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let t = Tolerances::read(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(
                !t.is_empty() && t.rule == DecisionRule::Iso14253_1,
                "{}",
                path.display()
            );
            read += 1;
        }
    }
    assert_eq!(read, 2);
}
