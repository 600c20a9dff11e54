//! The campaigns with effects: they load in mtcal as a user's session would
//! (`mtcal_identify::Study::load`), last as long as their docs say, write the context columns
//! where FORMATS.md puts them and `truth/effects.toml`, and — without effects — read what
//! mtcal's own prediction with the truth reads (the three-axis laser and tracer campaign, as
//! `agreement.rs` checks the other instruments).

use crate::common;

use std::path::Path;

use common::{positions_si, read_mtcal_run, truth_model};
use mtcal_identify::Study;
use mtcal_indsim::{
    Campaign, Effect, HeatSource, Machine, Programme, Realism, TemperatureProgramme, Truth,
    Written, shipped_machine,
};
use mtcal_instrument::{At, RunData};
use mtcal_session::{RunColumns, load_session, read_run};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn truth_of(file: &str, seed: u64) -> Truth {
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0)
}

fn duration_s(w: &Written) -> f64 {
    let first = w.runs.first().unwrap().t[0];
    let last = *w.runs.last().unwrap().t.last().unwrap();
    last - first
}

/// A warm-up of the head (two nodes, one on for 20 min then off), a scale warming by 1.5 K,
/// lost motion on X, a twist, the spindle speed driving a third node.
fn three_axis_effects() -> Vec<Effect> {
    let on_then_off = Programme::steps(&[(0.0, 1.0), (1200.0, 0.0)]);
    vec![
        Effect::SpindleSpeed {
            rpm: Programme::steps(&[(0.0, 6000.0), (900.0, 10000.0), (1500.0, 0.0)]),
        },
        Effect::Thermal {
            direction: [0.0, 0.0, 1.0],
            sources: vec![
                HeatSource {
                    gain: 8e-6,
                    tau_s: 900.0,
                    power: on_then_off.clone(),
                },
                HeatSource {
                    gain: 3e-6,
                    tau_s: 120.0,
                    power: on_then_off,
                },
                HeatSource {
                    gain: 0.4e-6,
                    tau_s: 300.0,
                    power: Programme::SpindleKrpm,
                },
            ],
        },
        Effect::ThermalScale {
            axis: 'Y',
            ppm_per_k: 10.0,
            reference: -0.27,
            temperature: TemperatureProgramme {
                ambient_c: 20.3,
                drift_k_per_h: 0.2,
                rises: vec![HeatSource {
                    gain: 1.5,
                    tau_s: 1200.0,
                    power: Programme::constant(1.0),
                }],
            },
            column: "T_yscale".into(),
        },
        Effect::Backlash {
            axis: 'X',
            lost_motion: 4e-6,
        },
        Effect::Twist { per_m2: 2e-5 },
    ]
}

/// The largest |indsim − mtcal| (µm) over every run of the session in `dir`, the noise-free
/// readings against mtcal's prediction with the truth's parameter files, both as changes from
/// the run's first sample (the laser and the tracer are zeroed there; mtcal carries the zero
/// as a nuisance).
fn worst_disagreement_um(dir: &Path) -> f64 {
    let session = load_session(dir).unwrap();
    let m = mtcal_machine::urdf::load_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
    let (model, coeffs) = truth_model(dir, &m);
    let mut ws = model.workspace();
    let mut worst = 0.0f64;
    for run in &session.runs {
        let common::MtcalRun { setup, clean, .. } = read_mtcal_run(dir, &session, run, &m);
        let q_all = positions_si(&clean, &m);
        let mut ours: Vec<f64> = (0..clean.len())
            .map(|k| clean.reading_row(k).unwrap()[0] * 1e-6)
            .collect();
        let q_flat: Vec<f64> = q_all.iter().flatten().copied().collect();
        setup
            .prepare_readings(
                &RunData {
                    q: &q_flat,
                    t: &clean.t,
                    context: &[],
                },
                &mut ours,
            )
            .unwrap();
        let nuisance = vec![0.0; setup.nuisance().len()];
        let mut out = vec![0.0; setup.channels().len()];
        let mut first = None;
        for (k, q) in q_all.iter().enumerate() {
            let pose = model.tool_pose(q, &coeffs, &mut ws);
            let at = At {
                q,
                t: clean.t[k],
                w_t_t: &pose,
                label: 0,
            };
            setup.predict(&at, &nuisance, &mut out);
            let base = *first.get_or_insert(out[0]);
            let theirs = (out[0] - base) * 1e6;
            let diff = (ours[k] * 1e6 - theirs).abs();
            // agreement.rs's 2e-9 µm per metre of reach; stations and reflector within 2 m.
            assert!(
                diff < 4e-9,
                "run {} sample {k}: indsim {} µm, mtcal {theirs} µm",
                run.name,
                ours[k] * 1e6
            );
            worst = worst.max(diff);
        }
    }
    worst
}

