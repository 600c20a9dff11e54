//! Real data: the spindle thermal test of `../shared/data/fl-thermal-spindle` (46 h, five
//! displacement channels, sixteen temperatures, spindle speed; MIT licence, read from the
//! shared folder, never copied into the project).
//!
//! Loaded as a user would write it, from scratch: one `displacement` set-up with five sensors
//! of unknown direction (`chN = {}`: each modelled on its own), the first four heat/cool cycles
//! fitted — as one run, and again cut into one run per cycle —, the fifth cycle's start as a
//! validation run with its context only (spindle speed and temperatures, no readings), the last
//! 20 % (the speed-step sequence the published models were tested on) as the validation run to
//! score; no `[identify]` table, no start model. `identify --search` must find its own drivers
//! and beat the best published learned model on every channel (README of the data folder), and
//! give the same answer however the recording was cut (within [`CUTS_AGREE_UM`] per channel);
//! the test prints every step's mean absolute error on the last 20 % and each search's time.
//! Issue 33 asks for 2.0 µm on every channel and a search under a minute on the CI machine
//! (both asserted; the two tests of this file run one at a time, so the timed search has the
//! machine's every core).
//!
//! Without `../shared` (or `MTCAL_SHARED_DATA`) the test says it was skipped; in CI
//! (`MTCAL_REQUIRE_SHARED_DATA`) a missing file is a failure.

use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::study::Changes;
use mtcal_identify::{Study, base, predict_run};
use mtcal_solve::{Options, Silent};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Best published mean absolute error per channel (µm) on the last 20 % (seq2seq v2).
const PUBLISHED_MAE_UM: [f64; 5] = [3.561, 3.755, 3.704, 3.461, 4.284];

/// Issue 33's bar on the last 20 % (µm), every channel.
const ISSUE_BAR_UM: f64 = 2.0;

/// Start of each heat/cool cycle (s): the spindle starts 465 s into the recording, and every
/// cycle is 4 h on, 4 h off.
const CYCLE_S: f64 = 28_800.0;
const FIRST_START_S: f64 = 465.0;

fn data_file() -> Option<PathBuf> {
    mtcal_testkit::shared_data("fl-thermal-spindle/data.csv")
}

/// The recording, read once per test (`None`, said on standard error, without the data).
fn recording() -> Option<Recording> {
    let Some(file) = data_file() else {
        eprintln!(
            "skipped: ../shared/data/fl-thermal-spindle/data.csv not found (set MTCAL_SHARED_DATA)"
        );
        return None;
    };
    let rec = read(&file);
    assert_eq!(rec.t.len(), 11_115);
    Some(rec)
}

/// The recording's columns.
struct Recording {
    t: Vec<f64>,
    rpm: Vec<f64>,
    channels: [Vec<f64>; 5],
    temperatures: Vec<Vec<f64>>,
}

fn read(file: &Path) -> Recording {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 23, "{header:?}");
    let mut rec = Recording {
        t: Vec::new(),
        rpm: Vec::new(),
        channels: Default::default(),
        temperatures: vec![Vec::new(); 16],
    };
    for line in lines.filter(|l| !l.is_empty()) {
        let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        rec.t.push(v[0]);
        rec.rpm.push(v[1]);
        for c in 0..5 {
            rec.channels[c].push(v[2 + c]);
        }
        for k in 0..16 {
            rec.temperatures[k].push(v[7 + k]);
        }
    }
    rec
}

/// How the user cut the recording into files.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cut {
    /// One fitted run for the first four heat/cool cycles.
    OneRun,
    /// One fitted run per cycle.
    FourRuns,
}

/// Rows of each run: the first four cycles fitted (one run, or one run per cycle), the start
/// of the fifth (context only), the last 20 %.
fn runs(rec: &Recording, cut: Cut) -> Vec<(&'static str, bool, std::ops::Range<usize>)> {
    let n = rec.t.len();
    let last = (0.8 * n as f64) as usize;
    let at = |s: f64| rec.t.partition_point(|&t| t < s);
    let cycle_end = |k: f64| at(FIRST_START_S + k * CYCLE_S);
    let mut out = match cut {
        Cut::OneRun => vec![("cycles-1-4", true, 0..cycle_end(4.0))],
        Cut::FourRuns => vec![
            ("cycle-1", true, 0..cycle_end(1.0)),
            ("cycle-2", true, cycle_end(1.0)..cycle_end(2.0)),
            ("cycle-3", true, cycle_end(2.0)..cycle_end(3.0)),
            ("cycle-4", true, cycle_end(3.0)..cycle_end(4.0)),
        ],
    };
    out.push(("cycle-5-start", false, cycle_end(4.0)..last));
    out.push(("speed-steps", false, last..n));
    out
}

