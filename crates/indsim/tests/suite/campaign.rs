//! The campaigns the identification tests use: they write sessions mtcal's loader accepts, with
//! the runs and validation runs the docs promise, and the realism knobs do what they say.

use mtcal_indsim::{Campaign, Realism};
use mtcal_session::{RunColumns, RunUse, load_session, read_run};

fn columns<'a>(instrument: &str, axes: &'a [char]) -> RunColumns<'a> {
    RunColumns {
        axes,
        readings: match instrument {
            "rtest" => &["dx", "dy", "dz"],
            _ => &["dr"],
        },
        readings_optional: false,
        labels: &[],
    }
}

#[test]
fn trunnion_campaign_is_a_valid_session() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let written = Campaign::trunnion_rtest_ballbar(&dir, 7, &Realism::ideal()).unwrap();
    let session = load_session(&dir).unwrap();
    assert!(
        session.machine.ends_with("machines/mcu630-cafyxz.urdf"),
        "{}",
        session.machine
    );
    let names: Vec<&str> = session.runs.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "rtest-xyc",
            "rtest-yza",
            "rtest-xyzac",
            "rtest-xyc-a+30",
            "rtest-xyc-a-30",
            "ballbar-xy-ccw",
            "ballbar-xy-cw",
            "ballbar-xy-c90",
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-a15",
            "ballbar-validate-c180"
        ]
    );
    let validate: Vec<&str> = session
        .runs
        .iter()
        .filter(|r| r.use_ == RunUse::Validate)
        .map(|r| r.name.as_str())
        .collect();
    assert_eq!(
        validate,
        [
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-a15",
            "ballbar-validate-c180"
        ]
    );
    let axes = ['X', 'Y', 'Z', 'A', 'C'];
    for run in &session.runs {
        let t = read_run(&run.file, &columns(&run.instrument, &axes)).unwrap();
        assert!(t.t.windows(2).all(|w| w[1] > w[0]));
        // A machine with errors of a few µm reads a few µm, not zero and not millimetres.
        let v = t.values.unwrap();
        let max = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(max > 0.5 && max < 500.0, "{}: {max} µm", run.name);
    }
    assert!(dir.join("truth/params.toml").is_file());
    assert_eq!(written.runs.len(), 12);
}

#[test]
fn three_axis_campaign_and_realism() {
    let tmp = tempfile::tempdir().unwrap();
    let ideal = Campaign::three_axis_ballbar(&tmp.path().join("a"), 3, &Realism::ideal()).unwrap();
    let real = Realism::realistic(11);
    let noisy = Campaign::three_axis_ballbar(&tmp.path().join("b"), 3, &real).unwrap();
    let session = load_session(&tmp.path().join("b")).unwrap();
    assert_eq!(session.runs.len(), 2);
    // The stated σ is the factor times the one used.
    let stated = session.setups["bar1"]["sigma_um"].as_float().unwrap();
    assert!((stated - real.noise_sigma_um * real.manifest_sigma_factor).abs() < 1e-12);
    for (a, b) in ideal.runs.iter().zip(noisy.runs.iter()) {
        // Same truth and path; the written readings are quantised to the resolution.
        for r in &b.written_um {
            let steps = r[0] / real.resolution_um;
            assert!((steps - steps.round()).abs() < 1e-6, "{}", r[0]);
        }
        // The noise (with the real set-up offsets in `clean_um`) has about the σ used.
        let res: Vec<f64> = b
            .written_um
            .iter()
            .zip(&b.clean_um)
            .map(|(w, c)| w[0] - c[0])
            .collect();
        let rms = (res.iter().map(|x| x * x).sum::<f64>() / res.len() as f64).sqrt();
        assert!((rms / real.noise_sigma_um - 1.0).abs() < 0.35, "rms {rms}");
        // AR(1): neighbouring noise values are correlated about φ.
        let lag1 = res.windows(2).map(|w| w[0] * w[1]).sum::<f64>()
            / res.iter().map(|x| x * x).sum::<f64>();
        assert!((lag1 - real.noise_phi).abs() < 0.2, "lag-1 {lag1}");
        // The real set-up differs from the stated one: the clean readings differ too.
        let moved = a
            .clean_um
            .iter()
            .zip(&b.clean_um)
            .map(|(x, y)| (x[0] - y[0]).abs())
            .fold(0.0, f64::max);
        assert!(moved > 1.0, "set-up offsets change the readings: {moved}");
    }
}

