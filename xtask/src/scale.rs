//! `mtcal scale-bench N`: how identification scales with the number of samples (issue 7).
//!
//! Writes a test plan for a large session into a temporary folder, simulates it (nothing goes
//! into the repository), then identifies it in a child process — the same steps as
//! `mtcal identify --quiet` (load, fit, report with the mismatch analysis, information account)
//! — and prints the samples, the wall time of each step and the child's peak resident memory
//! (`VmHWM` of `/proc/self/status`, read by the child at the end). The child is separate so
//! that the simulation's own memory does not count. With `--search` the child runs the physics
//! search instead (`mtcal identify --search --quiet`: the fit, every candidate effect scored,
//! the significant ones refitted and cross-validated, prediction bands, information account).
//!
//! The session (`--layout rtest`, the default): the MCU 630 trunnion with the 11-error set of
//! the five-axis example, R-test sampled at 1 kHz (0.5 µm noise) in 6 runs of N/6 samples: XYC
//! at A = 0, +30° and −30° and YZA with the ball low, XYC and YZA with the ball high; ball
//! position and tool length free (above 6·10⁶ samples the six runs are repeated: the R-test
//! path takes at most 10⁶ samples). 10⁷ samples are 2.8 hours of recording; the CSV files take
//! about 150 bytes per sample on disk (1.5 GB at 10⁷), deleted afterwards unless `--keep`.
//! `--layout ballbar`: the three-axis ZFYX machine (MCV 754), ISO 230-4 ball-bar circles
//! (100 mm bar) in the XY, YZ and ZX planes, each clockwise and counter-clockwise, sampled at
//! 1 kHz (0.5 µm noise): the three squareness errors, pivot and tool length free.
//! `--layout laser`: the same machine, ISO 230-2 laser runs on X, Y and Z at 1 kHz with the air
//! logged (T_air, P_air, H_air) beside them: the three positioning errors (runs of at most 10⁶
//! samples: above 3·10⁶ the three runs are repeated).
//!
//! Every layout records its files as a controller and an instrument would (`[record]` of the
//! plan): positions to 0.1 µm and 0.0001°, readings to 0.0001 µm, times to 1 ms, air to three
//! decimals — not the 17 digits of a float, which no instrument writes. The study keeps such
//! columns as integers (`mtcal_session::Column`); full-precision files load too, at 8 bytes a
//! value.

