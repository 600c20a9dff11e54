//! The study keeps its runs compactly (`mtcal_session::Column`: a held axis as one number, the
//! few-digit decimals instruments write as integers) and gives back **bit for bit** what the run
//! file holds after the conversion to SI and the set-up's preparation — so identification gives
//! the same bits as with plain vectors. Checked on simulated sessions written as a controller
//! and an instrument write them (`[record]` of the plan: 4 decimals) and at full `f64`
//! precision, for the five-axis R-test (readings as read) and for laser runs whose readings the
//! set-up prepares (wavelength compensation from the logged air).

use crate::common;

use common::planted::TRUTH;
use mtcal_identify::Study;
use mtcal_session::{RunColumns, Storage, read_run};
use mtcal_solve::{Options, Silent};
use std::path::{Path, PathBuf};

const RECORD: &str = "[record]\npositions = 4\nreadings = 4\ntime = 3\ncontext = 3\n";

fn machine(name: &str) -> String {
    mtcal_testkit::machine_file(name)
        .display()
        .to_string()
        .replace('\\', "/")
}

fn rtest_plan(record: bool, noise: f64) -> String {
    format!(
        r#"machine = "{}"
seed = 3
interval_s = 0.001
{}
[identify]
parameters = {}

[setup.ball]
ball = [100.0, 0.0, 200.0]
ball_free = false
tool_length_free = false

[[run]]
name = "xyc"
instrument = "rtest"
setup = "ball"
noise = {noise}
path = {{ kind = "xyc", samples = 400 }}

[[run]]
name = "xyc-a30"
instrument = "rtest"
setup = "ball"
noise = {noise}
path = {{ kind = "xyc", samples = 400, hold = {{ A = 30.0 }} }}

[[run]]
name = "yza"
instrument = "rtest"
setup = "ball"
noise = {noise}
path = {{ kind = "yza", samples = 300 }}
"#,
        machine("mcu630-cafyxz.urdf"),
        if record { RECORD } else { "" },
        mtcal_testkit::params::toml_list(&mtcal_testkit::ELEVEN)
    )
}

fn laser_plan(record: bool) -> String {
    format!(
        r#"machine = "{}"
seed = 3
interval_s = 0.001
{}
[identify]
parameters = ["EXX", "EYY"]

[context]
T_air = [[0.0, 20.4], [100.0, 21.2]]
P_air = [[0.0, 1008.0], [100.0, 1006.5]]
H_air = [[0.0, 42.0], [100.0, 47.0]]

[setup.laser-x]
mode = "linear"
origin = [0.0, 0.0, 390.0]
direction = "X"
wavelength_compensated = false

[setup.laser-y]
mode = "linear"
origin = [0.0, 0.0, 390.0]
direction = "Y"
wavelength_compensated = false

[[run]]
name = "laser-x"
instrument = "laser"
setup = "laser-x"
path = {{ axis = "X", from = -300.0, to = 300.0, points = 41, cycles = 5, hold = {{ Y = 0.0, Z = -250.0 }} }}

[[run]]
name = "laser-y"
instrument = "laser"
setup = "laser-y"
path = {{ axis = "Y", from = -200.0, to = 200.0, points = 41, cycles = 5, hold = {{ X = 0.0, Z = -250.0 }} }}
"#,
        machine("mcv754-zfyx.urdf"),
        if record { RECORD } else { "" }
    )
}

fn simulate(dir: &Path, plan: &str) -> PathBuf {
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    let session = dir.join("session");
    mtcal_simulate::simulate(&dir.join("plan.toml"), &session).unwrap();
    session
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits()
}

/// Every stored number against the run file read as a table and converted in place (what the
/// study kept before): times, SI positions, prepared readings, context. Returns the bytes the
/// study's columns take per sample.
fn check_against_the_files(study: &Study) -> f64 {
    let machine = study.model.machine();
    let letters: Vec<char> = machine
        .axes()
        .iter()
        .map(|a| a.letter().as_char())
        .collect();
    let rotary: Vec<bool> = machine
        .axes()
        .iter()
        .map(|a| a.kind() == mtcal_kinematics::AxisKind::Rotary)
        .collect();
    let (mut bytes, mut samples) = (0, 0);
    for (r, run) in study.runs.iter().enumerate() {
        let setup = &study.setups[run.setup].setup;
        let channels = study.channels(r);
        let names: Vec<&str> = channels.iter().map(|c| c.name.as_str()).collect();
        let table = read_run(
            &run.file.path,
            &RunColumns {
                axes: &letters,
                readings: &names,
                readings_optional: false,
                labels: &[],
            },
        )
        .unwrap();
        let (n, na, nch) = (table.len(), letters.len(), names.len());
        assert_eq!(run.len(), n);
        let q_si: Vec<f64> = table
            .positions
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                if rotary[k % na] {
                    v.to_radians()
                } else {
                    v * 1e-3
                }
            })
            .collect();
        let mut prepared: Vec<f64> = table
            .values
            .as_ref()
            .unwrap()
            .iter()
            .enumerate()
            .map(|(k, &v)| v / channels[k % nch].unit.per_si())
            .collect();
        setup
            .prepare_readings(
                &mtcal_instrument::RunData {
                    q: &q_si,
                    t: &table.t,
                    context: &table.context,
                },
                &mut prepared,
            )
            .unwrap();
        let readings = run.readings.as_ref().unwrap();
        for i in 0..n {
            assert!(same(run.t.get(i), table.t[i]), "{} t[{i}]", run.name);
            for a in 0..na {
                assert!(
                    same(run.q.get(i, a), q_si[i * na + a]),
                    "{} q[{i}][{a}]",
                    run.name
                );
                assert!(same(run.q.column(a).raw(i), table.positions[i * na + a]));
            }
            for c in 0..nch {
                assert!(
                    same(readings.get(i, c), prepared[i * nch + c]),
                    "{} reading [{i}][{c}]: {} vs {}",
                    run.name,
                    readings.get(i, c),
                    prepared[i * nch + c]
                );
            }
            for ((name, column), (file_name, values)) in run.context.iter().zip(&table.context) {
                assert_eq!(name, file_name);
                assert!(same(column.get(i), values[i]));
            }
        }
        bytes += run.t.heap_bytes() + run.q.heap_bytes() + readings.heap_bytes();
        bytes += run
            .context
            .iter()
            .map(|(_, c)| c.heap_bytes())
            .sum::<usize>();
        samples += n;
    }
    bytes as f64 / samples as f64
}