// ---------------------------------------------------------------------------------------------
// The five-axis layouts and the three-plane ball bar.

use mtcal_indsim::{FiveAxisLayout, JointKind, Machine, Truth, Written, shipped_machine};

fn duration_s(w: &Written) -> f64 {
    w.runs.last().unwrap().t.last().unwrap() - w.runs[0].t[0]
}

/// Reads every run of the session in `dir` back with mtcal's reader; every written position
/// within the machine's limits. Returns the run names and which are validation runs.
fn reads_back_within_limits(dir: &std::path::Path, file: &str) -> (Vec<String>, Vec<String>) {
    let session = load_session(dir).unwrap();
    assert!(session.machine.ends_with(file), "{}", session.machine);
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    let axes: Vec<char> = machine.letters().chars().collect();
    for run in &session.runs {
        let t = read_run(&run.file, &columns(&run.instrument, &axes)).unwrap();
        assert!(t.t.windows(2).all(|w| w[1] > w[0]), "{}", run.name);
        let n = t.t.len();
        assert!(n > 30, "{}: {n} samples", run.name);
        for k in 0..n {
            let q: Vec<f64> = (0..axes.len())
                .map(|i| {
                    let v = t.positions[k * axes.len() + i];
                    match machine.joints[i].kind {
                        JointKind::Linear => v * 1e-3,
                        JointKind::Rotary => v.to_radians(),
                    }
                })
                .collect();
            assert!(
                machine.within_limits(&q, 1e-9),
                "{} sample {k}: {q:?} leaves the limits",
                run.name
            );
        }
    }
    let names = session.runs.iter().map(|r| r.name.clone()).collect();
    let validate = session
        .runs
        .iter()
        .filter(|r| r.use_ == RunUse::Validate)
        .map(|r| r.name.clone())
        .collect();
    (names, validate)
}

/// The largest change (µm) of any clean reading between two sessions of the same runs.
fn largest_change_um(a: &Written, b: &Written) -> f64 {
    let mut worst = 0.0f64;
    for (ra, rb) in a.runs.iter().zip(b.runs.iter()) {
        assert_eq!(ra.name, rb.name);
        for (x, y) in ra.clean_um.iter().zip(&rb.clean_um) {
            for (u, v) in x.iter().zip(y) {
                worst = worst.max((u - v).abs());
            }
        }
    }
    worst
}

/// Each of the layout's location errors alone (20 µm or 20 µrad) moves some reading by more
/// than a micrometre: the session sees all of them.
fn responds_to_every_location_error(layout: FiveAxisLayout, tmp: &std::path::Path) {
    let machine = layout.machine().unwrap();
    let zero = Truth::zero(&machine);
    let base = Campaign::five_axis_check(layout, &tmp.join("zero"), &zero, &[], &Realism::ideal())
        .unwrap();
    let names = mtcal_indsim::truth::iso_location_names(&machine);
    assert!(names.len() >= 8, "{names:?}");
    let fitted = |w: &Written| -> Vec<f64> {
        let manifest = std::fs::read_to_string(w.dir.join("session.toml")).unwrap();
        w.runs
            .iter()
            .filter(|r| !is_validation(&manifest, &r.name))
            .flat_map(|r| r.clean_um.iter().flatten().copied())
            .collect()
    };
    let reference = fitted(&base);
    let mut columns = Vec::new();
    for name in &names {
        let mut truth = Truth::zero(&machine);
        truth.set(&machine, name, 20e-6).unwrap();
        let w = Campaign::five_axis_check(layout, &tmp.join(name), &truth, &[], &Realism::ideal())
            .unwrap();
        let moved = largest_change_um(&base, &w);
        eprintln!("{layout:?}: {name} moves the readings by up to {moved:.2} µm");
        assert!(moved > 1.0, "{layout:?}: {name} moves nothing ({moved} µm)");
        let col: Vec<f64> = fitted(&w)
            .iter()
            .zip(&reference)
            .map(|(a, b)| a - b)
            .collect();
        let norm = col.iter().map(|v| v * v).sum::<f64>().sqrt();
        columns.extend(col.into_iter().map(|v| v / norm));
    }
    // Together: the fitted runs' readings separate the location errors from one another (the
    // set-ups' own offsets aside): no combination of them leaves the readings nearly still.
    let j = nalgebra::DMatrix::from_column_slice(reference.len(), names.len(), &columns);
    let sv = j.singular_values();
    let (lo, hi) = (sv.min(), sv.max());
    eprintln!("{layout:?}: singular values of the normalised location columns {lo:.3e}..{hi:.3e}");
    assert!(lo > 1e-2 * hi, "{layout:?}: {sv}");
}