/// Per run of the session in `dir`: its name and the names of its context columns.
fn context_columns(dir: &Path) -> Vec<(String, Vec<String>)> {
    let session = load_session(dir).unwrap();
    let m = mtcal_machine::urdf::load_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
    let letters: Vec<char> = m.letters().chars().collect();
    session
        .runs
        .iter()
        .map(|run| {
            let readings: &[&str] = match run.instrument.as_str() {
                "rtest" => &["dx", "dy", "dz"],
                "ballbar" => &["dr"],
                _ => &["d"],
            };
            let cols = RunColumns {
                axes: &letters,
                readings,
                readings_optional: false,
                labels: &[],
            };
            let table = read_run(&run.file, &cols).unwrap();
            let names = table.context.iter().map(|(n, _)| n.clone()).collect();
            (run.name.clone(), names)
        })
        .collect()
}

#[test]
fn three_axis_laser_tracer_loads_in_mtcal_and_reads_its_prediction() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let truth = truth_of("mcv754-zfyx.urdf", 21);
    let w = Campaign::three_axis_laser_tracer(&dir, &truth, &[], &Realism::ideal()).unwrap();
    let study = Study::load(&dir).unwrap();
    let names: Vec<&str> = study.session.runs.iter().map(|r| r.name.as_str()).collect();
    let mut want = vec![
        "laser-x",
        "laser-y",
        "laser-z",
        "laser-x-straightness-y",
        "laser-y-straightness-x",
    ];
    let tracer: Vec<String> = (1..=3)
        .flat_map(|r| (1..=4).map(move |s| format!("tracer-s{s}-r{r}")))
        .collect();
    want.extend(tracer.iter().map(String::as_str));
    want.extend(["laser-diagonal", "tracer-check"]);
    assert_eq!(names, want);
    let validate: Vec<&str> = w
        .runs
        .iter()
        .zip(&study.session.runs)
        .filter(|(_, r)| r.use_ == mtcal_session::RunUse::Validate)
        .map(|(w, _)| w.name.as_str())
        .collect();
    assert_eq!(validate, ["laser-diagonal", "tracer-check"]);
    let samples: Vec<usize> = w.runs.iter().map(|r| r.t.len()).collect();
    assert_eq!(&samples[..5], &[73, 73, 73, 15, 11]);
    assert_eq!(samples.iter().sum::<usize>(), 1051);
    // 30.5 min: (1051 − 19) intervals of 1.5 s and 18 pauses of 15 s (+ 0.6 s each).
    let d = duration_s(&w);
    assert!((d - 1828.8).abs() < 1e-6, "{d} s");
    let worst = worst_disagreement_um(&dir);
    eprintln!("three-axis laser + tracer: max |indsim − mtcal| = {worst:e} µm");
    assert!(!dir.join("truth/effects.toml").exists());
    assert!(context_columns(&dir).iter().all(|(_, c)| c.is_empty()));
}