#[test]
fn recorded_rtest_runs_are_kept_as_integers_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let study = Study::load(&simulate(dir.path(), &rtest_plan(true, 0.5))).unwrap();
    let per_sample = check_against_the_files(&study);
    for run in study.runs.iter() {
        assert!(
            matches!(run.t.storage(), Storage::Decimal(_)),
            "{}",
            run.name
        );
        // The XYC runs hold A (and Z at A = 0), the YZA run holds X and C.
        let held = (0..5)
            .filter(|&a| run.q.column(a).storage() == Storage::Constant)
            .count();
        assert!(held >= 1, "{}: no held axis", run.name);
        for column in run.q.columns() {
            assert_ne!(column.storage(), Storage::Float, "{}", run.name);
        }
        for column in run.readings.as_ref().unwrap().columns() {
            assert_eq!(column.storage(), Storage::Decimal(4), "{}", run.name);
        }
    }
    // Time, at most four moving axes and three readings at 4 bytes: at most 32 bytes a sample
    // (72 as f64).
    println!("recorded R-test: {per_sample:.1} bytes per sample");
    assert!(per_sample <= 32.0, "{per_sample} bytes per sample");
}

#[test]
fn full_precision_files_are_kept_as_f64_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let study = Study::load(&simulate(dir.path(), &rtest_plan(false, 0.5))).unwrap();
    let per_sample = check_against_the_files(&study);
    // Held axes are still one number; the moving ones and the readings keep 8 bytes.
    for run in study.runs.iter() {
        assert!(
            run.readings
                .as_ref()
                .unwrap()
                .columns()
                .iter()
                .all(|c| c.storage() == Storage::Float)
        );
    }
    println!("full-precision R-test: {per_sample:.1} bytes per sample");
    assert!(per_sample > 40.0 && per_sample < 72.0, "{per_sample}");
}

#[test]
fn prepared_laser_readings_are_kept_as_computed() {
    for record in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        let study = Study::load(&simulate(dir.path(), &laser_plan(record))).unwrap();
        let per_sample = check_against_the_files(&study);
        for run in study.runs.iter() {
            // Wavelength compensation changes every reading: they are kept as computed.
            let readings = run.readings.as_ref().unwrap();
            assert_eq!(readings.column(0).storage(), Storage::Float, "{}", run.name);
            assert_eq!(run.context.len(), 3);
            if record {
                for (name, column) in &run.context {
                    assert!(
                        matches!(column.storage(), Storage::Decimal(_)),
                        "{} {name}: {:?}",
                        run.name,
                        column.storage()
                    );
                }
            }
        }
        println!("laser (record {record}): {per_sample:.1} bytes per sample");
    }
}

/// A recorded session is what the machine did: the controller was given the written positions,
/// so the only difference from the full-precision session is the readings' last digit
/// (0.0001 µm), far below any interval.
#[test]
fn a_recorded_session_identifies_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let plan = rtest_plan(true, 0.0).replace(
        "interval_s = 0.001\n",
        "interval_s = 0.001\ntruth = \"truth.params.toml\"\n",
    );
    std::fs::write(
        dir.path().join("truth.params.toml"),
        mtcal_testkit::params::values_file(&TRUTH),
    )
    .unwrap();
    let session = simulate(dir.path(), &plan);
    // The files hold at most four decimals.
    let text = std::fs::read_to_string(session.join("xyc-a30.csv")).unwrap();
    for field in text.lines().skip(1).flat_map(|l| l.split(',')) {
        let decimals = field.split_once('.').map_or(0, |(_, d)| d.len());
        assert!(decimals <= 4, "{field}");
    }
    let study = Study::load(&session).unwrap();
    let id = mtcal_identify::identify(&study, &Options::default(), &mut Silent).unwrap();
    for (name, value) in TRUTH {
        let p = id
            .parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} missing"));
        let got = p.value;
        assert!((got - value).abs() < 1e-3, "{name}: {got} vs {value}");
    }
    assert!(id.fit.rms_um < 1e-4, "rms {}", id.fit.rms_um);
}

#[test]
fn a_record_table_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    for (record, expected) in [
        (
            "[record]\npositions = 12\n",
            "[record] `positions` must be a number of decimals from 0 to 9, found 12",
        ),
        (
            "[record]\nangles = 3\n",
            "[record] unknown key `angles`; it has positions, readings, time, context",
        ),
        (
            "[record]\ntime = 1\n",
            "[record] time = 1: samples 0.001 s apart need more decimals",
        ),
    ] {
        let plan = rtest_plan(false, 0.5).replace("[identify]", &format!("{record}\n[identify]"));
        std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
        let err = mtcal_simulate::simulate(&dir.path().join("plan.toml"), &dir.path().join("out"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(expected), "{err}\nexpected: {expected}");
    }
}