use anyhow::{Context as _, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `scale-bench`.
#[derive(clap::Args, Debug)]
pub struct ScaleArgs {
    /// Number of samples of the simulated session.
    #[arg(default_value_t = 1_000_000)]
    samples: usize,
    /// `rtest` (five-axis trunnion, 3 readings and 5 axes per sample), `ballbar` (three-axis,
    /// 1 reading and 3 axes per sample) or `laser` (three-axis, 1 reading, 3 axes and 3 air
    /// columns per sample).
    #[arg(long, default_value = "rtest")]
    layout: String,
    /// Write the session to this folder and keep it (default: a temporary folder, deleted).
    #[arg(long)]
    keep: Option<PathBuf>,
    /// Run the physics search (`mtcal identify --search --quiet`: the fit, every candidate
    /// effect scored, the significant ones refitted and cross-validated) instead of the plain
    /// identification.
    #[arg(long)]
    search: bool,
    /// Identify this existing session and report (the child process' part).
    #[arg(long, hide = true)]
    session: Option<PathBuf>,
}

pub fn run(args: ScaleArgs, out: &mut impl Write) -> Result<()> {
    if let Some(dir) = &args.session {
        return identify_and_measure(dir, args.search, out);
    }
    let (dir, temporary) = match &args.keep {
        Some(d) => (d.clone(), false),
        None => (
            std::env::temp_dir().join(format!("mtcal-scale-{}", std::process::id())),
            true,
        ),
    };
    let result = generate_and_measure(&args, &dir, out);
    if temporary {
        let _ = std::fs::remove_dir_all(&dir);
    }
    result
}

fn generate_and_measure(args: &ScaleArgs, dir: &Path, out: &mut impl Write) -> Result<()> {
    let plan_dir = dir.join("plan");
    std::fs::create_dir_all(&plan_dir)
        .with_context(|| format!("cannot create {}", plan_dir.display()))?;
    let plan = write_plan(&args.layout, args.samples, &plan_dir)?;
    let session = dir.join("session");
    let start = Instant::now();
    let sim = mtcal_simulate::simulate(&plan, &session)?;
    writeln!(
        out,
        "simulated {} samples in {} runs ({:.1} s) into {}",
        sim.samples,
        sim.runs,
        start.elapsed().as_secs_f64(),
        session.display()
    )?;
    // The NC programs are not read by `identify`; they only take disk space.
    let _ = std::fs::remove_dir_all(session.join("programs"));
    out.flush()?;
    let exe = std::env::current_exe().context("cannot find the mtcal executable")?;
    let mut child = std::process::Command::new(exe);
    child.arg("scale-bench").arg("--session").arg(&session);
    if args.search {
        child.arg("--search");
    }
    let status = child.status().context("cannot start the identification")?;
    if !status.success() {
        bail!("the identification failed ({status})");
    }
    Ok(())
}

/// Loads and identifies `dir` as `mtcal identify --quiet` does (with `search`, as `mtcal
/// identify --search --quiet`), then prints the times and the peak resident memory.
fn identify_and_measure(dir: &Path, search: bool, out: &mut impl Write) -> Result<()> {
    let start = Instant::now();
    let study = mtcal_identify::Study::load(dir)?;
    let loaded = start.elapsed().as_secs_f64();
    let samples: usize = study.runs.iter().map(|r| r.len()).sum();
    let rss_loaded = status_kib("VmRSS");
    let (id, study, solution) = if search {
        physics_search(study, out)?
    } else {
        let options = mtcal_solve::Options::default();
        let (id, solution) =
            mtcal_identify::identify_with_solution(&study, &options, &mut mtcal_solve::Silent)?;
        (id, study, solution)
    };
    let fitted = start.elapsed().as_secs_f64();
    let peak_fitted = status_kib("VmHWM");
    let account = mtcal_identify::information::account(&study, &solution)?;
    let total = start.elapsed().as_secs_f64();
    std::hint::black_box((&id, &account));
    let peak = status_kib("VmHWM");
    writeln!(
        out,
        "identified {samples} samples: rms {:.3} um, {} passes, rank {}/{}",
        id.fit.rms_um, id.solver.passes, id.solver.rank, id.solver.parameters
    )?;
    writeln!(
        out,
        "time: load {loaded:.2} s, {} {:.2} s, information account {:.2} s, \
         total {total:.2} s ({:.2} us per sample)",
        if search { "search" } else { "fit and report" },
        fitted - loaded,
        total - fitted,
        total * 1e6 / samples as f64
    )?;
    if let (Some(peak), Some(loaded), Some(fit)) = (peak, rss_loaded, peak_fitted) {
        let mb = |kib: u64| kib as f64 * 1024.0 / 1e6;
        writeln!(
            out,
            "memory: {:.1} MB resident after loading, peak {:.1} MB to the end of the {}, \
             peak {:.1} MB in all ({:.1} bytes per sample)",
            mb(loaded),
            mb(fit),
            if search { "search" } else { "report" },
            mb(peak),
            peak as f64 * 1024.0 / samples as f64
        )?;
    }
    writeln!(
        out,
        "scale-bench: samples {samples} seconds {total:.3} peak_kib {}",
        peak.unwrap_or(0)
    )?;
    Ok(())
}

/// The physics search on `study` with the command line's settings, its prediction bands added
/// (what `identify --search` does before the information account); prints how it ended.
fn physics_search(
    study: mtcal_identify::Study,
    out: &mut impl Write,
) -> Result<(
    mtcal_identify::Identification,
    mtcal_identify::Study,
    mtcal_solve::Solution,
)> {
    let options = mtcal_identify::search::SearchOptions::default();
    let result = mtcal_identify::search::search(study, &options)?;
    let identification = result
        .identification
        .with_prediction_bands(&result.study, &result.solution);
    let report = &result.findings.report;
    writeln!(
        out,
        "search: {} candidates, {} steps, {} discoveries; {}",
        report.candidates,
        report.steps.len(),
        result.findings.discoveries.len(),
        report.stopped
    )?;
    Ok((identification, result.study, result.solution))
}

/// A `kB` line of `/proc/self/status` (Linux), in KiB.
fn status_kib(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix(key)?.strip_prefix(':'))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// Writes the plan of `layout` with about `samples` samples (and its machine) into `dir`.
fn write_plan(layout: &str, samples: usize, dir: &Path) -> Result<PathBuf> {
    let (urdf, errors, plan) = match layout {
        "rtest" => (
            include_str!("../../machines/mcu630-cafyxz.urdf"),
            include_str!("../../machines/mcu630-cafyxz.errors.toml"),
            rtest_plan(samples),
        ),
        "ballbar" => (
            include_str!("../../machines/mcv754-zfyx.urdf"),
            include_str!("../../machines/mcv754-zfyx.errors.toml"),
            ballbar_plan(samples),
        ),
        "laser" => (
            include_str!("../../machines/mcv754-zfyx.urdf"),
            include_str!("../../machines/mcv754-zfyx.errors.toml"),
            laser_plan(samples),
        ),
        other => bail!("unknown layout `{other}`: rtest, ballbar or laser"),
    };
    std::fs::write(dir.join("m.urdf"), urdf)?;
    std::fs::write(dir.join("m.errors.toml"), errors)?;
    let path = dir.join("plan.toml");
    std::fs::write(&path, plan)?;
    Ok(path)
}

/// The plans' top: the machine written beside them, the noise seed, 1 kHz sampling, `top`
/// (more top-level keys) and `[record]`: files written as a controller (0.1 µm, 0.0001°) and
/// an instrument (0.0001 µm, 1 ms, air to three decimals) write them.
fn header(top: &str) -> String {
    format!(
        "machine = \"m.urdf\"\nseed = 7\ninterval_s = 0.001\n{top}\n[record]\npositions = 4\n\
         readings = 4\ntime = 3\ncontext = 3\n"
    )
}

fn rtest_plan(samples: usize) -> String {
    // The R-test path takes at most 10⁶ samples: above 6·10⁶ the six runs are repeated.
    let cycles = samples.div_ceil(6_000_000).max(1);
    let n = (samples / (6 * cycles)).max(2);
    let mut plan = header("pause_s = 10.0\n");
    plan.push_str(
        r#"
[identify]
parameters = ["EC0Y", "EB0Z", "EA0Z", "EY0A", "EZ0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C"]

[setup.ball-low]
ball = [100.0, 0.0, 200.0]

[setup.ball-high]
ball = [100.0, 0.0, 300.0]

[nuisance.ball-low]
ball_x = 4.0
ball_z = -3.0
tool_length = 2.0

[nuisance.ball-high]
ball_y = -5.0
"#,
    );
    let runs = [
        ("xyc-a0", "ball-low", "xyc", ""),
        ("xyc-a+30", "ball-low", "xyc", ", hold = { A = 30.0 }"),
        ("xyc-a-30", "ball-low", "xyc", ", hold = { A = -30.0 }"),
        ("yza-low", "ball-low", "yza", ""),
        ("xyc-high", "ball-high", "xyc", ""),
        ("yza-high", "ball-high", "yza", ""),
    ];
    for cycle in 1..=cycles {
        for (name, setup, kind, extra) in runs {
            let name = if cycles > 1 {
                format!("{name}-{cycle}")
            } else {
                name.to_string()
            };
            plan += &format!(
                "\n[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nsetup = \"{setup}\"\n\
                 noise = 0.5\npath = {{ kind = \"{kind}\", samples = {n}{extra} }}\n"
            );
        }
    }
    plan
}

fn ballbar_plan(samples: usize) -> String {
    let n = (samples / 6).max(2);
    let mut plan = header("");
    plan.push_str(
        r#"
[identify]
parameters = ["EC0Y", "EB0Z", "EA0Z"]

[setup.bar]
pivot = [0.0, 0.0, 390.0]
length = 100.0

[nuisance.bar]
pivot_x = 3.0
pivot_y = -2.0
pivot_z = 4.0
tool_length = 2.0
"#,
    );
    for plane in ["XY", "YZ", "ZX"] {
        for direction in ["ccw", "cw"] {
            plan += &format!(
                "\n[[run]]\nname = \"{plane}-{direction}\"\ninstrument = \"ballbar\"\n\
                 setup = \"bar\"\nnoise = 0.5\npath = {{ kind = \"circle\", plane = \"{plane}\", \
                 direction = \"{direction}\", samples = {n} }}\n"
            );
        }
    }
    plan
}

fn laser_plan(samples: usize) -> String {
    // Each run: `points` targets, 5 bidirectional cycles (2·5·points samples), at most 10⁶
    // samples (17 minutes at 1 kHz): above 3·10⁶ samples the three runs are repeated.
    let repeats = samples.div_ceil(3_000_000).max(1);
    let points = (samples / (30 * repeats)).max(2);
    let mut plan = header("");
    plan.push_str(
        r#"
[identify]
parameters = ["EXX", "EYY", "EZZ"]

[context]
T_air = [[0.0, 20.4], [30000.0, 21.2]]
P_air = [[0.0, 1008.0], [30000.0, 1006.5]]
H_air = [[0.0, 42.0], [30000.0, 47.0]]
"#,
    );
    let runs = [
        ("X", -300.0, 300.0, "Y = 0.0, Z = -250.0"),
        ("Y", -200.0, 200.0, "X = 0.0, Z = -250.0"),
        ("Z", -450.0, -50.0, "X = 0.0, Y = 0.0"),
    ];
    for (axis, _, _, _) in runs {
        let lower = axis.to_lowercase();
        plan += &format!(
            "\n[setup.laser-{lower}]\nmode = \"linear\"\norigin = [0.0, 0.0, 390.0]\n\
             direction = \"{axis}\"\nwavelength_compensated = false\n"
        );
    }
    for (repeat, (axis, from, to, hold)) in (1..=repeats).flat_map(|k| runs.map(|r| (k, r))) {
        let lower = axis.to_lowercase();
        let name = if repeats > 1 {
            format!("laser-{lower}-{repeat}")
        } else {
            format!("laser-{lower}")
        };
        plan += &format!(
            "\n[[run]]\nname = \"{name}\"\ninstrument = \"laser\"\nsetup = \"laser-{lower}\"\n\
             path = {{ axis = \"{axis}\", from = {from:?}, to = {to:?}, points = {points}, \
             cycles = 5, overrun = 5.0, hold = {{ {hold} }} }}\n"
        );
    }
    plan
}