#[test]
fn three_axis_campaign_with_effects_loads_and_writes_its_context_in_every_run() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = truth_of("mcv754-zfyx.urdf", 22);
    for (name, realism) in [("ideal", Realism::ideal()), ("real", Realism::realistic(5))] {
        let dir = tmp.path().join(name);
        Campaign::three_axis_laser_tracer(&dir, &truth, &three_axis_effects(), &realism).unwrap();
        Study::load(&dir).unwrap_or_else(|e| panic!("{name}: {e}"));
        for (run, columns) in context_columns(&dir) {
            assert_eq!(columns, ["S", "T_yscale"], "{name} run {run}");
        }
        let planted: toml::Table = std::fs::read_to_string(dir.join("truth/effects.toml"))
            .unwrap()
            .parse()
            .unwrap();
        let kinds: Vec<&str> = planted["effect"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["kind"].as_str().unwrap())
            .collect();
        assert_eq!(
            kinds,
            [
                "spindle-speed",
                "thermal",
                "thermal-scale",
                "backlash",
                "twist"
            ]
        );
    }
}

#[test]
fn an_iso_230_2_run_shows_the_lost_motion_at_every_target() {
    // Lost motion alone: at each target the descending reading exceeds the ascending one by B
    // (the same command: the geometric errors cancel but for their change over the B between
    // the actual positions, slope · B ≈ 1e-5 · 4 µm).
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    let truth = truth_of("mcv754-zfyx.urdf", 23);
    let b_um = 4.0;
    let effects = [Effect::Backlash {
        axis: 'X',
        lost_motion: b_um * 1e-6,
    }];
    let w = Campaign::three_axis_laser_tracer(&dir, &truth, &effects, &Realism::ideal()).unwrap();
    let run = &w.runs[0];
    assert_eq!(run.name, "laser-x");
    // Cycle 1: overrun (0), ascending targets 1..=11, overrun (12), descending 13..=23.
    for j in 0..11 {
        let (up, down) = (1 + j, 23 - j);
        assert_eq!(run.positions[up], run.positions[down]);
        let reversal = run.clean_um[down][0] - run.clean_um[up][0];
        assert!((reversal - b_um).abs() < 1e-3, "target {j}: {reversal} µm");
    }
    // Y and Z have none.
    for r in &w.runs[1..3] {
        assert!(
            (r.clean_um[1][0] - r.clean_um[23][0]).abs() < 1e-9,
            "{}",
            r.name
        );
    }
}

#[test]
fn trunnion_campaign_with_effects_lasts_half_an_hour_and_writes_the_bar_temperature() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = truth_of("mcu630-cafyxz.urdf", 24);
    // Without effects: the runs of `trunnion_rtest_ballbar_with`, read alike, timed longer.
    let with =
        Campaign::trunnion_rtest_ballbar_with(&tmp.path().join("a"), &truth, &Realism::ideal())
            .unwrap();
    let none = Campaign::trunnion_rtest_ballbar_effects(
        &tmp.path().join("b"),
        &truth,
        &[],
        &Realism::ideal(),
    )
    .unwrap();
    for (a, b) in with.runs.iter().zip(none.runs.iter()) {
        assert_eq!(
            (&a.name, &a.positions, &a.clean_um),
            (&b.name, &b.positions, &b.clean_um)
        );
    }
    assert_eq!(none.runs.len(), 12);
    // 2196 samples: 2184 intervals of 0.75 s and 11 pauses of 15 s (+ 0.3 s each).
    assert!(
        (duration_s(&none) - 1806.3).abs() < 1e-6,
        "{} s",
        duration_s(&none)
    );

    let effects = vec![
        Effect::BallBarThermal {
            setup: "bar1".into(),
            ppm_per_k: 11.5,
            temperature: TemperatureProgramme {
                ambient_c: 20.5,
                drift_k_per_h: 0.5,
                rises: Vec::new(),
            },
            column: Some("T_bar".into()),
        },
        Effect::Thermal {
            direction: [0.0, 0.0, 1.0],
            sources: vec![HeatSource {
                gain: 10e-6,
                tau_s: 600.0,
                power: Programme::constant(1.0),
            }],
        },
    ];
    let dir = tmp.path().join("c");
    let warm = Campaign::trunnion_rtest_ballbar_effects(&dir, &truth, &effects, &Realism::ideal())
        .unwrap();
    Study::load(&dir).unwrap();
    for (run, columns) in context_columns(&dir) {
        let want: &[&str] = if run.starts_with("ballbar") {
            &["T_bar"]
        } else {
            &[]
        };
        assert_eq!(columns, want, "{run}");
    }
    // By the last R-test run (~28 min) the head has grown ~9.4 µm along +Z: the nest in the
    // spindle (its axes the machine's here) reads the table's ball that much lower.
    let at = |w: &Written| {
        let r = w
            .runs
            .iter()
            .find(|r| r.name == "rtest-validate-a15")
            .unwrap();
        (r.t[0], r.clean_um[0][2])
    };
    let (t, warm_dz) = at(&warm);
    let growth_um = 10.0 * (1.0 - (-t / 600.0f64).exp());
    let moved = warm_dz - at(&none).1;
    assert!((moved + growth_um).abs() < 1e-6, "{moved} µm at {t} s");
    assert!(growth_um > 9.0, "{growth_um} µm at {t} s");
    // The bar reads its own expansion: 11.5 ppm/K of 100 mm, 0.5 K/h.
    let bar = warm
        .runs
        .iter()
        .find(|r| r.name == "ballbar-xy-ccw")
        .unwrap();
    let plain = none
        .runs
        .iter()
        .find(|r| r.name == "ballbar-xy-ccw")
        .unwrap();
    for ((t, a), b) in bar.t.iter().zip(&bar.clean_um).zip(&plain.clean_um) {
        let want = -11.5e-6 * 0.5 * t / 3600.0 * 0.1 * 1e6;
        let growth = 10.0 * (1.0 - (-t / 600.0f64).exp());
        // The head's growth is along the bar's plane's normal: second order in the bar.
        assert!(
            (a[0] - b[0] - want).abs() < growth * growth / 1e5 + 1e-9,
            "{t} s"
        );
    }
}

