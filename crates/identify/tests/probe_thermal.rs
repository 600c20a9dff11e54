//! Scratch: the real thermal test from scratch.
use mtcal_identify::search::{SearchOptions, search};
use mtcal_identify::{Study, base, predict_run};
use mtcal_plugins as _;
use mtcal_solve::Options;
use std::fmt::Write as _;
use std::path::Path;

fn main_test() {
    let file = Path::new("/work/shared/data/fl-thermal-spindle/data.csv");
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines();
    lines.next();
    let rows: Vec<Vec<f64>> = lines.filter(|l| !l.is_empty()).map(|l| l.split(',').map(|x| x.parse().unwrap()).collect()).collect();
    let n = rows.len();
    let last = (0.8 * n as f64) as usize;
    let at = |s: f64| rows.partition_point(|r| r[0] < s);
    let cyc = |k: f64| at(465.0 + k * 28800.0);
    let runs = vec![
        ("cycle-1", "fit", 0..cyc(1.0), true),
        ("cycle-2", "fit", cyc(1.0)..cyc(2.0), true),
        ("cycle-3", "fit", cyc(2.0)..cyc(3.0), true),
        ("cycle-4", "fit", cyc(3.0)..cyc(4.0), true),
        ("cycle-5-start", "validate", cyc(4.0)..last, false),
        ("speed-steps", "validate", last..n, true),
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut manifest = String::from("machine = \"ZFYX\"\n\n[setup.spindle]\nsigma_um = 1.0\n[setup.spindle.sensors]\nch1 = {}\nch2 = {}\nch3 = {}\nch4 = {}\nch5 = {}\n\n");
    for (name, use_, range, readings) in &runs {
        let _ = write!(manifest, "[[run]]\nname = \"{name}\"\ninstrument = \"displacement\"\nfile = \"{name}.csv\"\nuse = \"{use_}\"\nsetup = \"spindle\"\n\n");
        let mut csv = String::from("t,X,Y,Z");
        if *readings { csv.push_str(",d_ch1,d_ch2,d_ch3,d_ch4,d_ch5"); }
        csv.push_str(",S");
        for k in 1..=16 { let _ = write!(csv, ",T_t{k}"); }
        csv.push('\n');
        for i in range.clone() {
            let r = &rows[i];
            let _ = write!(csv, "{},0,0,0", r[0]);
            if *readings { for c in 0..5 { let _ = write!(csv, ",{}", r[2 + c]); } }
            let _ = write!(csv, ",{}", r[1]);
            for k in 0..16 { let _ = write!(csv, ",{}", r[7 + k]); }
            csv.push('\n');
        }
        std::fs::write(dir.path().join(format!("{name}.csv")), csv).unwrap();
    }
    std::fs::write(dir.path().join("session.toml"), manifest).unwrap();
    let t0 = std::time::Instant::now();
    let (study, b) = base::identifiable_study(Study::load(dir.path()).unwrap(), &Options::default()).unwrap();
    let mut result = search(study, &SearchOptions { max_steps: 40, ..SearchOptions::default() }).unwrap();
    if let Some(b) = &b { result.apply_base(b).unwrap(); }
    eprintln!("{}\n({:.1} s)", result.identification.search_summary(), t0.elapsed().as_secs_f64());
    let study = &result.study;
    let r = study.runs.iter().position(|r| r.name == "speed-steps").unwrap();
    let pred = predict_run(study, r, &result.solution.x);
    let readings = study.runs[r].readings.as_ref().unwrap();
    let m = study.runs[r].len();
    let mut mae = [0.0; 5];
    for i in 0..m { for c in 0..5 { mae[c] += (pred[i * 5 + c] - readings.get(i, c)).abs() * 1e6 / m as f64; } }
    eprintln!("MAE last 20 %: {mae:.2?}  (published best 3.56 3.76 3.70 3.46 4.28)");
}

#[test]
fn from_scratch() { main_test(); }
