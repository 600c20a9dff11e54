//! The effects by hand: each on the three-axis machine of the crate's unit tests (`SIMPLE`:
//! the tool point at `(X, Y, Z + 0.4 m)` in the workpiece frame, whose axes are the machine's),
//! with numbers that can be worked out on paper.

use std::path::Path;

use nalgebra::Vector3;

use super::*;
use crate::instruments::{GeometricOnly, Instrument, LaserMode, Mount, SetupOffsets};
use crate::session::{Plan, Realism, RunPlan, SetupPlan, SimError, Written, write_session};
use crate::tests::SIMPLE;

const UM: f64 = 1e-6;

fn simple() -> Machine {
    Machine::from_urdf_text(SIMPLE).unwrap()
}

fn rtest(mount: Mount, ball_mm: [f64; 3]) -> Instrument {
    Instrument::RTest {
        ball_mm,
        mount,
        write_mount_key: true,
    }
}

/// Noise-free readings (m) of `instrument` over `poses` at `times` with `effects`, the truth
/// zero and the set-up as stated.
fn read(
    effects: &[Effect],
    instrument: &Instrument,
    poses: &[Vec<f64>],
    times: &[f64],
) -> Vec<Vec<f64>> {
    let m = simple();
    let resolved = Resolved::new(&m, &[], effects).unwrap();
    let states = Timeline::new(&resolved).run(poses, times);
    instrument.readings(
        &m,
        &Truth::zero(&m),
        poses,
        &[],
        &SetupOffsets::default(),
        states.as_slice(),
    )
}

fn assert_close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got:e}, want {want:e} (diff {:e})",
        got - want
    );
}

/// Writes a session of `SIMPLE` (the URDF beside it) with `setups`, `runs` and `effects`.
fn session(
    dir: &Path,
    setups: Vec<SetupPlan>,
    runs: Vec<RunPlan>,
    effects: Vec<Effect>,
    realism: &Realism,
) -> Result<Written, SimError> {
    std::fs::create_dir_all(dir)?;
    let urdf = dir.join("simple.urdf");
    std::fs::write(&urdf, SIMPLE)?;
    let plan = Plan {
        machine_urdf: urdf,
        setups,
        runs,
        effects,
    };
    write_session(
        &dir.join("s"),
        &simple(),
        &Truth::zero(&simple()),
        &plan,
        realism,
    )
}

fn setup(name: &str, instrument: Instrument) -> SetupPlan {
    SetupPlan {
        name: name.into(),
        instrument,
    }
}

fn run(name: &str, setup: &str, poses: Vec<Vec<f64>>) -> RunPlan {
    RunPlan {
        name: name.into(),
        setup: setup.into(),
        validate: false,
        poses,
        labels: Vec::new(),
        interval_s: None,
        pause_before_s: None,
    }
}

fn x_at(xs_um: &[f64]) -> Vec<Vec<f64>> {
    xs_um.iter().map(|&x| vec![x * UM, 0.0, -0.2]).collect()
}

/// A temperature that steps up by `rise_k` at once (a node of 1 ms from t = 0: at every sample
/// time, e^{−t/τ} underflows to zero).
fn stepped(rise_k: f64) -> TemperatureProgramme {
    TemperatureProgramme {
        ambient_c: 20.0,
        drift_k_per_h: 0.0,
        rises: vec![HeatSource {
            gain: rise_k,
            tau_s: 1e-3,
            power: Programme::constant(1.0),
        }],
    }
}

#[test]
fn backlash_takes_up_the_play_only_after_the_command_has_travelled_it() {
    // B = 4 µm: from below at 0 (a = −2), up to 10 (a = 8), back to 7 (inside the play: the
    // axis does not move), 5 (the play taken up: a = 7), 3 (a = 5), up to 6 (play: stays 5),
    // 9 (a = 7).
    let m = simple();
    let resolved = Resolved::new(
        &m,
        &[],
        &[Effect::Backlash {
            axis: 'X',
            lost_motion: 4.0 * UM,
        }],
    )
    .unwrap();
    let mut timeline = Timeline::new(&resolved);
    let commands = [0.0, 10.0, 7.0, 5.0, 3.0, 6.0, 9.0];
    let want = [-2.0, 8.0, 8.0, 7.0, 5.0, 5.0, 7.0];
    let states = timeline.run(&x_at(&commands), &[0.0; 7]);
    for ((s, c), w) in states.iter().zip(commands).zip(want) {
        let a = s.axes(&[c * UM, 0.0, 0.0])[0];
        assert_close(a / UM, w, 1e-9, &format!("actual X at command {c} µm"));
    }
    // The state carries into the next run: from a = 7 at 9, the command 8 is inside the play,
    // 4 takes it up (a = 6).
    let next = timeline.run(&x_at(&[8.0, 4.0]), &[1.0, 2.0]);
    assert_close(next[0].axes(&[8.0 * UM, 0.0, 0.0])[0] / UM, 7.0, 1e-9, "8");
    assert_close(next[1].axes(&[4.0 * UM, 0.0, 0.0])[0] / UM, 6.0, 1e-9, "4");
}

#[test]
fn backlash_reads_as_lost_motion_on_a_laser_and_carries_over_between_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let laser = Instrument::Laser {
        mode: LaserMode::Linear,
        direction: [1.0, 0.0, 0.0],
        across: [0.0; 3],
        optic_offset_mm: [0.0; 3],
    };
    // Out and back by 10 mm steps: the laser, zeroed at the first sample (lagging B/2), reads
    // 0 going out and +B coming back (the axis leads by B/2). The next run starts at 0 where
    // the last one ended (leading) and goes up: the play is taken up, −B.
    let b = 4.0;
    let w = session(
        tmp.path(),
        vec![setup("l1", laser.clone()), setup("l2", laser)],
        vec![
            run("out-back", "l1", x_at(&[0.0, 1e4, 2e4, 1e4, 0.0])),
            run("up-again", "l2", x_at(&[0.0, 1e4])),
        ],
        vec![Effect::Backlash {
            axis: 'X',
            lost_motion: b * UM,
        }],
        &Realism::ideal(),
    )
    .unwrap();
    let got: Vec<Vec<f64>> = w
        .runs
        .iter()
        .map(|r| r.clean_um.iter().map(|v| v[0]).collect())
        .collect();
    for (g, want) in got[0].iter().zip([0.0, 0.0, 0.0, b, b]) {
        assert_close(*g, want, 1e-9, "out and back (µm)");
    }
    for (g, want) in got[1].iter().zip([0.0, -b]) {
        assert_close(*g, want, 1e-9, "the next run (µm)");
    }
}

/// A node for [`euler`]: gain, τ (s), programme steps.
type EulerNode<'a> = (f64, f64, &'a [(f64, f64)]);