/// The thermal check: the same runs as the trunnion campaign in an interleaved order, the first
/// XYC repeated at the end, every validation run inside the fitted time span.
#[test]
fn trunnion_thermal_check_interleaves_its_runs_and_repeats_the_first_at_the_end() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = truth_of("mcu630-cafyxz.urdf", 24);
    let plain =
        Campaign::trunnion_rtest_ballbar_with(&tmp.path().join("a"), &truth, &Realism::ideal())
            .unwrap();
    let check =
        Campaign::trunnion_thermal_check(&tmp.path().join("b"), &truth, &[], &Realism::ideal())
            .unwrap();
    assert_eq!(check.runs.len(), plain.runs.len() + 1);
    for run in &plain.runs {
        let same = check.runs.iter().find(|r| r.name == run.name).unwrap();
        assert_eq!(
            (&same.positions, &same.clean_um),
            (&run.positions, &run.clean_um)
        );
    }
    let first = &check.runs[0];
    let end = check.runs.last().unwrap();
    assert_eq!(
        (first.name.as_str(), end.name.as_str()),
        ("rtest-xyc", "rtest-xyc-end")
    );
    assert_eq!(
        (&first.positions, &first.clean_um),
        (&end.positions, &end.clean_um)
    );
    // 2341 samples: 2328 intervals of 0.75 s and 12 pauses of 15 s (+ 0.3 s each).
    assert!(
        (duration_s(&check) - 1929.6).abs() < 1e-6,
        "{} s",
        duration_s(&check)
    );
    let manifest = std::fs::read_to_string(tmp.path().join("b/session.toml")).unwrap();
    let validate_at: Vec<usize> = check
        .runs
        .iter()
        .enumerate()
        .filter(|(_, r)| {
            let block = manifest
                .split("[[run]]")
                .find(|b| b.contains(&format!("name = \"{}\"", r.name)))
                .unwrap();
            block.contains("use = \"validate\"")
        })
        .map(|(k, _)| k)
        .collect();
    assert_eq!(validate_at, [4, 8, 10, 11]);
}

