//! Numerical edge cases of the identification (issue 7): a single sample, readings that are
//! all exactly zero, parameters the runs hardly see. Every number in the result is finite,
//! unidentifiable parameters have no value, and parameters the runs barely determine are
//! listed in `weakly_determined`. (The command-line side, with singular poses and priors:
//! `xtask/tests/suite/edge_cases.rs`.)

use mtcal_identify::{Identification, identify_session};
use mtcal_testkit::repo;
use std::path::{Path, PathBuf};

/// A plan on the five-axis trunnion with the example's truth and these runs.
fn simulate(dir: &Path, parameters: &str, runs: &str) -> PathBuf {
    simulate_with(dir, parameters, runs, &[])
}

/// [`simulate`], then each run file cut to its first `keep[k]` samples (by position).
fn simulate_with(dir: &Path, parameters: &str, runs: &str, keep: &[(&str, usize)]) -> PathBuf {
    let repo = repo();
    let plan = dir.join("plan.toml");
    std::fs::write(
        &plan,
        format!(
            "machine = \"{}\"\ntruth = \"{}\"\nseed = 11\ninterval_s = 0.25\n\
             [identify]\nparameters = [{parameters}]\n\
             [setup.ball]\nball = [100.0, 0.0, 200.0]\n{runs}",
            repo.join("machines/mcu630-cafyxz.urdf").display(),
            repo.join("examples/five-axis/truth.params.toml").display(),
        ),
    )
    .unwrap();
    let session = dir.join("session");
    mtcal_simulate::simulate(&plan, &session).unwrap();
    for (run, n) in keep {
        let p = session.join(format!("{run}.csv"));
        let text = std::fs::read_to_string(&p).unwrap();
        let lines: Vec<&str> = text.lines().take(1 + n).collect();
        std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    }
    session
}

/// Every number finite; no unidentifiable parameter among the valued ones; the JSON has no
/// `null` (serde_json's NaN) and reads back.
fn assert_sane(id: &Identification) {
    let unid: Vec<&String> = id
        .unidentifiable
        .iter()
        .flat_map(|u| &u.parameters)
        .collect();
    for p in &id.parameters {
        assert!(
            p.value.is_finite() && p.u95.is_finite() && p.u95 >= 0.0,
            "{p:?}"
        );
        assert!(!unid.contains(&&p.name), "{} has a value", p.name);
    }
    assert!(id.fit.rms_um.is_finite() && id.fit.chi2_reduced.is_finite());
    assert!(id.solver.condition_number.is_finite());
    for c in &id.component_errors {
        assert!(
            c.samples.iter().flatten().all(|v| v.is_finite()),
            "{}",
            c.name
        );
    }
    let json = mtcal_identify::report::IdentifyJson::of(id).to_json();
    assert!(!json.contains("null"), "{json}");
    let _: serde_json::Value = serde_json::from_str(&json).unwrap();
    let summary = id.summary();
    assert!(
        !summary.contains("NaN") && !summary.contains("inf "),
        "{summary}"
    );
}

#[test]
fn one_sample_identifies_nothing_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let session = simulate_with(
        dir.path(),
        "\"EC0Y\", \"EY0A\", \"EX0C\", \"EY0C\"",
        "[[run]]\nname = \"one\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"xyc\", samples = 2 }\n",
        &[("one", 1)],
    );
    let (_, id) = identify_session(&session).unwrap();
    assert_sane(&id);
    let unid: Vec<&String> = id
        .unidentifiable
        .iter()
        .flat_map(|u| &u.parameters)
        .collect();
    for p in ["EC0Y", "EY0A", "EX0C", "EY0C"] {
        assert!(unid.iter().any(|u| *u == p), "{p}:\n{}", id.summary());
    }
    assert_eq!(id.fit.dof, 0);
}

#[test]
fn all_zero_readings_give_zero_errors_with_intervals() {
    let dir = tempfile::tempdir().unwrap();
    let session = simulate(
        dir.path(),
        "\"EY0A\", \"EB0A\", \"EC0A\", \"EX0C\", \"EY0C\", \"EA0C\", \"EB0C\"",
        "[[run]]\nname = \"a0\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"xyc\", samples = 37 }\n\
         [[run]]\nname = \"a30\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"xyc\", samples = 37, hold = { A = 30.0 } }\n\
         [[run]]\nname = \"yza\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"yza\", samples = 31 }\n",
    );
    // Every reading replaced by an exact zero.
    for e in std::fs::read_dir(&session).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "csv") {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        let header = lines.next().unwrap();
        let cols: Vec<&str> = header.split(',').collect();
        let mut out = format!("{header}\n");
        for line in lines {
            let cells: Vec<&str> = line
                .split(',')
                .zip(&cols)
                .map(|(v, c)| if c.starts_with('d') { "0" } else { v })
                .collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        std::fs::write(&p, out).unwrap();
    }
    let (_, id) = identify_session(&session).unwrap();
    assert_sane(&id);
    assert!(id.solver.converged, "{:?}\n{}", id.solver, id.summary());
    assert!(!id.parameters.is_empty());
    for p in &id.parameters {
        assert!(p.value.abs() < 1e-6 && p.u95 > 0.0, "{p:?}");
    }
}

/// R-test runs at A = 0 and A = 0.01°: the A axis' location errors act only through a
/// hundredth of a degree of A. The solver's relative rank rule keeps them (intervals near a
/// millimetre); the identification lists them as weakly determined and leaves the C axis'
/// well-determined ones alone.
#[test]
fn parameters_the_runs_hardly_see_are_weakly_determined() {
    let dir = tempfile::tempdir().unwrap();
    let session = simulate(
        dir.path(),
        "\"EY0A\", \"EZ0A\", \"EB0A\", \"EC0A\", \"EX0C\", \"EY0C\", \"EA0C\", \"EB0C\"",
        "[[run]]\nname = \"a0\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"xyc\", samples = 73 }\n\
         [[run]]\nname = \"a-small\"\ninstrument = \"rtest\"\nsetup = \"ball\"\n\
         path = { kind = \"xyc\", samples = 73, hold = { A = 0.01 } }\n",
    );
    let (_, id) = identify_session(&session).unwrap();
    assert_sane(&id);
    let weak: Vec<&String> = id
        .weakly_determined
        .iter()
        .flat_map(|w| &w.parameters)
        .collect();
    let valued = |n: &str| id.parameters.iter().find(|p| p.name == n);
    for p in ["EY0A", "EB0A", "EC0A"] {
        // Identified (a number), but flagged.
        if let Some(v) = valued(p) {
            assert!(v.u95 > 100.0, "{v:?}");
            assert!(weak.iter().any(|w| *w == p), "{p}:\n{}", id.summary());
        }
    }
    for p in ["EA0C", "EB0C"] {
        assert!(valued(p).is_some_and(|v| v.u95 < 10.0), "{}", id.summary());
        assert!(!weak.iter().any(|w| *w == p), "{p}:\n{}", id.summary());
    }
    assert!(
        mtcal_identify::report::IdentifyJson::of(&id)
            .to_json()
            .contains("\"weakly_determined\"")
    );
    assert!(id.summary().contains("weakly determined"));
}

/// The shipped example has no weakly determined parameter: the key is absent from its JSON.
#[test]
fn a_well_designed_session_has_nothing_weakly_determined() {
    let (_, id) = identify_session(&repo().join("examples/five-axis/session")).unwrap();
    assert_sane(&id);
    assert!(id.weakly_determined.is_empty(), "{}", id.summary());
    assert!(
        !mtcal_identify::report::IdentifyJson::of(&id)
            .to_json()
            .contains("weakly_determined")
    );
}
