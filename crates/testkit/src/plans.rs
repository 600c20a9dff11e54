//! Simulation plans (`cargo xtask simulate`'s TOML) that several identification tests fit: the
//! R-test and ball-bar runs about the five-axis trunnion's rotary axes, and the ball-bar
//! circles in three planes. A run's noise is a number or a placeholder the test replaces
//! (`NOISE`; [`with_noise`] fills `NOISE_RTEST` and `NOISE_BALLBAR`).

/// One `[[run]]` table of a plan: its name, instrument and set-up, then the lines added in the
/// order they are given, then its path ([`Run::path`] ends it).
#[derive(Debug, Clone)]
pub struct Run {
    text: String,
}

impl Run {
    pub fn new(name: &str, instrument: &str, setup: &str) -> Run {
        Run {
            text: format!(
                "[[run]]\nname = \"{name}\"\ninstrument = \"{instrument}\"\nsetup = \"{setup}\"\n"
            ),
        }
    }

    /// `noise = …`: a number (µm) or a placeholder.
    pub fn noise(mut self, noise: &str) -> Run {
        self.text += &format!("noise = {noise}\n");
        self
    }

    /// `noise = …` if `noise` is given; the run is noise-free otherwise.
    pub fn noise_if(self, noise: Option<&str>) -> Run {
        match noise {
            Some(n) => self.noise(n),
            None => self,
        }
    }

    /// `use = "validate"`: predicted by the fit, not fitted.
    pub fn validation(mut self) -> Run {
        self.text += "use = \"validate\"\n";
        self
    }

    /// The table, ending with `path = …` (an inline TOML table).
    pub fn path(self, path: &str) -> String {
        self.text + &format!("path = {path}\n")
    }
}

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
/// three planes): C and A swept with the bar radial, tangential and axial, runs named `b-…`;
/// noise `NOISE_BALLBAR`.
pub fn ballbar() -> String {
    format!(
        "\n{BALLBAR_PIVOTS}{BALLBAR_CIRCLES}{}{}",
        ballbar_rotary_runs("b-", "NOISE_BALLBAR", false),
        ballbar_circle_runs("b-", "circles", "NOISE_BALLBAR")
    )
}

/// `plan` with its noise placeholders filled (µm).
pub fn with_noise(plan: &str, rtest_um: f64, ballbar_um: f64) -> String {
    plan.replace("NOISE_RTEST", &format!("{rtest_um:?}"))
        .replace("NOISE_BALLBAR", &format!("{ballbar_um:?}"))
}

/// The ball-bar set-ups of the five-axis rotary tests: pivot `p1` on the table off C's axis,
/// `p2` off A's, both pivots and the tool length calibrated.
pub const BALLBAR_PIVOTS: &str = "[setup.p1]
pivot = [100.0, 0.0, 250.0]
length = 100.0
pivot_free = false
tool_length_free = false
[setup.p2]
pivot = [0.0, 100.0, 300.0]
length = 100.0
pivot_free = false
tool_length_free = false
";

/// The ball-bar set-up `circles` of the ISO 230-4 circles: a free pivot, the tool length held.
pub const BALLBAR_CIRCLES: &str = "[setup.circles]
pivot = [0.0, 0.0, 250.0]
length = 100.0
tool_length_free = false
";

/// The five-axis ball-bar tests about [`BALLBAR_PIVOTS`]: C swept a full turn about `p1` and A
/// from −30° to 60° about `p2`, each with the bar radial, tangential and axial (runs
/// `{prefix}c-radial` …); with `tilted` also C with the bar radial at A = 30°
/// (`{prefix}c-radial-a30`), which tells A's errors from C's.
pub fn ballbar_rotary_runs(prefix: &str, noise: &str, tilted: bool) -> String {
    let mut runs = String::new();
    for (axis, setup, sweep, samples) in [
        ("c", "p1", "C = [0.0, 360.0]", 73),
        ("a", "p2", "A = [-30.0, 60.0]", 61),
    ] {
        for bar in ["radial", "tangential", "axial"] {
            runs += &Run::new(&format!("{prefix}{axis}-{bar}"), "ballbar", setup)
                .noise(noise)
                .path(&format!(
                    "{{ kind = \"rotary\", sweep = {{ {sweep} }}, bar = \"{bar}\", samples = {samples} }}"
                ));
        }
    }
    if tilted {
        runs += &Run::new(&format!("{prefix}c-radial-a30"), "ballbar", "p1")
            .noise(noise)
            .path(
                "{ kind = \"rotary\", sweep = { C = [0.0, 360.0] }, hold = { A = 30.0 }, bar = \"radial\", samples = 73 }",
            );
    }
    runs
}

/// ISO 230-4 circles of the ball-bar set-up `setup` (radius 100 mm): a full circle in XY, the
/// upper halves in YZ and ZX (the bar cannot swing through the pivot's stand); runs
/// `{prefix}xy`, `{prefix}yz`, `{prefix}zx`.
pub fn ballbar_circle_runs(prefix: &str, setup: &str, noise: &str) -> String {
    [
        ("xy", "{ kind = \"circle\", plane = \"XY\", samples = 91 }"),
        (
            "yz",
            "{ kind = \"circle\", plane = \"YZ\", samples = 61, start_deg = 0.0, sweep_deg = 180.0 }",
        ),
        (
            "zx",
            "{ kind = \"circle\", plane = \"ZX\", samples = 61, start_deg = -90.0, sweep_deg = 180.0 }",
        ),
    ]
    .into_iter()
    .map(|(plane, path)| {
        Run::new(&format!("{prefix}{plane}"), "ballbar", setup)
            .noise(noise)
            .path(path)
    })
    .collect()
}

/// The R-test runs of the trunnion's eleven-error tests (`coverage.rs`, `planted_truth.rs`,
/// `search.rs`): [`rtest_low_high_runs`] with each ball calibrated.
pub fn rtest_low_high(xyc: usize, yza: usize, noise: Option<&str>) -> String {
    String::from(
        "[setup.low]\nball = [100.0, 0.0, 200.0]\nball_free = false\ntool_length_free = false\n\
         [setup.high]\nball = [100.0, 0.0, 300.0]\nball_free = false\ntool_length_free = false\n",
    ) + &rtest_low_high_runs(xyc, yza, noise)
}

/// R-test runs about the trunnion's rotary axes: XYC at A = 0 and ±30° and YZA with the ball of
/// set-up `low`, XYC with the ball of `high`; `xyc` and `yza` samples per run, and a
/// `noise = …` line in every run when `noise` is given (a number or a placeholder).
pub fn rtest_low_high_runs(xyc: usize, yza: usize, noise: Option<&str>) -> String {
    let xyc_path = |hold: &str| format!("{{ kind = \"xyc\", samples = {xyc}{hold} }}");
    let mut runs = String::new();
    for (name, setup, path) in [
        ("xyc-a0", "low", xyc_path("")),
        ("xyc-a+30", "low", xyc_path(", hold = { A = 30.0 }")),
        ("xyc-a-30", "low", xyc_path(", hold = { A = -30.0 }")),
        (
            "yza",
            "low",
            format!("{{ kind = \"yza\", samples = {yza} }}"),
        ),
        ("xyc-high", "high", xyc_path("")),
    ] {
        runs += &Run::new(name, "rtest", setup).noise_if(noise).path(&path);
    }
    runs
}