/// A set-up creep ([`Effect::SetupCreep`]): the R-test ball `ball1` on the table settles by
/// `s·(1 − e^{−(t − t_s)/τ})` from its first sample on. Its readings move by that vector seen
/// from the nest (`Rᵀ·Δ`, R the tool's rotation in the workpiece frame); every other set-up
/// reads as without it.
#[test]
fn a_creeping_setup_moves_its_own_readings_only() {
    let tmp = tempfile::tempdir().unwrap();
    let file = "mcu630-cafyxz.urdf";
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    let truth = truth_of(file, 5);
    let settle_m = [3e-6, 0.0, -2e-6];
    let tau_s = 600.0;
    let creep = Effect::SetupCreep {
        setup: "ball1".into(),
        settle: settle_m,
        tau_s,
    };
    let write = |name: &str, effects: &[Effect]| {
        Campaign::trunnion_thermal_check(&tmp.path().join(name), &truth, effects, &Realism::ideal())
            .unwrap()
    };
    let moved = write("creep", &[creep]);
    let still = write("still", &[]);
    let mounted_s = moved.runs.iter().find(|r| r.setup == "ball1").unwrap().t[0];
    let (mut ball1_samples, mut worst_um) = (0, 0.0_f64);
    for (a, b) in moved.runs.iter().zip(still.runs.iter()) {
        assert_eq!((&a.name, &a.t), (&b.name, &b.t));
        if a.setup != "ball1" {
            assert_eq!(a.clean_um, b.clean_um, "{}", a.name);
            continue;
        }
        for (k, pos) in a.positions.iter().enumerate() {
            let q: Vec<f64> = pos
                .iter()
                .zip(&machine.joints)
                .map(|(v, j)| match j.kind {
                    mtcal_indsim::JointKind::Linear => v * 1e-3,
                    mtcal_indsim::JointKind::Rotary => v.to_radians(),
                })
                .collect();
            let rotation = machine
                .tool_in_workpiece(&q, Some(&truth))
                .fixed_view::<3, 3>(0, 0)
                .into_owned();
            let shift =
                nalgebra::Vector3::from(settle_m) * (1.0 - (-(a.t[k] - mounted_s) / tau_s).exp());
            let expected_um = rotation.transpose() * shift * 1e6;
            for c in 0..3 {
                let d = a.clean_um[k][c] - b.clean_um[k][c];
                worst_um = worst_um.max((d - expected_um[c]).abs());
            }
            ball1_samples += 1;
        }
    }
    assert!(ball1_samples > 500, "{ball1_samples}");
    assert!(worst_um < 1e-9, "{worst_um} µm");
    // The effect is written down with its parameters.
    let effects = std::fs::read_to_string(moved.dir.join("truth/effects.toml")).unwrap();
    assert!(
        effects.contains("setup-creep") && effects.contains("settle_um"),
        "{effects}"
    );
}

/// A creep on a set-up the plan does not have is refused, naming the effect and the set-up.
#[test]
fn a_creep_is_refused_on_an_unknown_setup() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = truth_of("mcu630-cafyxz.urdf", 5);
    let creep = Effect::SetupCreep {
        setup: "ball9".into(),
        settle: [1e-6, 0.0, 0.0],
        tau_s: 600.0,
    };
    let err = Campaign::trunnion_thermal_check(tmp.path(), &truth, &[creep], &Realism::ideal())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("setup-creep") && err.contains("no set-up ball9"),
        "{err}"
    );
}