/// Σ gain·x of `nodes` at `times` (on the grid of `h`), by forward Euler steps of `h` with the
/// programme's value at the start of each step.
fn euler(nodes: &[EulerNode<'_>], times: &[f64], h: f64) -> Vec<f64> {
    let mut x = vec![0.0; nodes.len()];
    let mut out = Vec::new();
    let mut k = 0u64;
    for &t in times {
        while (k as f64) * h < t - 0.5 * h {
            let now = k as f64 * h;
            for (xi, (_, tau, steps)) in x.iter_mut().zip(nodes) {
                *xi += h * (value_at(steps, now) - *xi) / tau;
            }
            k += 1;
        }
        out.push(nodes.iter().zip(&x).map(|((g, _, _), xi)| g * xi).sum());
    }
    out
}

#[test]
fn two_node_thermal_growth_is_the_exact_response_of_a_fine_integration() {
    // A fast and a slow node, both switched off later (cool-down), the second stepping twice.
    let slow: &[(f64, f64)] = &[(0.0, 1.0), (1200.0, 0.0)];
    let fast: &[(f64, f64)] = &[(100.0, 0.5), (700.0, 1.0), (1500.0, 0.0)];
    let (g1, tau1, g2, tau2) = (12.0 * UM, 600.0, 5.0 * UM, 90.0);
    let effect = Effect::Thermal {
        direction: [0.0, 0.0, 2.0],
        sources: vec![
            HeatSource {
                gain: g1,
                tau_s: tau1,
                power: Programme::steps(slow),
            },
            HeatSource {
                gain: g2,
                tau_s: tau2,
                power: Programme::steps(fast),
            },
        ],
    };
    let times: Vec<f64> = (0..=12).map(|k| 250.0 * k as f64).collect();
    let m = simple();
    let resolved = Resolved::new(&m, &[], &[effect]).unwrap();
    let states = Timeline::new(&resolved).run(&vec![vec![0.0, 0.0, -0.2]; times.len()], &times);
    // Euler with 1 ms steps: its error (h/2τ of the state) is below 1e-10 m here.
    let reference = euler(&[(g1, tau1, slow), (g2, tau2, fast)], &times, 1e-3);
    for ((s, want), t) in states.iter().zip(reference).zip(&times) {
        let d = s.tool_shift(&[0.0, 0.0, -0.2]);
        assert_close(
            d.z,
            want,
            1e-9,
            &format!("growth along +Z at t = {t} s (m)"),
        );
        assert!(d.x == 0.0 && d.y == 0.0, "{d}");
    }
    // It did grow, and cooled down: a few µm at 1200 s, less at 3000 s.
    let at = |k: usize| states[k].tool_shift(&[0.0; 3]).z;
    assert!(
        at(4) > 5.0 * UM && at(12) < 0.3 * at(4),
        "{} {}",
        at(4),
        at(12)
    );
}

#[test]
fn a_cool_down_decays_with_its_time_constant() {
    let tau = 300.0;
    let off = 2000.0;
    let steps = [(0.0, 1.0), (off, 0.0)];
    let x = |t| first_order_response(&steps, tau, t);
    // Heating: 1 − e^{−t/τ}; switched off: the state at `off` decays as e^{−(t − off)/τ}.
    assert_close(x(tau), 1.0 - (-1.0f64).exp(), 1e-15, "x(τ)");
    let x_off = 1.0 - (-off / tau).exp();
    assert_close(x(off), x_off, 1e-15, "x(off)");
    assert_close(x(off + tau), x_off * (-1.0f64).exp(), 1e-15, "one τ later");
    assert_close(
        x(off + 2.0 * tau),
        x_off * (-2.0f64).exp(),
        1e-15,
        "two τ later",
    );
    assert_eq!(x(0.0), 0.0);
    // A programme that starts later: cold until then.
    assert_eq!(first_order_response(&[(50.0, 1.0)], tau, 40.0), 0.0);
}

#[test]
fn a_screw_error_puts_the_axis_beyond_its_command_at_a_positive_sine() {
    // Pitch 10 mm, 2 µm at the first harmonic: a quarter pitch in, the axis is 2 µm beyond its
    // command; three quarters in, 2 µm short. The R-test with the ball in the spindle reads
    // the tool point minus the nest: +2 µm along X, then −2 µm. A second harmonic of 1 µm at
    // phase π/2 adds sin(π + π/2) = −1 µm a quarter pitch in.
    let nest = |x_mm: f64| rtest(Mount::BallInSpindle, [x_mm, 0.0, 200.0]);
    let effect = |harmonics| Effect::ScrewError {
        axis: 'X',
        pitch: 0.01,
        harmonics,
    };
    let at = |x_mm: f64| vec![vec![x_mm * 1e-3, 0.0, -0.2]];
    let one = vec![effect(vec![(1, 2.0 * UM, 0.0)])];
    let dx = |e: &[Effect], x_mm| read(e, &nest(x_mm), &at(x_mm), &[0.0])[0][0] / UM;
    assert_close(dx(&one, 2.5), 2.0, 1e-9, "a quarter pitch in (µm)");
    assert_close(dx(&one, 7.5), -2.0, 1e-9, "three quarters in (µm)");
    let two = vec![effect(vec![
        (1, 2.0 * UM, 0.0),
        (2, UM, std::f64::consts::FRAC_PI_2),
    ])];
    assert_close(dx(&two, 2.5), 1.0, 1e-9, "with the second harmonic (µm)");
}

#[test]
fn a_thermal_scale_vanishes_at_its_reference_and_grows_away_from_it() {
    // 10 ppm/K, 2 K warmer, fixed at X = 100 mm: at 300 mm the axis overshoots by
    // 10e-6·2·0.2 m = 4 µm, at −100 mm it falls 4 µm short, at 100 mm nothing.
    let effects = vec![Effect::ThermalScale {
        axis: 'X',
        ppm_per_k: 10.0,
        reference: 0.1,
        temperature: stepped(2.0),
        column: "T_xscale".into(),
    }];
    for (x_mm, want) in [(100.0, 0.0), (300.0, 4.0), (-100.0, -4.0)] {
        let nest = rtest(Mount::BallInSpindle, [x_mm, 0.0, 200.0]);
        let r = read(&effects, &nest, &[vec![x_mm * 1e-3, 0.0, -0.2]], &[5.0]);
        assert_close(
            r[0][0] / UM,
            want,
            1e-9,
            &format!("dx at X = {x_mm} mm (µm)"),
        );
    }
    // Before it warms (t = 0), nothing anywhere.
    let nest = rtest(Mount::BallInSpindle, [300.0, 0.0, 200.0]);
    let r = read(&effects, &nest, &[vec![0.3, 0.0, -0.2]], &[0.0]);
    assert!(r[0][0].abs() < 1e-15, "{r:?}");
}

#[test]
fn twist_raises_the_tool_by_k_x_y_on_both_r_test_mounts_and_the_ball_bar() {
    // k = 1e-4 m/m² at X = 0.1, Y = 0.2 m: the tool point 2 µm higher (+Z) relative to the
    // workpiece. Ball in the spindle: tool minus nest, dz = +2 µm; ball on the table: ball
    // minus nest along the tool frame's axes (turned about Z only on this machine, so dz is
    // along machine Z), dz = −2 µm; a ball bar standing
    // vertically under the tool (pivot 100 mm below) is 2 µm longer.
    let effects = vec![Effect::Twist { per_m2: 1e-4 }];
    let q = vec![vec![0.1, 0.2, -0.2]];
    // The tool point there: (0.1, 0.2, 0.2) m.
    let point = [100.0, 200.0, 200.0];
    let spindle = read(&effects, &rtest(Mount::BallInSpindle, point), &q, &[0.0]);
    let table = read(&effects, &rtest(Mount::BallOnTable, point), &q, &[0.0]);
    let bar = Instrument::BallBar {
        pivot_mm: [100.0, 200.0, 100.0],
        length_mm: 100.0,
    };
    let dr = read(&effects, &bar, &q, &[0.0]);
    assert_close(
        spindle[0][2] / UM,
        2.0,
        1e-9,
        "ball in the spindle, dz (µm)",
    );
    assert_close(table[0][2] / UM, -2.0, 1e-9, "ball on the table, dz (µm)");
    assert!(spindle[0][0].abs() < 1e-15 && spindle[0][1].abs() < 1e-15);
    assert_close(dr[0][0] / UM, 2.0, 1e-9, "vertical ball bar (µm)");
    // Opposite quadrant, opposite sign: x·y < 0.
    let q = vec![vec![-0.1, 0.2, -0.2]];
    let r = read(
        &effects,
        &rtest(Mount::BallInSpindle, [-100.0, 200.0, 200.0]),
        &q,
        &[0.0],
    );
    assert_close(r[0][2] / UM, -2.0, 1e-9, "x < 0 (µm)");
}

#[test]
fn sag_displaces_along_its_direction_by_k_q_squared() {
    // k = 5e-5 m/m² on Z, along X: at Z = −0.2 m the tool is 5e-5·0.04 m = 2 µm further +X.
    let effects = vec![Effect::Sag {
        axis: 'Z',
        direction: 'X',
        per_m2: 5e-5,
    }];
    let r = read(
        &effects,
        &rtest(Mount::BallInSpindle, [0.0, 0.0, 200.0]),
        &[vec![0.0, 0.0, -0.2]],
        &[0.0],
    );
    assert_close(r[0][0] / UM, 2.0, 1e-9, "dx (µm)");
    assert!(r[0][1].abs() < 1e-15 && r[0][2].abs() < 1e-15, "{r:?}");
}

#[test]
fn every_instrument_sees_the_same_tool_displacement() {
    // The head grows by 5 µm along +Z at once at t = 10 s (a node of 1 µs switched on then).
    // At the pose X = 0.1, Y = 0.05, Z = −0.2 m (tool point (0.1, 0.05, 0.2) m):
    let effects = vec![Effect::Thermal {
        direction: [0.0, 0.0, 1.0],
        sources: vec![HeatSource {
            gain: 5.0 * UM,
            tau_s: 1e-6,
            power: Programme::steps(&[(10.0, 1.0)]),
        }],
    }];
    let q = vec![vec![0.1, 0.05, -0.2]; 2];
    let times = [5.0, 20.0];
    let tip = [100.0, 50.0, 200.0];
    let cases: Vec<(&str, Instrument, usize, f64)> = vec![
        (
            "R-test, ball in the spindle",
            rtest(Mount::BallInSpindle, tip),
            2,
            5.0,
        ),
        (
            "R-test, ball on the table",
            rtest(Mount::BallOnTable, tip),
            2,
            -5.0,
        ),
        (
            "vertical ball bar",
            Instrument::BallBar {
                pivot_mm: [100.0, 50.0, 100.0],
                length_mm: 100.0,
            },
            0,
            5.0,
        ),
        (
            "laser along Z (zeroed before the step)",
            Instrument::Laser {
                mode: LaserMode::Linear,
                direction: [0.0, 0.0, 1.0],
                across: [0.0; 3],
                optic_offset_mm: [0.0, 0.0, -50.0],
            },
            0,
            5.0,
        ),
        (
            "tracer straight below (zeroed before the step)",
            Instrument::Tracer {
                station_mm: [100.0, 50.0, -300.0],
                reflector_mm: [0.0; 3],
            },
            0,
            5.0,
        ),
        (
            "displacement sensor along Z",
            Instrument::Displacement {
                position_mm: tip,
                sensors: vec![crate::DisplacementSensor {
                    name: "z".into(),
                    direction: crate::SensorDirection::Axis {
                        letter: 'Z',
                        negative: false,
                    },
                    at_mm: None,
                }],
            },
            0,
            5.0,
        ),
    ];
    for (what, instrument, channel, want) in cases {
        let r = read(&effects, &instrument, &q, &times);
        assert!(r[0][channel].abs() < 1e-12, "{what} before: {r:?}");
        assert_close(r[1][channel] / UM, want, 1e-6, what);
    }
    // A 3-D plate: the axis position at which the actual tool sits on a feature's centre is
    // 5 µm lower in Z once the head has grown.
    let plate = Instrument::Artefact {
        features: vec![("f".into(), vec![0.0, 0.0, 0.0])],
        placements: vec![crate::PlatePlacement {
            name: "p".into(),
            origin_mm: [100.0, 50.0, -200.0],
            rotation_deg: 0.0,
            flipped: false,
        }],
        probed: crate::Probed::Commanded,
    };
    let m = simple();
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let states = Timeline::new(&resolved).run(&q, &times);
    let labels = vec!["f".to_string(); 2];
    let r = plate.readings(
        &m,
        &Truth::zero(&m),
        &q,
        &labels,
        &SetupOffsets::default(),
        states.as_slice(),
    );
    assert_close(r[0][2], -0.2, 1e-15, "plate z before (m)");
    assert_close((r[1][2] + 0.2) / UM, -5.0, 1e-6, "plate z after (µm)");
}

#[test]
fn zero_sized_effects_read_exactly_what_no_effects_read() {
    // The composed chain with nothing in it is the geometric model's, to the bit, on every
    // instrument kind of this test (so that planting an effect changes only what it plants).
    let zero = vec![
        Effect::Backlash {
            axis: 'Y',
            lost_motion: 0.0,
        },
        Effect::Twist { per_m2: 0.0 },
        Effect::ScrewError {
            axis: 'Z',
            pitch: 0.005,
            harmonics: vec![(1, 0.0, 0.3)],
        },
    ];
    let q: Vec<Vec<f64>> = (0..5)
        .map(|k| vec![0.01 * k as f64, -0.02 * k as f64, -0.1 - 0.01 * k as f64])
        .collect();
    let times: Vec<f64> = (0..5).map(|k| k as f64).collect();
    let m = simple();
    let mut truth = Truth::zero(&m);
    truth.set(&m, "EC0Y", 12e-6).unwrap();
    truth.axes[0].component[1][2] = 3e-6;
    let instruments = [
        rtest(Mount::BallOnTable, [10.0, 20.0, 300.0]),
        Instrument::BallBar {
            pivot_mm: [0.0, 0.0, 250.0],
            length_mm: 100.0,
        },
        Instrument::Tracer {
            station_mm: [300.0, 200.0, 0.0],
            reflector_mm: [10.0, 0.0, 30.0],
        },
    ];
    let resolved = Resolved::new(&m, &[], &zero).unwrap();
    let states = Timeline::new(&resolved).run(&q, &times);
    let off = SetupOffsets::default();
    for i in &instruments {
        let with = i.readings(&m, &truth, &q, &[], &off, states.as_slice());
        let without = i.readings(&m, &truth, &q, &[], &off, &GeometricOnly);
        assert_eq!(with, without, "{}", i.plugin_name());
    }
}

/// The `name` column of a run file, or `None`.
fn column(path: &Path, name: &str) -> Option<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let j = header.iter().position(|h| *h == name)?;
    Some(
        lines
            .map(|l| l.split(',').nth(j).unwrap().parse().unwrap())
            .collect(),
    )
}