/// Whether the manifest marks run `name` `use = "validate"`.
fn is_validation(manifest: &str, name: &str) -> bool {
    manifest
        .split("[[run]]")
        .find(|b| b.contains(&format!("name = \"{name}\"\n")))
        .unwrap()
        .contains("use = \"validate\"")
}

fn five_axis_session_is_valid(layout: FiveAxisLayout, want: &[&str], validate: &[&str]) {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let machine = layout.machine().unwrap();
    let truth = Truth::random(
        &machine,
        &mut <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(9),
        1.0,
    );
    let w = Campaign::five_axis_check(layout, &dir, &truth, &[], &Realism::realistic(3)).unwrap();
    // mtcal loads it as a user's session (every plugin accepts its set-ups).
    mtcal_identify::Study::load(&dir).unwrap();
    let (names, got_validate) = reads_back_within_limits(&dir, layout.urdf_file());
    assert_eq!(names, want);
    assert_eq!(got_validate, validate);
    let samples: usize = w.runs.iter().map(|r| r.t.len()).sum();
    let minutes = duration_s(&w) / 60.0;
    eprintln!(
        "{layout:?}: {} runs, {samples} samples, {minutes:.1} min",
        w.runs.len()
    );
    assert!((28.0..36.0).contains(&minutes), "{minutes} min");
    // The first run is repeated at the end.
    let (first, end) = (&w.runs[0], w.runs.last().unwrap());
    assert_eq!(first.positions, end.positions);
    // The mount is written: the ball is on the table.
    let manifest = std::fs::read_to_string(dir.join("session.toml")).unwrap();
    assert!(manifest.contains("mount = \"ball-on-table\""), "{manifest}");
    responds_to_every_location_error(layout, tmp.path());
}

#[test]
fn table_table_campaign_is_a_valid_session_that_sees_every_location_error() {
    five_axis_session_is_valid(
        FiveAxisLayout::TableTable,
        &[
            "rtest-c",
            "ballbar-xy-ccw",
            "rtest-b",
            "ballbar-xy-cw",
            "rtest-validate",
            "rtest-bc",
            "ballbar-xy-c90",
            "rtest-c-b-45",
            "ballbar-validate",
            "rtest-c-b-75",
            "rtest-validate-b-30",
            "ballbar-validate-c180",
            "rtest-b-c90",
            "rtest-c-end",
        ],
        &[
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-b-30",
            "ballbar-validate-c180",
        ],
    );
}

#[test]
fn head_head_campaign_is_a_valid_session_that_sees_every_location_error() {
    five_axis_session_is_valid(
        FiveAxisLayout::HeadHead,
        &[
            "rtest-c",
            "ballbar-xy-ccw",
            "rtest-a",
            "ballbar-xy-cw",
            "rtest-validate",
            "rtest-ac",
            "ballbar-xy-a+30",
            "rtest-c-a-30",
            "ballbar-validate",
            "rtest-c-a+50",
            "rtest-validate-a-15",
            "ballbar-validate-c90",
            "rtest-a-c90",
            "rtest-c-end",
        ],
        &[
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-a-15",
            "ballbar-validate-c90",
        ],
    );
}

