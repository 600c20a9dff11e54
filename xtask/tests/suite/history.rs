//! `mtcal history`: campaigns of the bundled examples added to an SQLite history (from a session
//! and from an identify JSON), listed, shown, trended and set against tolerances; the digests
//! say which files a campaign came from. The store's own suite (both back ends, two processes,
//! a killed writer, bad databases) is in crates/history/tests.

use mtcal_testkit::cli::{assert_success, run_in_repo};
use std::path::Path;

fn mtcal(args: &[&str]) -> std::process::Output {
    run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

/// `history … --db DB --json`, parsed.
fn json(db: &Path, args: &[&str]) -> serde_json::Value {
    let mut all = vec!["history"];
    all.extend_from_slice(args);
    all.extend(["--db", db.to_str().unwrap(), "--json"]);
    let out = mtcal(&all);
    assert_success(&out);
    serde_json::from_slice(&out.stdout).expect("JSON")
}

#[test]
fn campaigns_are_kept_listed_trended_and_set_against_tolerances() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("history.sqlite");
    let db_arg = db.to_str().unwrap();
    let session = "examples/three-axis/session";
    // Two campaigns from the session, one from its identify JSON.
    for date in ["2026-01-10", "2026-04-10"] {
        let out = mtcal(&[
            "history",
            "add",
            session,
            "--machine",
            "mill-3",
            "--date",
            date,
            "--db",
            db_arg,
        ]);
        assert_success(&out);
        let said = String::from_utf8_lossy(&out.stdout);
        assert!(
            said.starts_with("added campaign") && said.contains(date),
            "{said}"
        );
    }
    let result = dir.path().join("result.json");
    assert_success(&mtcal(&[
        "identify",
        session,
        "--quiet",
        "--json",
        result.to_str().unwrap(),
    ]));
    let added = json(
        &db,
        &[
            "add",
            result.to_str().unwrap(),
            "--machine",
            "mill-3",
            "--date",
            "2026-07-01",
        ],
    );
    assert_eq!(added["added"], 3);

    let machines = json(&db, &["list"]);
    assert_eq!(machines[0]["name"], "mill-3");
    assert_eq!(machines[0]["campaigns"], 3);

    // A session's campaign records the digests of its files; the JSON's cannot.
    let shown = json(&db, &["show", "mill-3"]);
    let rows = shown.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    let digest = |k: usize| rows[k]["session_digest"].as_str().map(str::to_string);
    assert!(digest(0).unwrap().starts_with("sha256:"));
    assert_eq!(digest(0), digest(1), "the same session, the same digest");
    assert_eq!(digest(2), None);
    assert!(
        rows[0]["machine"]["urdf_digest"]
            .as_str()
            .unwrap()
            .starts_with("sha256:")
    );

    // EC0Y is 5.52 ± 0.77 µrad in every campaign: no change, and beyond a 3 µrad tolerance by
    // more than its U.
    let tolerances = dir.path().join("tolerances.toml");
    std::fs::write(
        &tolerances,
        "schema = \"mtcal.acceptance/1\"\n[parameters]\nEC0Y = { max_abs_urad = 3 }\n",
    )
    .unwrap();
    let tol = tolerances.to_str().unwrap();
    let trend = json(
        &db,
        &["trend", "mill-3", "--param", "EC0Y", "--tolerances", tol],
    );
    let view = &trend[0];
    assert_eq!(view["points"].as_array().unwrap().len(), 3);
    assert_eq!(view["trend"]["verdict"], "NoChange");
    let value = view["points"][0]["value"].as_f64().unwrap();
    assert!((value - 5.52).abs() < 0.05, "{value}");
    assert_eq!(view["trend"]["tolerance"]["first_out"], 0);
    let fleet = json(&db, &["fleet", "--tolerances", tol]);
    assert_eq!(fleet[0]["machine"], "mill-3");
    assert_eq!(fleet[0]["out_of_tolerance"], serde_json::json!(["EC0Y"]));

    // The text a person reads: the verdict first, then the series.
    let out = mtcal(&[
        "history",
        "trend",
        "mill-3",
        "--param",
        "EC0Y",
        "--tolerances",
        tol,
        "--db",
        db_arg,
    ]);
    assert_success(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = text.lines().collect();
    assert!(
        lines[0].starts_with("EC0Y of mill-3: 3 campaigns"),
        "{text}"
    );
    assert!(text.contains("verdict: no significant change"), "{text}");
    assert!(
        text.contains("tolerance |value| ≤ 3 urad: crossed"),
        "{text}"
    );

    // One check on its day is no warm-up trajectory, and says why.
    let thermal = json(&db, &["thermal", "mill-3", "--param", "EC0Y"]);
    assert_eq!(thermal[0]["day"], "2026-07-01");
    assert_eq!(thermal[0]["checks"], 1);
    let why = thermal[0]["not_determined"].as_str().unwrap();
    assert!(why.contains("1 checks"), "{why}");

    // Superseding keeps both and says so.
    assert_success(&mtcal(&[
        "history",
        "supersede",
        "1",
        "--by",
        "2",
        "--reason",
        "wrong tool length",
        "--db",
        db_arg,
    ]));
    let shown = json(&db, &["show", "mill-3"]);
    assert_eq!(shown[0]["superseded"]["by"], 2);
    assert_eq!(shown.as_array().unwrap().len(), 3);
}
