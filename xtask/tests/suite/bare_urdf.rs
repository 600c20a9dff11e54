//! A user with a bare URDF and a session another program wrote (the independent simulator's
//! three-axis ball-bar test, no `.errors.toml`, no `[identify]`): `mtcal identify` converges,
//! names what the circles see only in combination, gives no number to what they cannot see,
//! writes the model they identify (`--suggest-model`), and that model, kept beside the URDF,
//! gives the same squareness combination with nothing left that the runs cannot see but its
//! own members.

use mtcal_indsim::{Campaign, Realism};
use std::path::Path;
use std::process::Command;

fn identify(dir: &Path, extra: &[&str]) -> (String, serde_json::Value) {
    let json = dir.join("out.json");
    let out = Command::new(env!("CARGO_BIN_EXE_mtcal"))
        .args(["identify", "--quiet", "--json"])
        .arg(&json)
        .args(extra)
        .arg(dir.join("session"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    let value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (text, value)
}

/// EC0Y's number: alone, or the combination it carries.
fn ec0y(json: &serde_json::Value) -> (f64, f64) {
    let pick = |list: &str| {
        json[list].as_array().and_then(|a| {
            a.iter()
                .find(|p| p["name"] == "EC0Y")
                .map(|p| (p["value"].as_f64().unwrap(), p["u95"].as_f64().unwrap()))
        })
    };
    pick("parameters")
        .or_else(|| pick("combinations"))
        .unwrap_or_else(|| panic!("EC0Y has no number: {json:#}"))
}

#[test]
fn a_bare_urdf_ball_bar_session_and_the_model_it_suggests() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let session = dir.join("session");
    Campaign::three_axis_ballbar(&session, 5, &Realism::realistic(5)).unwrap();
    // The machine copied beside the session without its .errors.toml: the full ISO model.
    let manifest = session.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let line = text.lines().find(|l| l.starts_with("machine")).unwrap();
    let urdf = session.join(line.split('"').nth(1).unwrap());
    std::fs::copy(&urdf, session.join("m.urdf")).unwrap();
    std::fs::write(&manifest, text.replace(line, "machine = \"m.urdf\"")).unwrap();

    let suggested = session.join("m.errors.toml.suggested");
    let (text, json) = identify(dir, &["--suggest-model", suggested.to_str().unwrap()]);
    let first = text.lines().nth(1).unwrap();
    assert!(first.starts_with("model: "), "{text}");
    assert!(!text.contains("NOT"), "{text}");
    assert!(text.contains("identified combinations"), "{text}");
    assert!(text.contains("circular deviation G (ISO 230-4)"), "{text}");
    assert!(
        text.lines().count() <= 60,
        "{} lines:\n{text}",
        text.lines().count()
    );
    // What the circles cannot see has no number anywhere in the JSON.
    let held: Vec<&str> = json["held"]
        .as_array()
        .unwrap()
        .iter()
        .map(|h| h["name"].as_str().unwrap())
        .collect();
    assert!(
        held.contains(&"EZZ.P1"),
        "a Z positioning error from an XY circle: {held:?}"
    );
    for p in json["parameters"].as_array().unwrap() {
        assert!(!held.contains(&p["name"].as_str().unwrap()), "{p}");
    }
    let (before, u_before) = ec0y(&json);

    // The suggested model beside the URDF: a model these runs identify.
    std::fs::rename(&suggested, session.join("m.errors.toml")).unwrap();
    let (text, json) = identify(dir, &[]);
    assert!(!text.contains("NOT"), "{text}");
    let held_now = json["held"].as_array().map_or(0, Vec::len);
    assert!(held_now < held.len() / 4, "{held_now} still held:\n{text}");
    let (after, u_after) = ec0y(&json);
    assert!(
        (after - before).abs() <= u_before.max(u_after),
        "EC0Y {before} ± {u_before} then {after} ± {u_after}"
    );
}