#[test]
fn temperatures_are_written_where_they_belong_and_the_bar_reads_its_own() {
    let tmp = tempfile::tempdir().unwrap();
    // A scale warming by 3 K with τ = 600 s, and a bar warming by 2 K with τ = 100 s (11.5
    // ppm/K, 100 mm: up to 2.3 µm shorter), over runs of an R-test and a bar, 5 s apart.
    let scale_t = TemperatureProgramme {
        ambient_c: 20.0,
        drift_k_per_h: 0.0,
        rises: vec![HeatSource {
            gain: 3.0,
            tau_s: 600.0,
            power: Programme::constant(1.0),
        }],
    };
    let bar_t = TemperatureProgramme {
        ambient_c: 21.0,
        drift_k_per_h: 0.0,
        rises: vec![HeatSource {
            gain: 2.0,
            tau_s: 100.0,
            power: Programme::constant(1.0),
        }],
    };
    let effects = vec![
        Effect::ThermalScale {
            axis: 'X',
            ppm_per_k: 0.0,
            reference: 0.0,
            temperature: scale_t,
            column: "T_xscale".into(),
        },
        Effect::BallBarThermal {
            setup: "bar".into(),
            ppm_per_k: 11.5,
            temperature: bar_t,
            column: Some("T_bar".into()),
        },
    ];
    let circle = |n: usize| -> Vec<Vec<f64>> {
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                vec![0.1 * a.cos(), 0.1 * a.sin(), -0.2]
            })
            .collect()
    };
    let setups = vec![
        setup("ball", rtest(Mount::BallOnTable, [0.0, 0.0, 200.0])),
        setup(
            "bar",
            Instrument::BallBar {
                pivot_mm: [0.0, 0.0, 200.0],
                length_mm: 100.0,
            },
        ),
    ];
    let runs = vec![
        run("rtest", "ball", vec![vec![0.0, 0.0, -0.2]; 20]),
        run("bar", "bar", circle(40)),
    ];
    let realism = Realism {
        interval_s: 5.0,
        ..Realism::ideal()
    };
    let w = session(tmp.path(), setups, runs, effects, &realism).unwrap();
    let dir = tmp.path().join("s");
    for r in &w.runs {
        let path = dir.join(&r.file);
        let scale = column(&path, "T_xscale").expect("the scale's column in every run");
        for (t, v) in r.t.iter().zip(scale) {
            let want = 20.0 + 3.0 * (1.0 - (-t / 600.0).exp());
            assert_close(v, want, 1e-12, &format!("T_xscale at {t} s"));
        }
        let bar = column(&path, "T_bar");
        assert_eq!(bar.is_some(), r.setup == "bar", "{}", r.name);
        let header = std::fs::read_to_string(&path).unwrap();
        let first = header.lines().next().unwrap();
        assert!(
            first.ends_with(if r.setup == "bar" {
                "dr,T_xscale,T_bar"
            } else {
                "dz,T_xscale"
            }),
            "{first}"
        );
    }
    // The bar's reading drops by α·ΔT·L; the R-test does not see the bar's temperature.
    let bar = &w.runs[1];
    for (t, dr) in bar.t.iter().zip(&bar.clean_um) {
        let want = -11.5e-6 * 2.0 * (1.0 - (-t / 100.0).exp()) * 0.1 / UM;
        assert_close(dr[0], want, 1e-9, &format!("dr at {t} s (µm)"));
    }
    assert!(
        w.runs[0]
            .clean_um
            .iter()
            .all(|r| r.iter().all(|v| v.abs() < 1e-9))
    );
    // A realistic sensor: 0.01 K steps, about 0.02 K of noise.
    let w = session(
        &tmp.path().join("real"),
        vec![setup("ball", rtest(Mount::BallOnTable, [0.0, 0.0, 200.0]))],
        vec![run("rtest", "ball", vec![vec![0.0, 0.0, -0.2]; 400])],
        vec![Effect::ThermalScale {
            axis: 'X',
            ppm_per_k: 0.0,
            reference: 0.0,
            temperature: TemperatureProgramme::constant(20.0),
            column: "T_xscale".into(),
        }],
        &Realism::realistic(3),
    )
    .unwrap();
    let (_, read) = &w.runs[0].context[0];
    for v in read {
        assert!(((v / 0.01) - (v / 0.01).round()).abs() < 1e-6, "{v}");
    }
    let rms = (read.iter().map(|v| (v - 20.0).powi(2)).sum::<f64>() / read.len() as f64).sqrt();
    assert!((0.015..0.025).contains(&rms), "rms {rms} K");
}