/// Writes the session as a user would: machine `ZFYX` held at zero, one displacement set-up
/// with five sensors of unknown direction, spindle speed and sixteen temperatures as context,
/// no `[identify]` table; the fifth cycle's start without readings.
fn write_session(dir: &Path, rec: &Recording, cut: Cut) -> PathBuf {
    let mut manifest = String::from(
        "machine = \"ZFYX\"\n\n[setup.spindle]\nsigma_um = 1.0\n\
         [setup.spindle.sensors]\nch1 = {}\nch2 = {}\nch3 = {}\nch4 = {}\nch5 = {}\n\n",
    );
    for (name, fit, rows) in runs(rec, cut) {
        let readings = fit || name == "speed-steps";
        let _ = write!(
            manifest,
            "[[run]]\nname = \"{name}\"\ninstrument = \"displacement\"\nfile = \"{name}.csv\"\nuse = \"{}\"\nsetup = \"spindle\"\n\n",
            if fit { "fit" } else { "validate" }
        );
        let mut csv = String::from("t,X,Y,Z");
        if readings {
            csv.push_str(",d_ch1,d_ch2,d_ch3,d_ch4,d_ch5");
        }
        csv.push_str(",S");
        for k in 1..=16 {
            let _ = write!(csv, ",T_t{k}");
        }
        csv.push('\n');
        for i in rows {
            let _ = write!(csv, "{},0,0,0", rec.t[i]);
            if readings {
                for c in 0..5 {
                    let _ = write!(csv, ",{}", rec.channels[c][i]);
                }
            }
            let _ = write!(csv, ",{}", rec.rpm[i]);
            for k in 0..16 {
                let _ = write!(csv, ",{}", rec.temperatures[k][i]);
            }
            csv.push('\n');
        }
        std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
    }
    std::fs::write(dir.join("session.toml"), manifest).unwrap();
    dir.to_path_buf()
}

/// Mean absolute error per channel (µm) of the run `speed-steps` at parameters `x`.
fn last_mae(study: &Study, x: &[f64]) -> [f64; 5] {
    let r = study
        .runs
        .iter()
        .position(|r| r.name == "speed-steps")
        .unwrap();
    let pred = predict_run(study, r, x);
    let readings = study.runs[r].readings.as_ref().unwrap();
    let n = study.runs[r].len();
    let mut mae = [0.0; 5];
    for i in 0..n {
        for c in 0..5 {
            mae[c] += (pred[i * 5 + c] - readings.get(i, c)).abs() * 1e6 / n as f64;
        }
    }
    mae
}

