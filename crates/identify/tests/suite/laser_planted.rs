//! Planted truth for the laser interferometer: simulate laser runs on the shipped three-axis
//! machine `mcv754-zfyx` (its URDF, with a smaller error model written beside a temporary copy),
//! identify, compare with the truth.
//!
//! The error model holds what laser runs can see: per linear axis its positioning error (cubic
//! Legendre `P1..P3`, µm), its two straightness errors (`P2, P3`: no constant, no slope), its
//! pitch and yaw (`P1..P3`, µrad: the constant of an angular error only shifts an angular run's
//! zero and a linear run's zero through the Abbe offset, so it is left out of the model), and
//! the three squareness errors (µrad). Rolls are not in it: an interferometer does not read them.
//!
//! The runs, per axis: two linear runs (optic on the tool point and 100 mm up the tool axis:
//! the Abbe offset that separates positioning from pitch), two straightness runs (the two
//! perpendicular senses), two angular runs (pitch and yaw); plus the four body diagonals
//! (ISO 230-6), which carry the squareness errors, one of them also stepped one axis at a time,
//! and a linear X run with the laser on the spindle side. Each run has its own set-up (its own zero,
//! beam tilts under their 100 µrad prior, straightness slopes free).
//!
//! - noise-free: every coefficient back to 1e-6 in its unit (µm or µrad) absolute, nothing
//!   unidentifiable, fit RMS below 1e-6 µm;
//! - noisy (0.5 µm, 1 µrad): over a handful of noise seeds the 95 % intervals contain the
//!   truth 90–99 % of the time (the binomial spread of ~300 intervals around 95 %).

use mtcal_identify::{Identification, identify_session};
use mtcal_simulate::simulate;
use mtcal_testkit::machine_file;
use std::fmt::Write as _;
use std::path::Path;

