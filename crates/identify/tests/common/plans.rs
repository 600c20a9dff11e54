//! Test plans shared by the tests of identification across instruments (`joint.rs`,
//! `mixed_instruments.rs`): R-test and ball-bar runs about the five-axis trunnion's rotary axes.
//! `NOISE_RTEST` and `NOISE_BALLBAR` stand for each run's noise (µm); [`with_noise`] fills them.

#![allow(dead_code)]

/// R-test (calibrated ball and tool length): XYC at A = 0 and 30°, YZA.
pub const RTEST: &str = r#"
[setup.ball]
ball = [100.0, 0.0, 200.0]
ball_free = false
tool_length_free = false
[[run]]
name = "r-xyc"
instrument = "rtest"
setup = "ball"
noise = NOISE_RTEST
path = { kind = "xyc", samples = 37 }
[[run]]
name = "r-xyc-a30"
instrument = "rtest"
setup = "ball"
noise = NOISE_RTEST
path = { kind = "xyc", samples = 37, hold = { A = 30.0 } }
[[run]]
name = "r-yza"
instrument = "rtest"
setup = "ball"
noise = NOISE_RTEST
path = { kind = "yza", samples = 31 }
"#;

/// Ball-bar (calibrated pivots for the rotary tests, a free pivot for the ISO 230-4 circles in
/// three planes): C and A swept with the bar radial, tangential and axial.
pub const BALLBAR: &str = r#"
[setup.p1]
pivot = [100.0, 0.0, 250.0]
length = 100.0
pivot_free = false
tool_length_free = false
[setup.p2]
pivot = [0.0, 100.0, 300.0]
length = 100.0
pivot_free = false
tool_length_free = false
[setup.circles]
pivot = [0.0, 0.0, 250.0]
length = 100.0
tool_length_free = false
[[run]]
name = "b-c-radial"
instrument = "ballbar"
setup = "p1"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { C = [0.0, 360.0] }, bar = "radial", samples = 73 }
[[run]]
name = "b-c-tangential"
instrument = "ballbar"
setup = "p1"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { C = [0.0, 360.0] }, bar = "tangential", samples = 73 }
[[run]]
name = "b-c-axial"
instrument = "ballbar"
setup = "p1"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { C = [0.0, 360.0] }, bar = "axial", samples = 73 }
[[run]]
name = "b-a-radial"
instrument = "ballbar"
setup = "p2"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { A = [-30.0, 60.0] }, bar = "radial", samples = 61 }
[[run]]
name = "b-a-tangential"
instrument = "ballbar"
setup = "p2"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { A = [-30.0, 60.0] }, bar = "tangential", samples = 61 }
[[run]]
name = "b-a-axial"
instrument = "ballbar"
setup = "p2"
noise = NOISE_BALLBAR
path = { kind = "rotary", sweep = { A = [-30.0, 60.0] }, bar = "axial", samples = 61 }
[[run]]
name = "b-xy"
instrument = "ballbar"
setup = "circles"
noise = NOISE_BALLBAR
path = { kind = "circle", plane = "XY", samples = 91 }
[[run]]
name = "b-yz"
instrument = "ballbar"
setup = "circles"
noise = NOISE_BALLBAR
path = { kind = "circle", plane = "YZ", samples = 61, start_deg = 0.0, sweep_deg = 180.0 }
[[run]]
name = "b-zx"
instrument = "ballbar"
setup = "circles"
noise = NOISE_BALLBAR
path = { kind = "circle", plane = "ZX", samples = 61, start_deg = -90.0, sweep_deg = 180.0 }
"#;

/// `plan` with its noise placeholders filled (µm).
pub fn with_noise(plan: &str, rtest_um: f64, ballbar_um: f64) -> String {
    plan.replace("NOISE_RTEST", &format!("{rtest_um:?}"))
        .replace("NOISE_BALLBAR", &format!("{ballbar_um:?}"))
}

/// The R-test runs of the trunnion's eleven-error tests (`coverage.rs`, `planted_truth.rs`,
/// `search.rs`): XYC at A = 0 and ±30° and YZA with the ball low, XYC with it high, each ball
/// calibrated; `xyc` and `yza` samples per run, and a `noise = …` line in every run when `noise`
/// is given (a number or a placeholder the caller replaces).
pub fn rtest_low_high(xyc: usize, yza: usize, noise: Option<&str>) -> String {
    let noise = noise.map_or(String::new(), |n| format!("noise = {n}\n"));
    let run = |name: &str, setup: &str, path: String| {
        format!(
            "[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\n{noise}path = {path}\n"
        )
    };
    let mut plan = String::from(
        "[setup.low]\nball = [100.0, 0.0, 200.0]\nball_free = false\ntool_length_free = false\n\
         [setup.high]\nball = [100.0, 0.0, 300.0]\nball_free = false\ntool_length_free = false\n",
    );
    plan += &run(
        "xyc-a0",
        "low",
        format!("{{ kind = \"xyc\", samples = {xyc} }}"),
    );
    for (name, a) in [("xyc-a+30", "30.0"), ("xyc-a-30", "-30.0")] {
        plan += &run(
            name,
            "low",
            format!("{{ kind = \"xyc\", samples = {xyc}, hold = {{ A = {a} }} }}"),
        );
    }
    plan += &run(
        "yza",
        "low",
        format!("{{ kind = \"yza\", samples = {yza} }}"),
    );
    plan += &run(
        "xyc-high",
        "high",
        format!("{{ kind = \"xyc\", samples = {xyc} }}"),
    );
    plan
}