fn fmt(mae: &[f64; 5]) -> String {
    mae.iter()
        .map(|m| format!("{m:6.2}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The search from scratch on the recording cut as `cut`: the mean absolute error per channel
/// on the last 20 % after each discovery (printed) and at the end, and the search's time.
fn searched(rec: &Recording, cut: Cut) -> ([f64; 5], std::time::Duration) {
    let dir = tempfile::tempdir().unwrap();
    // `KEEP=dir` keeps the session (as `dir/<cut>`) to time or look at with `mtcal`.
    let folder = match std::env::var("KEEP") {
        Ok(keep) => Path::new(&keep).join(format!("{cut:?}")),
        Err(_) => dir.path().to_path_buf(),
    };
    std::fs::create_dir_all(&folder).unwrap();
    let session = write_session(&folder, rec, cut);
    let started = std::time::Instant::now();
    let loaded = Study::load(&session).unwrap();
    assert!(loaded.effects().is_empty(), "no start model");
    assert!(loaded.session.identify.is_empty(), "no [identify] table");
    let (study, base) = base::identifiable_study(loaded, &Options::default()).unwrap();
    let mut result = search(study, &SearchOptions::default()).unwrap();
    let took = started.elapsed();
    if let Some(base) = &base {
        result = result.with_base(base).unwrap();
    }
    let found = &result.findings;
    eprintln!("{cut:?}:\n{}", found.summary_with(false));
    // Every step's error on the unseen speed steps: the model with the first k discoveries,
    // refitted.
    let effects = result.study.effects().to_vec();
    let mut report = format!(
        "{cut:?}, search {:.0} s; MAE on the last 20 % (µm):   ch1    ch2    ch3    ch4    ch5\n",
        took.as_secs_f64()
    );
    let mut last = [f64::INFINITY; 5];
    for k in 0..=effects.len() {
        let study = result
            .study
            .rebuild(Changes {
                effects: effects[..k].to_vec(),
                ..result.study.changes().clone()
            })
            .unwrap();
        let sol = mtcal_identify::solve_from(
            &study,
            &study.initial_x(),
            &Options::default(),
            &mut Silent,
        )
        .unwrap();
        last = last_mae(&study, &sol.x);
        let step = if k == 0 {
            "sensor offsets only".to_string()
        } else {
            format!("+ {}", effects[k - 1].info().label)
        };
        let _ = writeln!(report, "  {step:<40} {}", fmt(&last));
    }
    let _ = writeln!(
        report,
        "  {:<40} {}",
        "published best (seq2seq v2)",
        fmt(&PUBLISHED_MAE_UM)
    );
    eprintln!("{report}");
    // The drivers are the search's own: a joint model of every recorded input per channel.
    assert!(
        found
            .discoveries
            .iter()
            .any(|d| d.effect == "thermal-model"),
        "{}",
        found.summary()
    );
    for c in 0..5 {
        assert!(
            last[c] <= ISSUE_BAR_UM,
            "{cut:?}, channel {}: {:.2} µm, more than {ISSUE_BAR_UM:.2} µm\n{report}",
            c + 1,
            last[c]
        );
        assert!(
            last[c] < PUBLISHED_MAE_UM[c],
            "{cut:?}, channel {}: {:.2} µm, the published model {:.2} µm\n{report}",
            c + 1,
            last[c],
            PUBLISHED_MAE_UM[c]
        );
    }
    (last, took)
}

/// Largest difference (µm) between the two cuts' errors on a channel: the file boundaries a
/// user chose must not decide the answer.
const CUTS_AGREE_UM: f64 = 0.5;

/// Issue 33's bar on each search's wall time (s).
const SEARCH_LIMIT_S: f64 = 60.0;

/// The tests of this file one at a time: the searches are timed with the machine's every core.
static ALONE: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn from_scratch_the_search_beats_the_published_models_however_the_recording_is_cut() {
    let _alone = ALONE.lock().unwrap_or_else(|e| e.into_inner());
    let Some(rec) = recording() else {
        return;
    };
    // One after the other, each with the machine's every core, as a user runs it.
    let one = searched(&rec, Cut::OneRun);
    let four = searched(&rec, Cut::FourRuns);
    eprintln!(
        "as one run {} ({:.0} s)\nas four runs {} ({:.0} s)",
        fmt(&one.0),
        one.1.as_secs_f64(),
        fmt(&four.0),
        four.1.as_secs_f64()
    );
    // Issue 33: each search under a minute on the CI machine (two cores), as a user times it:
    // from loading the session to the search's result. 52–53 s here in the test profile,
    // 48–50 s released.
    for (cut, took) in [("one run", one.1), ("four runs", four.1)] {
        assert!(
            took.as_secs_f64() < SEARCH_LIMIT_S,
            "as {cut}: the search took {:.1} s, more than {SEARCH_LIMIT_S} s",
            took.as_secs_f64()
        );
    }
    for c in 0..5 {
        assert!(
            (one.0[c] - four.0[c]).abs() <= CUTS_AGREE_UM,
            "channel {}: {:.2} µm as one run, {:.2} µm as four",
            c + 1,
            one.0[c],
            four.0[c]
        );
    }
}

/// The fit itself, at a given noise model, is the same bits (to rounding) whether the
/// recording is one run or four: the noise filter runs on across a boundary between runs that
/// continue one another (`Study::continues`) instead of starting again (Prais–Winsten's first
/// row, the level of the run as it is, once per file).
#[test]
fn the_fit_does_not_depend_on_how_the_recording_is_cut() {
    let _alone = ALONE.lock().unwrap_or_else(|e| e.into_inner());
    let Some(rec) = recording() else {
        return;
    };
    let noise = mtcal_identify::noise::NoiseModel {
        per_setup: vec![vec![
            mtcal_identify::noise::ChannelNoise {
                scale: 1.5,
                phi: 0.8,
                samples: 1000,
            };
            5
        ]],
    };
    let fits: Vec<(f64, Vec<f64>, Vec<Option<usize>>)> = [Cut::OneRun, Cut::FourRuns]
        .into_iter()
        .map(|cut| {
            let dir = tempfile::tempdir().unwrap();
            let study = Study::load(&write_session(dir.path(), &rec, cut)).unwrap();
            let study = study
                .rebuild(Changes {
                    noise: Some(std::sync::Arc::new(noise.clone())),
                    ..study.changes().clone()
                })
                .unwrap();
            let sol = mtcal_identify::solve_from(
                &study,
                &study.initial_x(),
                &Options::default(),
                &mut Silent,
            )
            .unwrap();
            (sol.chi2, sol.x, study.continues())
        })
        .collect();
    // The four cycles continue one another; the validation runs continue nothing.
    assert_eq!(
        fits[1].2,
        vec![None, Some(0), Some(1), Some(2), None, None],
        "{:?}",
        fits[1].2
    );
    let (one, four) = (&fits[0], &fits[1]);
    assert!(
        (one.0 - four.0).abs() <= 1e-9 * one.0,
        "χ² {} as one run, {} as four",
        one.0,
        four.0
    );
    for (a, b) in one.1.iter().zip(&four.1) {
        assert!((a - b).abs() <= 1e-12, "{:?} vs {:?}", one.1, four.1);
    }
}