#[test]
fn mixed_campaign_is_a_valid_session_that_sees_every_location_error() {
    five_axis_session_is_valid(
        FiveAxisLayout::Mixed,
        &[
            "rtest-c",
            "ballbar-xy-ccw",
            "rtest-b",
            "ballbar-xy-cw",
            "rtest-validate",
            "rtest-bc",
            "ballbar-xy-c90",
            "rtest-c-b+30",
            "ballbar-validate",
            "rtest-c-b-30",
            "rtest-validate-b+15",
            "ballbar-validate-c180",
            "rtest-b-c90",
            "rtest-c-end",
        ],
        &[
            "rtest-validate",
            "ballbar-validate",
            "rtest-validate-b+15",
            "ballbar-validate-c180",
        ],
    );
}

#[test]
fn every_layout_has_its_machine_and_the_trunnion_is_its_thermal_check() {
    for layout in FiveAxisLayout::ALL {
        let m = layout.machine().unwrap();
        assert_eq!(m.letters().len(), 5, "{layout:?}");
    }
    let tmp = tempfile::tempdir().unwrap();
    let m = FiveAxisLayout::Trunnion.machine().unwrap();
    let truth = Truth::zero(&m);
    let a = Campaign::five_axis_check(
        FiveAxisLayout::Trunnion,
        &tmp.path().join("a"),
        &truth,
        &[],
        &Realism::ideal(),
    )
    .unwrap();
    let b = Campaign::trunnion_thermal_check(&tmp.path().join("b"), &truth, &[], &Realism::ideal())
        .unwrap();
    assert_eq!(a.runs.len(), b.runs.len());
    assert_eq!(largest_change_um(&a, &b), 0.0);
}

#[test]
fn three_axis_ballbar_planes_reads_back_times_its_samples_by_the_feed_and_sees_squareness() {
    let tmp = tempfile::tempdir().unwrap();
    let file = "mcv754-zfyx.urdf";
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    let zero = Truth::zero(&machine);
    let dir = tmp.path().join("s");
    let w = Campaign::three_axis_ballbar_planes(&dir, &zero, &[], &Realism::realistic(4)).unwrap();
    mtcal_identify::Study::load(&dir).unwrap();
    let (names, validate) = reads_back_within_limits(&dir, file);
    let mut want = Vec::new();
    for plane in ["xy", "yz", "zx"] {
        for feed in [1000, 3000] {
            for dir in ["ccw", "cw"] {
                want.push(format!("ballbar-{plane}-{dir}-f{feed}"));
            }
        }
        match plane {
            "xy" => want.push("ballbar-xy-cw-f2000".into()),
            "zx" => want.push("ballbar-zx-ccw-f2000".into()),
            _ => {}
        }
    }
    assert_eq!(names, want);
    assert_eq!(validate, ["ballbar-xy-cw-f2000", "ballbar-zx-ccw-f2000"]);
    let samples: usize = w.runs.iter().map(|r| r.t.len()).sum();
    eprintln!(
        "planes: {} runs, {samples} samples, {:.1} min",
        w.runs.len(),
        duration_s(&w) / 60.0
    );
    // The sample times follow the feed: 1° of a 150 mm arc at the run's feed (jitter aside).
    for r in &w.runs {
        let feed: f64 = r.name.rsplit("-f").next().unwrap().parse().unwrap();
        let want_s = 150.0 * 1f64.to_radians() / (feed / 60.0);
        let mean = (r.t.last().unwrap() - r.t[0]) / (r.t.len() - 1) as f64;
        assert!((mean / want_s - 1.0).abs() < 1e-2, "{}: {mean} s", r.name);
        // Full circles in XY (361 samples), 220° arcs otherwise (221).
        let n = if r.name.contains("-xy-") { 361 } else { 221 };
        assert_eq!(r.t.len(), n, "{}", r.name);
    }
    // Each out-of-squareness moves the tool across as its axis moves: EC0Y by ∓k·Y along X,
    // EA0Z by ∓k·Z along Y, EB0Z by ∓k·Z along X. The bar reads that along itself,
    // `u·Δ`, `u` the unit vector from the pivot to the tool ball: an ellipse at 45° in the
    // squareness' own plane, a centring offset in the planes where that axis is held.
    let ideal = Campaign::three_axis_ballbar_planes(
        &tmp.path().join("ideal"),
        &zero,
        &[],
        &Realism::ideal(),
    )
    .unwrap();
    for (name, axis, along) in [("EC0Y", 1, 0), ("EA0Z", 2, 1), ("EB0Z", 2, 0)] {
        let k = 20e-6;
        let mut truth = Truth::zero(&machine);
        truth.set(&machine, name, k).unwrap();
        let s = Campaign::three_axis_ballbar_planes(
            &tmp.path().join(name),
            &truth,
            &[],
            &Realism::ideal(),
        )
        .unwrap();
        let (mut dd, mut dp, mut pp, mut n) = (0.0, 0.0, 0.0, 0);
        let mut pairs = Vec::new();
        for (a, b) in s.runs.iter().zip(ideal.runs.iter()) {
            for (pos, (x, y)) in a.positions.iter().zip(a.clean_um.iter().zip(&b.clean_um)) {
                // The tool ball (mm, workpiece frame): X, Y, Z + 640 here; the pivot at
                // [0, 0, 160].
                let u = [pos[0], pos[1], pos[2] + 640.0 - 160.0].map(|v| v / 150.0);
                let d = x[0] - y[0];
                let p = u[along] * pos[axis] * 1e3; // µm per unit of k
                dd += d * d;
                dp += d * p;
                pp += p * p;
                n += 1;
                pairs.push((d, p));
            }
        }
        let c = dp / pp;
        let residual = ((dd - dp * dp / pp) / n as f64).max(0.0).sqrt();
        assert!((c.abs() / k - 1.0).abs() < 1e-3, "{name}: slope {c:e}");
        assert!(
            residual < 1e-3,
            "{name}: {residual} µm off the first-order reading"
        );
        let largest = pairs.iter().fold(0.0f64, |m, (d, _)| m.max(d.abs()));
        assert!(largest > 1.0, "{name}: {largest} µm");
    }
}

