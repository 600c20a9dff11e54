//! Test plans write either R-test mount: `simulate` passes `mount` through to the session, the
//! readings are the plugin's for that mount, and the identification reads them back.

use mtcal_identify::identify_session;
use mtcal_session::{RunColumns, read_run};
use mtcal_simulate::simulate;
use std::path::Path;

const PLAN: &str = r#"
seed = 3
[identify]
parameters = ["EX0C", "EY0C"]
[setup.table]
ball = [150.0, 0.0, 200.0]
mount = "ball-on-table"
ball_free = false
tool_length_free = false
[setup.spindle]
ball = [150.0, 0.0, 200.0]
mount = "ball-in-spindle"
ball_free = false
tool_length_free = false
[setup.unsaid]
ball = [150.0, 0.0, 200.0]
ball_free = false
tool_length_free = false
[[run]]
name = "table"
instrument = "rtest"
setup = "table"
noise = 0.0
path = { kind = "xyc", samples = 5 }
[[run]]
name = "spindle"
instrument = "rtest"
setup = "spindle"
noise = 0.0
path = { kind = "xyc", samples = 5 }
[[run]]
name = "unsaid"
instrument = "rtest"
setup = "unsaid"
noise = 0.0
path = { kind = "xyc", samples = 5 }
"#;

/// Readings (µm) of a run, row by row.
fn readings(session: &Path, run: &str) -> Vec<[f64; 3]> {
    let table = read_run(
        &session.join(format!("{run}.csv")),
        &RunColumns {
            axes: &['X', 'Y', 'Z', 'A', 'C'],
            readings: &["dx", "dy", "dz"],
            readings_optional: false,
            labels: &[],
        },
    )
    .unwrap();
    let v = table.values.unwrap();
    v.chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
}

#[test]
fn a_plan_simulates_and_identifies_both_mounts() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let truth = dir.path().join("truth.params.toml");
    std::fs::write(
        &truth,
        "schema = \"mtcal.params/1\"\n[values]\nEX0C = 10.0\n",
    )
    .unwrap();
    let machine = repo.join("machines/mcu630-cafyxz.urdf");
    let plan = dir.path().join("plan.toml");
    std::fs::write(
        &plan,
        format!("machine = {machine:?}\ntruth = {truth:?}\n{PLAN}"),
    )
    .unwrap();
    let out = dir.path().join("session");
    simulate(&plan, &out).unwrap();

    // The session says which mount each set-up has; the one without `mount` stays without.
    let manifest: toml::Table =
        toml::from_str(&std::fs::read_to_string(out.join("session.toml")).unwrap()).unwrap();
    let mount = |s: &str| {
        manifest["setup"][s]
            .get("mount")
            .and_then(|v| v.as_str())
            .map(str::to_string)
    };
    assert_eq!(mount("table").as_deref(), Some("ball-on-table"));
    assert_eq!(mount("spindle").as_deref(), Some("ball-in-spindle"));
    assert_eq!(mount("unsaid"), None);

    // C = 0, 90, 180, 270, 360°. The shipped machine turns the table clockwise for +C, so
    // EX0C = +10 µm reads FORMATS.md's worked examples mirrored (docs/FORMATS.md, mtcal's
    // additions): ball on the table (+10, +10, 0) at 90°, ball in the spindle (+10, −10, 0).
    let want_table = [
        [0.0, 0.0, 0.0],
        [10.0, 10.0, 0.0],
        [20.0, 0.0, 0.0],
        [10.0, -10.0, 0.0],
    ];
    let want_spindle = [
        [0.0, 0.0, 0.0],
        [10.0, -10.0, 0.0],
        [20.0, 0.0, 0.0],
        [10.0, 10.0, 0.0],
    ];
    for (run, want) in [
        ("table", want_table),
        ("unsaid", want_table),
        ("spindle", want_spindle),
    ] {
        let got = readings(&out, run);
        assert_eq!(got.len(), 5);
        for (g, w) in got.iter().zip(&want) {
            for i in 0..3 {
                assert!((g[i] - w[i]).abs() < 1e-6, "{run}: {got:?}");
            }
        }
    }

    // The identification reads each set-up with its own mount: the noise-free truth back.
    let (_, id) = identify_session(&out).unwrap();
    for (name, value) in [("EX0C", 10.0), ("EY0C", 0.0)] {
        let p = id.parameters.iter().find(|p| p.name == name).unwrap();
        assert!((p.value - value).abs() < 1e-6, "{name}: {p:?}");
    }
    assert!(id.fit.rms_um < 1e-6, "{:?}", id.fit.rms_um);
}