#[test]
fn spindle_speed_is_written_exactly_and_drives_its_heat_source() {
    // 8000 rpm from 101.5 s, 12 000 rpm from 201.5 s (the samples every 5 s from 2 s: one
    // half a second after each step); the head grows 2 µm per 1000 rpm at steady state with
    // τ = 50 s: between the steps z = 16 µm·(1 − e^{−(t − 101.5)/50}); after the second it
    // relaxes from there towards 24 µm.
    let tmp = tempfile::tempdir().unwrap();
    let (on, up) = (101.5, 201.5);
    let rpm = [(0.0, 0.0), (on, 8000.0), (up, 12000.0)];
    let effects = vec![
        Effect::SpindleSpeed {
            rpm: Programme::steps(&rpm),
        },
        Effect::Thermal {
            direction: [0.0, 0.0, 1.0],
            sources: vec![HeatSource {
                gain: 2.0 * UM,
                tau_s: 50.0,
                power: Programme::SpindleKrpm,
            }],
        },
    ];
    let realism = Realism {
        interval_s: 5.0,
        ..Realism::ideal()
    };
    let w = session(
        tmp.path(),
        vec![setup(
            "ball",
            rtest(Mount::BallInSpindle, [0.0, 0.0, 200.0]),
        )],
        vec![run("hold", "ball", vec![vec![0.0, 0.0, -0.2]; 80])],
        effects,
        &realism,
    )
    .unwrap();
    let r = &w.runs[0];
    assert!(r.t.contains(&102.0) && r.t.contains(&202.0), "{:?}", r.t);
    let s = column(&tmp.path().join("s").join(&r.file), "S").expect("an S column");
    let z_up = 16.0 * (1.0 - (-(up - on) / 50.0f64).exp());
    for ((t, s), reading) in r.t.iter().zip(s).zip(&r.clean_um) {
        let (want_s, want_z) = match *t {
            t if t < on => (0.0, 0.0),
            t if t < up => (8000.0, 16.0 * (1.0 - (-(t - on) / 50.0).exp())),
            t => (12000.0, 24.0 + (z_up - 24.0) * (-(t - up) / 50.0).exp()),
        };
        assert_eq!(s, want_s, "S at {t} s");
        assert_close(reading[2], want_z, 1e-9, &format!("dz at {t} s (µm)"));
    }
    let planted: toml::Table = std::fs::read_to_string(tmp.path().join("s/truth/effects.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let list = planted["effect"].as_array().unwrap();
    assert_eq!(list[0]["kind"].as_str(), Some("spindle-speed"));
    assert_eq!(list[1]["kind"].as_str(), Some("thermal"));
    assert_eq!(list[1]["source"][0]["power"].as_str(), Some("spindle_krpm"));
    assert_close(
        list[1]["source"][0]["gain_um"].as_float().unwrap(),
        2.0,
        1e-12,
        "gain",
    );
}

#[test]
fn effects_toml_names_every_effect_with_its_parameters() {
    let m = simple();
    let text = effects_toml(
        &m,
        &[
            Effect::Backlash {
                axis: 'X',
                lost_motion: 4e-6,
            },
            Effect::ScrewError {
                axis: 'Y',
                pitch: 0.01,
                harmonics: vec![(2, 1.5e-6, 0.25)],
            },
            Effect::Sag {
                axis: 'Z',
                direction: 'Y',
                per_m2: -3e-5,
            },
        ],
    );
    let t: toml::Table = text.parse().unwrap();
    let list = t["effect"].as_array().unwrap();
    assert_eq!(list.len(), 3);
    assert_eq!(list[0]["kind"].as_str(), Some("backlash"));
    assert_close(
        list[0]["lost_motion_um"].as_float().unwrap(),
        4.0,
        1e-12,
        "B",
    );
    assert_close(
        list[1]["pitch_mm"].as_float().unwrap(),
        10.0,
        1e-12,
        "pitch",
    );
    assert_eq!(list[1]["harmonic"][0]["order"].as_integer(), Some(2));
    assert_close(
        list[2]["um_per_m2"].as_float().unwrap(),
        -30.0,
        1e-12,
        "sag",
    );
    assert_eq!(list[2]["direction"].as_str(), Some("Y"));
}

#[test]
fn bad_plans_are_refused_with_a_clear_message() {
    let m = simple();
    let y_rotary = Machine::from_urdf_text(&SIMPLE.replacen(
        r#"<joint name="Y" type="prismatic">"#,
        r#"<joint name="Y" type="revolute">"#,
        1,
    ))
    .unwrap();
    let bar = setup(
        "bar",
        Instrument::BallBar {
            pivot_mm: [0.0; 3],
            length_mm: 100.0,
        },
    );
    let ball = setup("ball", rtest(Mount::BallOnTable, [0.0; 3]));
    let setups = [bar, ball];
    let heat = |power| HeatSource {
        gain: 1e-6,
        tau_s: 10.0,
        power,
    };
    let scale = |column: &str| Effect::ThermalScale {
        axis: 'X',
        ppm_per_k: 10.0,
        reference: 0.0,
        temperature: TemperatureProgramme::constant(20.0),
        column: column.into(),
    };
    let trunnion = Machine::from_urdf_file(&crate::shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let cases: Vec<(&Machine, Vec<Effect>, &str)> = vec![
        (
            &trunnion,
            vec![Effect::ThermalScale {
                axis: 'C',
                ppm_per_k: 10.0,
                reference: 0.0,
                temperature: TemperatureProgramme::constant(20.0),
                column: "T_c".into(),
            }],
            "a thermal scale needs a linear axis C; C is rotary here",
        ),
        (
            &m,
            vec![Effect::Backlash {
                axis: 'U',
                lost_motion: 1e-6,
            }],
            "no axis U: the machine's axes are XYZ",
        ),
        (
            &m,
            vec![Effect::Backlash {
                axis: 'X',
                lost_motion: -1e-6,
            }],
            "lost_motion = -0.000001",
        ),
        (
            &y_rotary,
            vec![Effect::Twist { per_m2: 1e-4 }],
            "a twist needs a linear axis Y; Y is rotary here",
        ),
        (
            &y_rotary,
            vec![Effect::Sag {
                axis: 'Y',
                direction: 'Z',
                per_m2: 1e-4,
            }],
            "a sag needs a linear axis Y",
        ),
        (
            &m,
            vec![Effect::Sag {
                axis: 'Z',
                direction: 'Q',
                per_m2: 1e-4,
            }],
            "direction Q: a machine direction is X, Y or Z",
        ),
        (
            &m,
            vec![scale("Txscale")],
            "a temperature column is T_<name>",
        ),
        (&m, vec![scale("T_x,y")], "a temperature column is T_<name>"),
        (
            &m,
            vec![scale("T_x"), scale("T_x")],
            "context column T_x is written by two effects",
        ),
        (
            &m,
            vec![Effect::BallBarThermal {
                setup: "ball".into(),
                ppm_per_k: 11.5,
                temperature: TemperatureProgramme::constant(20.0),
                column: None,
            }],
            "set-up ball is not a ball bar (its instrument is rtest)",
        ),
        (
            &m,
            vec![Effect::BallBarThermal {
                setup: "nope".into(),
                ppm_per_k: 11.5,
                temperature: TemperatureProgramme::constant(20.0),
                column: None,
            }],
            "no set-up nope",
        ),
        (
            &m,
            vec![Effect::Thermal {
                direction: [0.0; 3],
                sources: vec![heat(Programme::constant(1.0))],
            }],
            "is not a direction",
        ),
        (
            &m,
            vec![Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![heat(Programme::SpindleKrpm)],
            }],
            "the plan has no SpindleSpeed",
        ),
        (
            &m,
            vec![Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![heat(Programme::steps(&[(10.0, 1.0), (10.0, 0.0)]))],
            }],
            "power: step times must increase strictly",
        ),
        (
            &m,
            vec![Effect::Thermal {
                direction: [0.0, 0.0, 1.0],
                sources: vec![HeatSource {
                    gain: 1e-6,
                    tau_s: 0.0,
                    power: Programme::constant(1.0),
                }],
            }],
            "tau_s = 0: expected a positive number",
        ),
        (
            &m,
            vec![Effect::ScrewError {
                axis: 'X',
                pitch: 0.01,
                harmonics: vec![(0, 1e-6, 0.0)],
            }],
            "the order is 1 or more",
        ),
        (
            &m,
            vec![
                Effect::SpindleSpeed {
                    rpm: Programme::constant(1000.0),
                },
                Effect::SpindleSpeed {
                    rpm: Programme::constant(2000.0),
                },
            ],
            "two SpindleSpeed effects",
        ),
    ];
    for (machine, effects, want) in cases {
        let err = Resolved::new(machine, &setups, &effects).unwrap_err();
        let SimError::Plan(message) = &err else {
            panic!("{err}")
        };
        assert!(message.contains(want), "{message:?} lacks {want:?}");
    }
    // Through the writer: refused before anything is written.
    let tmp = tempfile::tempdir().unwrap();
    let err = session(
        tmp.path(),
        vec![setup("ball", rtest(Mount::BallOnTable, [0.0; 3]))],
        vec![run("r", "ball", vec![vec![0.0, 0.0, -0.2]])],
        vec![Effect::Backlash {
            axis: 'B',
            lost_motion: 1e-6,
        }],
        &Realism::ideal(),
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("effect 1 (backlash): no axis B"),
        "{err}"
    );
    assert!(!tmp.path().join("s").exists());
}

#[test]
fn a_session_with_effects_has_the_same_random_draws_as_without() {
    // Noise, jitter and set-up offsets are drawn as without effects: a zero-sized effect and
    // a realistic measurement give the same files' readings as no effect at all.
    let tmp = tempfile::tempdir().unwrap();
    let make = |dir: &str, effects| {
        session(
            &tmp.path().join(dir),
            vec![setup("ball", rtest(Mount::BallOnTable, [0.0, 0.0, 200.0]))],
            vec![run("r", "ball", vec![vec![0.01, 0.02, -0.2]; 30])],
            effects,
            &Realism::realistic(4),
        )
        .unwrap()
    };
    let plain = make("a", Vec::new());
    let zero = make(
        "b",
        vec![Effect::ThermalScale {
            axis: 'X',
            ppm_per_k: 0.0,
            reference: 0.0,
            temperature: TemperatureProgramme::constant(20.0),
            column: "T_x".into(),
        }],
    );
    assert_eq!(plain.runs[0].written_um, zero.runs[0].written_um);
    assert_eq!(plain.runs[0].t, zero.runs[0].t);
    assert!(plain.runs[0].context.is_empty());
    assert_eq!(zero.runs[0].context[0].0, "T_x");
    assert!(!tmp.path().join("a/s/truth/effects.toml").exists());
    assert!(tmp.path().join("b/s/truth/effects.toml").exists());
}

#[test]
fn the_twist_translates_the_tool_point_without_turning_it() {
    // The twist is a translation of the tool point only: the tool's orientation is untouched,
    // so the R-test with the ball on the table reads along the same (tool) axes.
    let m = simple();
    let resolved = Resolved::new(&m, &[], &[Effect::Twist { per_m2: 1e-3 }]).unwrap();
    let q = vec![vec![0.2, 0.1, -0.3]];
    let states = Timeline::new(&resolved).run(&q, &[0.0]);
    let truth = Truth::zero(&m);
    let pose = states[0].tool_in_workpiece(&m, &truth, &q[0]);
    let nominal = m.tool_in_workpiece(&q[0], None);
    let d = crate::machine::translation_of(&pose) - crate::machine::translation_of(&nominal);
    assert!((d - Vector3::new(0.0, 0.0, 2e-5)).norm() < 1e-15, "{d}");
    assert_eq!(
        crate::machine::rotation_of(&pose),
        crate::machine::rotation_of(&nominal)
    );
}

/// The actual minus commanded position of axis `i` at each sample of one run.
fn axis_errors(states: &[SampleState<'_>], poses: &[Vec<f64>], i: usize) -> Vec<f64> {
    states
        .iter()
        .zip(poses)
        .map(|(s, q)| s.axes(q)[i] - q[i])
        .collect()
}

/// The tool point's translation from its nominal place (workpiece frame) at each sample, the
/// truth zero, and whether the orientation stayed nominal.
fn tool_moves(m: &Machine, states: &[SampleState<'_>], poses: &[Vec<f64>]) -> Vec<Vector3<f64>> {
    let truth = Truth::zero(m);
    states
        .iter()
        .zip(poses)
        .map(|(s, q)| {
            let pose = s.tool_in_workpiece(m, &truth, q);
            let nominal = m.tool_in_workpiece(q, None);
            assert!(
                (crate::machine::rotation_of(&pose) - crate::machine::rotation_of(&nominal)).norm()
                    < 1e-15
            );
            crate::machine::translation_of(&pose) - crate::machine::translation_of(&nominal)
        })
        .collect()
}

fn x_at_m(xs: &[f64]) -> Vec<Vec<f64>> {
    xs.iter().map(|&x| vec![x, 0.0, -0.2]).collect()
}

#[test]
fn worn_lost_motion_widens_along_the_stroke() {
    // X's stroke −0.4…0.4 m, B = 2 µm at the low end, 6 µm at the high end: B(c) =
    // 2 + 4·(c + 0.4)/0.8 µm. From below at −0.4 (−B/2 = −1), up to 0 (−2), 0.2 (−2.5), down
    // to 0.1 (the play taken up: +B(0.1)/2 = +2.25), up to 0.3 (−2.75).
    let m = simple();
    let worn = |approach| Effect::LostMotion {
        axis: 'X',
        lost_motion_low: 2.0 * UM,
        lost_motion_high: 6.0 * UM,
        approach,
    };
    let resolved = Resolved::new(&m, &[], &[worn(Approach::Carried)]).unwrap();
    let poses = x_at_m(&[-0.4, 0.0, 0.2, 0.1, 0.3]);
    let states = Timeline::new(&resolved).run(&poses, &[0.0; 5]);
    for (got, want) in axis_errors(&states, &poses, 0)
        .iter()
        .zip([-1.0, -2.0, -2.5, 2.25, -2.75])
    {
        assert_close(got / UM, want, 1e-9, "worn lost motion (µm)");
    }
    // Beyond the stroke the width holds its end value.
    let states = Timeline::new(&resolved).run(&x_at_m(&[0.5]), &[0.0]);
    assert_close(
        states[0].axes(&[0.5, 0.0, -0.2])[0] - 0.5,
        -3.0 * UM,
        1e-15,
        "end",
    );

    // Random approach: every run starts B/2 short of or beyond its first command, the side a
    // fair draw per run from the seed's stream; within a run the play is carried.
    let seed = 17;
    let resolved = Resolved::new(&m, &[], &[worn(Approach::RandomPerRun { seed })]).unwrap();
    let mut timeline = Timeline::new(&resolved);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut sides = Vec::new();
    for _ in 0..24 {
        let poses = x_at_m(&[0.0, 0.0]);
        let states = timeline.run(&poses, &[0.0, 1.0]);
        let below = rng.random_bool(0.5);
        let want = if below { -2.0 } else { 2.0 };
        for e in axis_errors(&states, &poses, 0) {
            assert_close(e / UM, want, 1e-9, "random approach (µm)");
        }
        sides.push(below);
    }
    assert!(sides.contains(&true) && sides.contains(&false), "{sides:?}");
}

#[test]
fn backlash_works_on_a_rotary_axis() {
    // The trunnion's C with 100 µrad of lost motion: C lags 50 µrad turning up, leads 50 µrad
    // after turning back. The R-test ball on the table 150 mm off C's line then sits
    // 0.15 m · 50 µrad = 7.5 µm round the circle from where it would be, in the table's plane.
    let m = Machine::from_urdf_file(&crate::shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let c = m.index('C').unwrap();
    let b = 100e-6;
    let effects = [Effect::Backlash {
        axis: 'C',
        lost_motion: b,
    }];
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let ball = Vector3::new(0.15, 0.0, 0.2);
    let deg = f64::to_radians;
    let mut poses = crate::paths::follow_ball(&m, ball, &[('C', 0.0, deg(90.0))], &[], 7).unwrap();
    poses.extend(
        crate::paths::follow_ball(&m, ball, &[('C', deg(80.0), deg(20.0))], &[], 5).unwrap(),
    );
    let times: Vec<f64> = (0..poses.len()).map(|k| k as f64).collect();
    let states = Timeline::new(&resolved).run(&poses, &times);
    for (k, e) in axis_errors(&states, &poses, c).iter().enumerate() {
        let want = if k < 7 { -0.5 * b } else { 0.5 * b };
        assert_close(
            *e,
            want,
            1e-15,
            &format!("C's lost motion at sample {k} (rad)"),
        );
    }
    let rtest = rtest(Mount::BallOnTable, [150.0, 0.0, 200.0]);
    let truth = Truth::zero(&m);
    let off = SetupOffsets::default();
    let with = rtest.readings(&m, &truth, &poses, &[], &off, states.as_slice());
    let without = rtest.readings(&m, &truth, &poses, &[], &off, &GeometricOnly);
    for (k, (w, o)) in with.iter().zip(&without).enumerate() {
        let d = Vector3::new(w[0] - o[0], w[1] - o[1], w[2] - o[2]);
        assert_close(d.norm() / UM, 7.5, 1e-6, &format!("sample {k} (µm)"));
        assert!(d.z.abs() < 1e-12, "sample {k}: {d}");
    }
    // The planted effect is written in µrad.
    let text = effects_toml(&m, &effects);
    assert!(text.contains("lost_motion_urad = 100"), "{text}");
}

#[test]
fn lateral_play_crosses_the_clearance_over_its_take_up_travel() {
    // X's carriage rocks along +Y: +2 µm moving up (play 4 µm), −2 µm moving down, crossing
    // over 0.5 mm of travel after a reversal as p₀ + (s·play/2 − p₀)·(1 − cos(π·d/take_up))/2.
    let m = simple();
    let effects = [Effect::LateralPlay {
        axis: 'X',
        across: [0.0, 2.0, 0.0],
        play: 4.0 * UM,
        take_up: 0.5e-3,
    }];
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let xs = [0.0, 0.01, 0.02, 0.0199, 0.01975, 0.019, 0.0192];
    let poses = x_at_m(&xs);
    let states = Timeline::new(&resolved).run(&poses, &[0.0; 7]);
    let ramp = |d: f64| 0.5 * (1.0 - (std::f64::consts::PI * d / 0.5e-3).cos());
    let after = 2.0 - 4.0 * ramp(0.1e-3);
    let turned = -2.0 + (2.0 - -2.0) * ramp(0.2e-3);
    let want = [2.0, 2.0, 2.0, after, 0.0, -2.0, turned];
    for (k, (d, w)) in tool_moves(&m, &states, &poses).iter().zip(want).enumerate() {
        assert_close(d.y / UM, w, 1e-9, &format!("across at sample {k} (µm)"));
        assert!(d.x.abs() < 1e-15 && d.z.abs() < 1e-15, "{d}");
    }
}

#[test]
fn a_reversal_spike_recovers_critically_damped_in_time() {
    // X reverses at t = 0.2 s (the turning point 2 mm): from then on it trails by
    // −s·h·(1 + Δt/T)·e^{−Δt/T}, s = −1, h = 3 µm, T = 50 ms; standing still it still recovers.
    let m = simple();
    let (h, t_rec) = (3.0 * UM, 0.05);
    let effects = [Effect::ReversalSpike {
        axis: 'X',
        height: h,
        recovery_s: t_rec,
    }];
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let poses = x_at_m(&[0.0, 1e-3, 2e-3, 1.5e-3, 1e-3, 1e-3]);
    let times = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5];
    let states = Timeline::new(&resolved).run(&poses, &times);
    let spike = |dt: f64| h * (1.0 + dt / t_rec) * (-dt / t_rec).exp();
    let want = [0.0, 0.0, 0.0, spike(0.1), spike(0.2), spike(0.3)];
    for (k, (e, w)) in axis_errors(&states, &poses, 0).iter().zip(want).enumerate() {
        assert_close(e / UM, w / UM, 1e-9, &format!("spike at sample {k} (µm)"));
    }
    // 1.218 µm 0.1 s after the reversal.
    assert_close(want[3] / UM, 9.0 * (-2.0f64).exp(), 1e-12, "by hand");
}

#[test]
fn stick_slip_sticks_for_its_height_then_slips_over_its_travel() {
    // After the reversal at 5 mm (moving down, s = −1; h = 2 µm, λ = 0.2 mm): 1 µm of travel
    // the carriage still stands (+1 µm), 0.1 mm on it has slipped to
    // 2·(1 + 0.49)·e^{−0.49} µm, 1 mm on 2·5.99·e^{−4.99} µm; standing changes nothing.
    let m = simple();
    let effects = [Effect::StickSlip {
        axis: 'X',
        height: 2.0 * UM,
        slip_travel: 0.2e-3,
    }];
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let xs = [0.0, 5e-3, 5e-3 - 1e-6, 4.9e-3, 4e-3, 4e-3];
    let poses = x_at_m(&xs);
    let states = Timeline::new(&resolved).run(&poses, &[0.0, 1.0, 2.0, 3.0, 4.0, 100.0]);
    let slip = |u: f64| 2.0 * (1.0 + u) * (-u).exp();
    let want = [0.0, 0.0, 1.0, slip(0.49), slip(4.99), slip(4.99)];
    for (k, (e, w)) in axis_errors(&states, &poses, 0).iter().zip(want).enumerate() {
        assert_close(e / UM, w, 1e-6, &format!("stick-slip at sample {k} (µm)"));
    }
}

#[test]
fn a_guideway_bump_raises_the_tool_over_its_width() {
    // A 3 µm raised cosine 40 mm wide centred at X = 0.1 m, displacing the tool along +Z:
    // 3 at the centre, 1.5 at ±10 mm, 0 beyond ±20 mm.
    let m = simple();
    let effects = [Effect::GuidewayBump {
        axis: 'X',
        direction: [0.0, 0.0, 5.0],
        centre: 0.1,
        width: 0.04,
        height: 3.0 * UM,
    }];
    let resolved = Resolved::new(&m, &[], &effects).unwrap();
    let poses = x_at_m(&[0.05, 0.09, 0.1, 0.11, 0.125]);
    let states = Timeline::new(&resolved).run(&poses, &[0.0; 5]);
    for (d, w) in tool_moves(&m, &states, &poses)
        .iter()
        .zip([0.0, 1.5, 3.0, 1.5, 0.0])
    {
        assert_close(d.z / UM, w, 1e-9, "bump (µm)");
        assert!(d.x.abs() < 1e-15 && d.y.abs() < 1e-15, "{d}");
    }
}

#[test]
fn spindle_growth_moves_the_tool_point_out_of_the_spindle_and_turns_with_the_head() {
    // 10 µm of growth at once (a node of 1 µs switched on at t = 0): on the head-head machine
    // the tool point moves by −g along the tool's own z, wherever the head points.
    let m = Machine::from_urdf_file(&crate::shipped_machine("headhead-xyzca.urdf")).unwrap();
    let g = 10.0 * UM;
    let growth = Effect::SpindleGrowth {
        sources: vec![HeatSource {
            gain: g,
            tau_s: 1e-6,
            power: Programme::constant(1.0),
        }],
    };
    let resolved = Resolved::new(&m, &[], std::slice::from_ref(&growth)).unwrap();
    let deg = f64::to_radians;
    let poses: Vec<Vec<f64>> = [(0.0, 0.0), (30.0, 0.0), (-45.0, 90.0)]
        .iter()
        .map(|&(a, c)| vec![0.1, -0.2, -0.3, deg(a), deg(c)])
        .collect();
    let states = Timeline::new(&resolved).run(&poses, &[1.0; 3]);
    for ((d, q), (a, c)) in tool_moves(&m, &states, &poses).iter().zip(&poses).zip([
        (0.0, 0.0),
        (30.0, 0.0),
        (-45.0, 90.0),
    ]) {
        let z_tool = crate::machine::rotation_of(&m.tool_in_workpiece(q, None)) * Vector3::z();
        assert!((d + z_tool * g).norm() < 1e-15, "A = {a}°, C = {c}°: {d}");
    }
    // Tilted 30° about +X, the tool's z is (0, −sin 30°, cos 30°): the point moves
    // +5 µm along Y and −8.66 µm along Z.
    let d = tool_moves(&m, &states, &poses)[1];
    assert_close(d.y / UM, 5.0, 1e-9, "y (µm)");
    assert_close(d.z / UM, -5.0 * 3f64.sqrt(), 1e-9, "z (µm)");
    // On a vertical spindle it is the head's growth along −Z ([`Effect::Thermal`]).
    let q = vec![vec![0.1, 0.05, -0.2]];
    let thermal = Effect::Thermal {
        direction: [0.0, 0.0, -1.0],
        sources: vec![HeatSource {
            gain: g,
            tau_s: 1e-6,
            power: Programme::constant(1.0),
        }],
    };
    let a = read(
        &[growth],
        &rtest(Mount::BallInSpindle, [100.0, 50.0, 200.0]),
        &q,
        &[1.0],
    );
    let b = read(
        &[thermal],
        &rtest(Mount::BallInSpindle, [100.0, 50.0, 200.0]),
        &q,
        &[1.0],
    );
    for (x, y) in a[0].iter().zip(&b[0]) {
        assert_close(*x, *y, 1e-18, "spindle growth = thermal along −Z");
    }
    assert_close(a[0][2] / UM, -10.0, 1e-9, "dz (µm)");
}

#[test]
fn the_new_effects_are_written_down_and_checked() {
    let m = simple();
    let text = effects_toml(
        &m,
        &[
            Effect::LostMotion {
                axis: 'X',
                lost_motion_low: 2e-6,
                lost_motion_high: 6e-6,
                approach: Approach::RandomPerRun { seed: 5 },
            },
            Effect::LateralPlay {
                axis: 'Y',
                across: [1.0, 0.0, 0.0],
                play: 3e-6,
                take_up: 5e-4,
            },
            Effect::ReversalSpike {
                axis: 'X',
                height: 2e-6,
                recovery_s: 0.03,
            },
            Effect::StickSlip {
                axis: 'Y',
                height: 1e-6,
                slip_travel: 2e-4,
            },
            Effect::GuidewayBump {
                axis: 'Z',
                direction: [1.0, 0.0, 0.0],
                centre: -0.2,
                width: 0.05,
                height: 2e-6,
            },
            Effect::SpindleGrowth {
                sources: vec![HeatSource {
                    gain: 8e-6,
                    tau_s: 600.0,
                    power: Programme::constant(1.0),
                }],
            },
        ],
    );
    let t: toml::Table = text.parse().unwrap();
    let list = t["effect"].as_array().unwrap();
    let kinds: Vec<&str> = list.iter().map(|e| e["kind"].as_str().unwrap()).collect();
    assert_eq!(
        kinds,
        [
            "lost-motion",
            "lateral-play",
            "reversal-spike",
            "stick-slip",
            "guideway-bump",
            "spindle-growth"
        ]
    );
    assert_close(
        list[0]["lost_motion_high_um"].as_float().unwrap(),
        6.0,
        1e-9,
        "B",
    );
    assert_eq!(list[0]["approach"].as_str(), Some("random-per-run"));
    assert_close(
        list[1]["take_up_mm"].as_float().unwrap(),
        0.5,
        1e-12,
        "take-up",
    );
    assert_close(list[2]["recovery_ms"].as_float().unwrap(), 30.0, 1e-9, "T");
    assert_close(list[4]["width_mm"].as_float().unwrap(), 50.0, 1e-9, "width");
    assert_close(
        list[5]["source"][0]["gain_um"].as_float().unwrap(),
        8.0,
        1e-9,
        "g",
    );

    let y_rotary = Machine::from_urdf_text(&SIMPLE.replacen(
        r#"<joint name="Y" type="prismatic">"#,
        r#"<joint name="Y" type="revolute">"#,
        1,
    ))
    .unwrap();
    let cases: Vec<(&Machine, Effect, &str)> = vec![
        (
            &y_rotary,
            Effect::GuidewayBump {
                axis: 'Y',
                direction: [0.0, 0.0, 1.0],
                centre: 0.0,
                width: 0.01,
                height: 1e-6,
            },
            "a guideway bump needs a linear axis Y",
        ),
        (
            &m,
            Effect::LateralPlay {
                axis: 'X',
                across: [0.0; 3],
                play: 1e-6,
                take_up: 1e-3,
            },
            "across [0.0, 0.0, 0.0] is not a direction",
        ),
        (
            &m,
            Effect::ReversalSpike {
                axis: 'X',
                height: 1e-6,
                recovery_s: 0.0,
            },
            "recovery_s = 0: expected a positive number",
        ),
        (
            &m,
            Effect::LostMotion {
                axis: 'X',
                lost_motion_low: -1e-6,
                lost_motion_high: 1e-6,
                approach: Approach::Carried,
            },
            "lost_motion_low = -0.000001",
        ),
    ];
    for (machine, effect, want) in cases {
        let err = Resolved::new(machine, &[], &[effect])
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{err:?} lacks {want:?}");
    }
}

#[test]
fn an_axis_line_drift_is_the_location_error_moved_by_its_temperature() {
    // A's line 2 µm/K along Y with a 3 K rise: at every pose the actual tool pose is the
    // geometric model's with EY0A at 6 µm, and at A = 0 nothing moves (the parts A carries
    // keep their place at the axis' zero).
    let m = Machine::from_urdf_file(&crate::shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let drift = Effect::AxisLineDrift {
        parameter: "EY0A".into(),
        per_k: 2.0 * UM,
        temperature: stepped(3.0),
        column: Some("T_adrive".into()),
    };
    let resolved = Resolved::new(&m, &[], std::slice::from_ref(&drift)).unwrap();
    let deg = f64::to_radians;
    let poses: Vec<Vec<f64>> = [(0.0, 0.0), (30.0, 45.0), (90.0, -120.0)]
        .iter()
        .map(|&(a, c)| vec![0.1, -0.2, -0.3, deg(a), deg(c)])
        .collect();
    let states = Timeline::new(&resolved).run(&poses, &[1.0; 3]);
    let truth = Truth::zero(&m);
    let mut moved = Truth::zero(&m);
    moved.set(&m, "EY0A", 6.0 * UM).unwrap();
    for (k, q) in poses.iter().enumerate() {
        let got = states[k].tool_in_workpiece(&m, &truth, q);
        let want = m.tool_in_workpiece(q, Some(&moved));
        assert!((got - want).norm() < 1e-15, "pose {k}: {got} vs {want}");
    }
    let d = tool_moves(&m, &states, &poses);
    assert!(d[0].norm() < 1e-15, "A = 0: {}", d[0]);
    assert!(d[2].norm() > 5.0 * UM, "A = 90°: {}", d[2]);
    // What is not a line across a rotary axis is refused.
    for bad in ["EX0A", "EC0Y", "EX0Z", "EQ0A"] {
        let e = Effect::AxisLineDrift {
            parameter: bad.into(),
            per_k: UM,
            temperature: stepped(1.0),
            column: None,
        };
        let err = Resolved::new(&m, &[], &[e]).unwrap_err();
        assert!(err.to_string().contains(bad), "{bad}: {err}");
    }
}