/// Per axis: its letter, the two perpendicular senses (straightness), the pitch and yaw axes
/// (angular), the range of the runs (mm) and where the other axes are held.
struct AxisRuns {
    letter: char,
    senses: [&'static str; 2],
    angles: [&'static str; 2],
    range: (f64, f64),
    hold: &'static str,
}

const AXES: [AxisRuns; 3] = [
    AxisRuns {
        letter: 'X',
        senses: ["Y", "Z"],
        angles: ["Y", "Z"],
        range: (-300.0, 300.0),
        hold: "{ Y = 0.0, Z = -250.0 }",
    },
    AxisRuns {
        letter: 'Y',
        senses: ["X", "Z"],
        angles: ["X", "Z"],
        range: (-200.0, 200.0),
        hold: "{ X = 0.0, Z = -250.0 }",
    },
    AxisRuns {
        letter: 'Z',
        senses: ["X", "Y"],
        angles: ["X", "Y"],
        range: (-450.0, -50.0),
        hold: "{ X = 0.0, Y = 0.0 }",
    },
];

/// The component errors of an axis in the model: positioning, straightness, pitch and yaw.
fn components(a: &AxisRuns) -> [String; 5] {
    let k = a.letter;
    [
        format!("E{k}{k}"),
        format!("E{}{k}", a.senses[0]),
        format!("E{}{k}", a.senses[1]),
        format!("E{}{k}", angle_name(a.angles[0])),
        format!("E{}{k}", angle_name(a.angles[1])),
    ]
}

fn angle_name(axis: &str) -> char {
    match axis {
        "X" => 'A',
        "Y" => 'B',
        _ => 'C',
    }
}

const SQUARENESS: [(&str, f64); 3] = [("EC0Y", 12.0), ("EB0Z", -8.0), ("EA0Z", 5.0)];

/// The truth: every coefficient a few µm / µrad, different for every component.
fn truth() -> Vec<(String, Vec<f64>)> {
    let mut out = Vec::new();
    for (i, a) in AXES.iter().enumerate() {
        for (j, name) in components(a).into_iter().enumerate() {
            let s = 1.0 + 0.37 * (i * 5 + j) as f64;
            let c = if j == 1 || j == 2 {
                vec![2.0 * s.sin(), -1.5 * s.cos()]
            } else {
                vec![3.0 * s.cos(), 1.2 * s.sin(), -0.8 * (2.0 * s).cos()]
            };
            out.push((name, c));
        }
    }
    for (n, v) in SQUARENESS {
        out.push((n.to_string(), vec![v]));
    }
    out
}

/// Writes the machine copy, its error model, the truth and the plan into `dir`, simulates and
/// identifies.
fn run(dir: &Path, noise: bool, seed: u64) -> Identification {
    std::fs::copy(machine_file("mcv754-zfyx.urdf"), dir.join("m.urdf")).unwrap();
    let mut errors = String::from("components = [");
    let mut list = Vec::new();
    for a in &AXES {
        list.extend(components(a));
    }
    let quoted: Vec<String> = list.iter().map(|n| format!("\"{n}\"")).collect();
    writeln!(errors, "{}]", quoted.join(", ")).unwrap();
    errors.push_str("locations = [\"EC0Y\", \"EB0Z\", \"EA0Z\"]\n[basis.linear]\nkind = \"legendre\"\ndegree = 3\n");
    for a in &AXES {
        for name in &components(a)[3..] {
            writeln!(errors, "[component.{name}]\nmin_degree = 1").unwrap();
        }
    }
    std::fs::write(dir.join("m.errors.toml"), errors).unwrap();
    let mut t = String::from("[values]\n");
    for (n, c) in truth() {
        if c.len() == 1 {
            writeln!(t, "{n} = {}", c[0]).unwrap();
        }
    }
    for (n, c) in truth() {
        if c.len() > 1 {
            let cs: Vec<String> = c.iter().map(|v| v.to_string()).collect();
            writeln!(t, "[component.{n}]\ncoefficients = [{}]", cs.join(", ")).unwrap();
        }
    }
    std::fs::write(dir.join("truth.params.toml"), t).unwrap();
    let noise = if noise { "" } else { "noise = 0.0" };
    let mut plan = format!(
        "machine = \"m.urdf\"\ntruth = \"truth.params.toml\"\nseed = {seed}\n[identify]\nparameters = [{}, \"EC0Y\", \"EB0Z\", \"EA0Z\"]\n",
        quoted.join(", ")
    );
    for a in &AXES {
        let k = a.letter;
        let (lo, hi) = a.range;
        let path = format!(
            "{{ axis = \"{k}\", from = {lo}, to = {hi}, points = 9, cycles = 1, hold = {} }}",
            a.hold
        );
        let mut add = |name: String, setup: String| {
            write!(
                plan,
                "[[run]]\nname = \"{name}\"\ninstrument = \"laser\"\npath = {path}\n{}\n[run.setup]\n{setup}\n",
                noise
            )
            .unwrap();
        };
        add(
            format!("{k}-linear"),
            format!("mode = \"linear\"\ndirection = \"{k}\""),
        );
        add(
            format!("{k}-linear-abbe"),
            format!("mode = \"linear\"\ndirection = \"{k}\"\noptic_offset = [0.0, 0.0, 100.0]"),
        );
        for s in a.senses {
            add(
                format!("{k}-straightness-{s}"),
                format!("mode = \"straightness\"\ndirection = \"{k}\"\nsense = \"{s}\""),
            );
        }
        for w in a.angles {
            add(
                format!("{k}-angular-{w}"),
                format!("mode = \"angular\"\ndirection = \"{k}\"\nabout = \"{w}\""),
            );
        }
    }
    let (x, y, z) = (300.0, 200.0, 200.0);
    for (i, (sx, sy, sz)) in [
        (1.0, 1.0, 1.0),
        (-1.0, 1.0, 1.0),
        (1.0, -1.0, 1.0),
        (1.0, 1.0, -1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let zc = -250.0;
        write!(
            plan,
            "[[run]]\nname = \"diagonal-{i}\"\ninstrument = \"laser\"\n{}\n\
             path = {{ from = {{ X = {}, Y = {}, Z = {} }}, to = {{ X = {}, Y = {}, Z = {} }}, points = 9 }}\n\
             [run.setup]\nmode = \"diagonal\"\ndirection = [{}, {}, {}]\n",
            noise,
            -sx * x,
            -sy * y,
            zc - sz * z,
            sx * x,
            sy * y,
            zc + sz * z,
            sx * 2.0 * x,
            sy * 2.0 * y,
            sz * 2.0 * z
        )
        .unwrap();
    }
    // The same body diagonal stepped one axis at a time (ISO 230-6), and a linear X run with
    // the laser on the spindle side (the beam turning with the tool).
    write!(
        plan,
        "[[run]]\nname = \"step-diagonal\"\ninstrument = \"laser\"\n{noise}\n\
         path = {{ from = {{ X = {}, Y = {}, Z = {} }}, to = {{ X = {x}, Y = {y}, Z = {} }}, points = 5 }}\n\
         [run.setup]\nmode = \"step-diagonal\"\ndirection = [{}, {}, {}]\n\
         [[run]]\nname = \"X-linear-table\"\ninstrument = \"laser\"\n{noise}\n\
         path = {{ axis = \"X\", from = -300.0, to = 300.0, points = 9, hold = {{ Y = 0.0, Z = -250.0 }} }}\n\
         [run.setup]\nmode = \"linear\"\ndirection = \"X\"\noptic = \"table\"\noptic_offset = [0.0, 0.0, 100.0]\n",
        -x,
        -y,
        -250.0 - z,
        -250.0 + z,
        2.0 * x,
        2.0 * y,
        2.0 * z
    )
    .unwrap();
    std::fs::write(dir.join("plan.toml"), plan).unwrap();
    simulate(&dir.join("plan.toml"), &dir.join("s")).unwrap_or_else(|e| panic!("{e}"));
    let (_, id) = identify_session(&dir.join("s")).unwrap_or_else(|e| panic!("{e}"));
    id
}

/// Every truth coefficient with its report name (`EXX.P1`, …, `EC0Y`).
fn truth_by_name() -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for (n, c) in truth() {
        if c.len() == 1 {
            out.push((n, c[0]));
        } else {
            let first = if c.len() == 2 { 2 } else { 1 };
            for (i, v) in c.iter().enumerate() {
                out.push((format!("{n}.P{}", first + i), *v));
            }
        }
    }
    out
}

#[test]
fn noise_free_laser_runs_recover_every_component_error() {
    let dir = tempfile::tempdir().unwrap();
    let id = run(dir.path(), false, 0);
    assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
    let truth = truth_by_name();
    assert_eq!(truth.len(), 42);
    let mut worst = 0.0f64;
    for (name, t) in &truth {
        let p = id
            .parameters
            .iter()
            .find(|p| &p.name == name)
            .unwrap_or_else(|| {
                let names: Vec<&str> = id.parameters.iter().map(|p| p.name.as_str()).collect();
                panic!("{name} not identified; parameters: {names:?}")
            });
        worst = worst.max((p.value - t).abs());
        assert!(
            (p.value - t).abs() < 1e-6,
            "{name}: {} vs truth {t} {}",
            p.value,
            p.unit
        );
    }
    assert!(id.fit.rms_um < 1e-6, "fit rms {} um", id.fit.rms_um);
    eprintln!("noise-free: worst coefficient error {worst:.2e} (um or urad)");
}

#[test]
fn noisy_laser_runs_give_honest_intervals() {
    let truth = truth_by_name();
    let (mut hits, mut n) = (0usize, 0usize);
    let mut ss = 0.0;
    for seed in 1..=8 {
        let dir = tempfile::tempdir().unwrap();
        let id = run(dir.path(), true, seed);
        assert!(id.unidentifiable.is_empty(), "{:?}", id.unidentifiable);
        for (name, t) in &truth {
            let p = id.parameters.iter().find(|p| &p.name == name).unwrap();
            let err = p.value - t;
            hits += usize::from(err.abs() <= p.u95);
            n += 1;
            ss += (err / p.u95 * 1.96).powi(2);
        }
    }
    let coverage = hits as f64 / n as f64;
    // Normalised errors err/σ should have unit variance.
    let z_rms = (ss / n as f64).sqrt();
    eprintln!("laser coverage {coverage:.3} over {n} intervals, rms(err/σ) {z_rms:.3}");
    assert!((0.90..=0.99).contains(&coverage), "coverage {coverage}");
    assert!((0.8..=1.2).contains(&z_rms), "rms(err/σ) {z_rms}");
}
