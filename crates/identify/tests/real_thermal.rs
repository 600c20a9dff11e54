//! Real data: the spindle thermal test of `../shared/data/fl-thermal-spindle` (46 h, five
//! displacement channels, sixteen temperatures, spindle speed; MIT licence, read from the
//! shared folder, never copied into the project).
//!
//! The recording becomes a session of the `displacement` instrument (five sensors against the
//! spindle, directions unknown: each channel is modelled on its own): the first four heat/cool
//! cycles are fitted, the rest is validation — the start of the fifth cycle, and the last 20 %
//! of the recording (the speed-step sequence the published models were tested on). The model
//! starts as source 003's: per channel a polynomial (linear) in the one temperature that
//! matches it best. The physics search adds what is missing; the test reports every step's
//! mean absolute error per channel on the last 20 %, and requires the final model to beat the
//! best published learned model on every channel (README of the data folder).
//!
//! Without `../shared` (or `MTCAL_SHARED_DATA`) the test says it was skipped.

use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::study::Changes;
use mtcal_identify::{Study, predict_run};
use mtcal_plugins as _;
use mtcal_solve::{Options, Silent};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Best published mean absolute error per channel (µm) on the last 20 % (seq2seq v2).
const PUBLISHED_MAE_UM: [f64; 5] = [3.561, 3.755, 3.704, 3.461, 4.284];

/// Start of each heat/cool cycle (s): the spindle starts 465 s into the recording, and every
/// cycle is 4 h on, 4 h off.
const CYCLE_S: f64 = 28_800.0;
const FIRST_START_S: f64 = 465.0;

fn data_file() -> Option<PathBuf> {
    let base = std::env::var_os("MTCAL_SHARED_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    let file = base.join("fl-thermal-spindle/data.csv");
    // In CI (`.ci/run` sets MTCAL_REQUIRE_SHARED_DATA) a missing file is a failure, not a skip.
    if !file.is_file() && std::env::var_os("MTCAL_REQUIRE_SHARED_DATA").is_some() {
        panic!("{} not found: CI requires ../shared/data", file.display());
    }
    file.is_file().then_some(file)
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

/// Rows of each run: four fitted cycles, the start of the fifth, the last 20 %.
fn runs(rec: &Recording) -> Vec<(&'static str, bool, std::ops::Range<usize>)> {
    let n = rec.t.len();
    let last = (0.8 * n as f64) as usize;
    let at = |s: f64| rec.t.partition_point(|&t| t < s);
    let cycle_end = |k: f64| at(FIRST_START_S + k * CYCLE_S);
    vec![
        ("cycle-1", true, 0..cycle_end(1.0)),
        ("cycle-2", true, cycle_end(1.0)..cycle_end(2.0)),
        ("cycle-3", true, cycle_end(2.0)..cycle_end(3.0)),
        ("cycle-4", true, cycle_end(3.0)..cycle_end(4.0)),
        ("cycle-5-start", false, cycle_end(4.0)..last),
        ("speed-steps", false, last..n),
    ]
}

/// Per channel, the temperature whose linear fit over the fitted rows matches the channel
/// best (source 003's choice of reference sensor).
fn reference_sensors(rec: &Recording, fitted: usize) -> [usize; 5] {
    let mut out = [0; 5];
    for (c, best) in out.iter_mut().enumerate() {
        let y = &rec.channels[c][..fitted];
        let mut best_rss = f64::INFINITY;
        for (k, temp) in rec.temperatures.iter().enumerate() {
            let x = &temp[..fitted];
            let n = x.len() as f64;
            let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
            let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
            let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
            let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
            let rss: f64 = x
                .iter()
                .zip(y)
                .map(|(a, b)| (b - my - slope * (a - mx)).powi(2))
                .sum();
            if rss < best_rss {
                best_rss = rss;
                *best = k;
            }
        }
    }
    out
}

/// Writes the session: machine `ZFYX` held at zero, one displacement set-up with five sensors
/// of unknown direction, spindle speed and sixteen temperatures as context, the baseline as
/// `[[identify.effect]]` tables.
fn write_session(dir: &Path, rec: &Recording) -> PathBuf {
    let runs = runs(rec);
    let fitted = runs[3].2.end;
    let refs = reference_sensors(rec, fitted);
    let mut manifest = String::from(
        "machine = \"ZFYX\"\n\n[identify]\nparameters = []\nheldout = \"timeline\"\nfolds = 16\n\n[setup.spindle]\nsigma_um = 1.0\n\
         [setup.spindle.sensors]\nch1 = {}\nch2 = {}\nch3 = {}\nch4 = {}\nch5 = {}\n\n",
    );
    for (c, k) in refs.iter().enumerate() {
        let _ = write!(
            manifest,
            "[[identify.effect]]\neffect = \"temperature-coupling\"\nchannel = \"d_ch{}\"\ndriver = \"T_t{}\"\n\n",
            c + 1,
            k + 1
        );
    }
    for (name, fit, rows) in &runs {
        let _ = write!(
            manifest,
            "[[run]]\nname = \"{name}\"\ninstrument = \"displacement\"\nfile = \"{name}.csv\"\nuse = \"{}\"\nsetup = \"spindle\"\n\n",
            if *fit { "fit" } else { "validate" }
        );
        let mut csv = String::from("t,X,Y,Z,d_ch1,d_ch2,d_ch3,d_ch4,d_ch5,S");
        for k in 1..=16 {
            let _ = write!(csv, ",T_t{k}");
        }
        csv.push('\n');
        for i in rows.clone() {
            let _ = write!(csv, "{},0,0,0", rec.t[i]);
            for c in 0..5 {
                let _ = write!(csv, ",{}", rec.channels[c][i]);
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

#[test]
fn the_search_beats_the_published_models_on_every_channel() {
    let Some(file) = data_file() else {
        eprintln!(
            "skipped: ../shared/data/fl-thermal-spindle/data.csv not found (set MTCAL_SHARED_DATA)"
        );
        return;
    };
    let rec = read(&file);
    assert_eq!(rec.t.len(), 11_115);
    let dir = tempfile::tempdir().unwrap();
    let session = write_session(dir.path(), &rec);
    let study = Study::load(&session).unwrap();
    let baseline = study.effects().len();
    assert_eq!(baseline, 5, "one temperature coupling per channel");
    let result = search(
        study,
        &SearchOptions {
            max_steps: 40,
            ..SearchOptions::default()
        },
    )
    .unwrap();
    let id = &result.identification;
    eprintln!("{}", id.search_summary());
    // Every step's error on the unseen speed steps: the model with the baseline and the first
    // k discoveries, refitted.
    let effects = result.study.effects().to_vec();
    let mut report = String::from("MAE on the last 20 % (µm):   ch1    ch2    ch3    ch4    ch5\n");
    let mut last = [f64::INFINITY; 5];
    for k in baseline..=effects.len() {
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
        let step = if k == baseline {
            "baseline (source 003)".to_string()
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
    for c in 0..5 {
        assert!(
            last[c] < PUBLISHED_MAE_UM[c],
            "channel {}: {:.2} µm, the published model {:.2} µm\n{report}",
            c + 1,
            last[c],
            PUBLISHED_MAE_UM[c]
        );
    }
}