/// Set-ups placed by eye ([`Realism::setup_position_bound_um`]): up to 0.2 mm off nominal in
/// each coordinate, drawn from a stream of their own (the noise and sample times as without).
#[test]
fn setups_can_be_placed_up_to_two_tenths_of_a_millimetre_off() {
    let tmp = tempfile::tempdir().unwrap();
    let machine = FiveAxisLayout::TableTable.machine().unwrap();
    let truth = Truth::zero(&machine);
    let plain = Realism::realistic(6);
    let by_eye = Realism {
        setup_position_bound_um: 200.0,
        ..plain.clone()
    };
    let a = Campaign::table_table_check(&tmp.path().join("a"), &truth, &[], &plain).unwrap();
    let b = Campaign::table_table_check(&tmp.path().join("b"), &truth, &[], &by_eye).unwrap();
    let mut largest = 0.0f64;
    for ((name, oa), (_, ob)) in a.offsets.iter().zip(&b.offsets) {
        let extra = ob.position - oa.position;
        assert!(extra.amax() <= 200e-6, "{name}: {extra}");
        largest = largest.max(extra.amax());
        assert_eq!(oa.tool_length, ob.tool_length);
    }
    assert!(largest > 50e-6, "{largest}");
    for (ra, rb) in a.runs.iter().zip(b.runs.iter()) {
        assert_eq!(ra.t, rb.t);
        let noise = |r: &mtcal_indsim::WrittenRun| -> Vec<f64> {
            r.written_um
                .iter()
                .zip(&r.clean_um)
                .flat_map(|(w, c)| w.iter().zip(c).map(|(x, y)| x - y).collect::<Vec<_>>())
                .collect()
        };
        // The same noise, up to the 0.1 µm quantisation.
        for (x, y) in noise(ra).iter().zip(noise(rb)) {
            assert!((x - y).abs() <= 0.1 + 1e-9, "{}", ra.name);
        }
    }
    // The readings see the bigger offsets (a ball 0.1 mm off reads about that).
    assert!(largest_change_um(&a, &b) > 50.0);
}