/// A servo lag of X ([`Effect::ServoLag`]): X stands where it was commanded `T` earlier. The
/// ball bar reads that along the bar, `u_x·(c_x(t − T) − c_x(t))` to first order, `u` the unit
/// vector from the pivot to the tool ball: the 45° ellipse of a gain mismatch, turning with the
/// direction of the circle.
#[test]
fn a_servo_lag_moves_the_axis_by_its_following_error() {
    let tmp = tempfile::tempdir().unwrap();
    let file = "mcu630-cafyxz.urdf";
    let truth = truth_of(file, 5);
    let lag_s = 2e-3;
    let write = |name: &str, effects: &[Effect]| {
        Campaign::trunnion_thermal_check(&tmp.path().join(name), &truth, effects, &Realism::ideal())
            .unwrap()
    };
    let lagging = write("lag", &[Effect::ServoLag { axis: 'X', lag_s }]);
    let still = write("still", &[]);
    let (mut worst_um, mut largest_um, mut samples) = (0.0_f64, 0.0_f64, 0);
    for (a, b) in lagging.runs.iter().zip(still.runs.iter()) {
        if a.setup != "bar1" {
            continue;
        }
        // Run positions (mm), X first; the pivot at [0, 0, 200] mm in the workpiece frame and
        // the circle in XY, so the bar's direction in XY is the position over its length.
        // The commanded path is smooth between the samples (the control interpolates it):
        // its velocity at a sample is the slope between the neighbours (the chord's at the
        // run's end).
        let n = a.positions.len();
        for k in 1..n {
            let (x, y) = (a.positions[k][0], a.positions[k][1]);
            let ux = x / x.hypot(y);
            let (before, after) = (k - 1, (k + 1).min(n - 1));
            let dt = a.t[after] - a.t[before];
            let vx_mm_s = (a.positions[after][0] - a.positions[before][0]) / dt;
            let expected_um = -ux * vx_mm_s * lag_s * 1e3;
            let d = a.clean_um[k][0] - b.clean_um[k][0];
            worst_um = worst_um.max((d - expected_um).abs());
            largest_um = largest_um.max(d.abs());
            samples += 1;
        }
    }
    assert!(samples > 1000, "{samples}");
    // A bar 2 ms behind at about 2.3 mm/s: microns; the first-order reading holds to within
    // the geometric errors' share of it.
    assert!(largest_um > 1.0, "{largest_um} µm");
    assert!(
        worst_um < 0.02 * largest_um,
        "{worst_um} of {largest_um} µm"
    );
    let effects = std::fs::read_to_string(lagging.dir.join("truth/effects.toml")).unwrap();
    assert!(
        effects.contains("servo-lag") && effects.contains("lag_ms"),
        "{effects}"
    );
}

/// A reversal spike on X ([`Effect::ReversalSpike`]) in the three-plane ball-bar session: the
/// first circle (counter-clockwise from +X at 1000 mm/min) reverses X at once (the axis was
/// brought to its start from below) and again at 180°; after each X trails by
/// `−s·h·(1 + Δt/T)·e^{−Δt/T}` and the bar reads that along itself, `u_x·e_x` (first order).
#[test]
fn a_reversal_spike_shows_on_the_ball_bar_where_x_reverses() {
    let tmp = tempfile::tempdir().unwrap();
    let truth = truth_of("mcv754-zfyx.urdf", 8);
    let (h, t_rec) = (5e-6, 0.5);
    let spike = Effect::ReversalSpike {
        axis: 'X',
        height: h,
        recovery_s: t_rec,
    };
    let with = Campaign::three_axis_ballbar_planes(
        &tmp.path().join("a"),
        &truth,
        &[spike],
        &Realism::ideal(),
    )
    .unwrap();
    let without =
        Campaign::three_axis_ballbar_planes(&tmp.path().join("b"), &truth, &[], &Realism::ideal())
            .unwrap();
    let (a, b) = (&with.runs[0], &without.runs[0]);
    assert_eq!(a.name, "ballbar-xy-ccw-f1000");
    let mut largest = 0.0f64;
    for k in 1..a.t.len() {
        // Sample k is at k° of the circle; X moves down until 180°, then up.
        let (sense, at) = if k <= 180 {
            (-1.0, a.t[0])
        } else {
            (1.0, a.t[180])
        };
        let r = (a.t[k] - at) / t_rec;
        let e_x = -sense * h * (1.0 + r) * (-r).exp();
        let u_x = (k as f64).to_radians().cos();
        let want_um = u_x * e_x * 1e6;
        let got_um = a.clean_um[k][0] - b.clean_um[k][0];
        assert!(
            (got_um - want_um).abs() < 1e-3,
            "sample {k}: {got_um} µm, want {want_um} µm"
        );
        largest = largest.max(got_um.abs());
    }
    assert!(largest > 4.0, "{largest} µm");
}
