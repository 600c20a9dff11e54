//! Agreement with mtcal: for every shipped machine an instrument fits, a random truth (with
//! set-up errors and own-direction location constants too), zero noise and the set-up as
//! stated, the readings this crate writes equal mtcal's predictions for the same session and
//! truth. mtcal reads the session through its own loaders (`mtcal-session`, the plugins'
//! `load_setup`), the truth through its parameter and model files, and predicts with
//! `MachineModel::tool_pose` and the plugin's `Setup::predict` — what its simulator and
//! `identify --predict` do per sample. The file's readings are compared as the fit sees them:
//! in SI, after the plugin's `prepare_readings` (the artefact's measured centre minus the
//! probed position), each sample's label resolved by the plugin (the artefact's `feature`).
//!
//! Instruments: R-test (both mounts), ball bar, laser (linear and angular along each linear
//! axis, angular also with the rotary axes turned, straightness along the first; diagonal and
//! step-diagonal along the four body diagonals, whose poses must also be the plugin's own
//! planned path between the same corners), tracer, displacement sensors (at a held pose,
//! sensors touching up the tool only where the nominal tool frame is the workpiece frame's,
//! the plugin's documented approximation) and artefact plates (2-D at three placements, 3-D at
//! one; axis columns the reported centres, and again the commanded nominal centres, see
//! [`COMMANDED_ARTEFACT_TOL_UM`]). Laser and tracer readings are compared as changes from the
//! run's first sample (both instruments are zeroed there; mtcal carries the zero as a
//! nuisance).

use crate::common;

use std::path::Path;

use common::{positions_si, read_mtcal_run, truth_model};
use mtcal_instrument::{At, RunData};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use mtcal_indsim::machine::{JointKind, rotation_of, translation_of};
use mtcal_indsim::{
    DisplacementSensor, Instrument, LaserMode, Machine, Mount, Plan, PlatePlacement, Probed,
    Realism, RunPlan, SensorDirection, SetupPlan, Side, Truth, paths, shipped_machine,
    write_session,
};

/// µm per metre of reach: the acceptance, 1e-9 µm, on machines whose branch poses stay within
/// 1 m of the machine frame. Both sides compose metre-sized transforms in f64 in different
/// orders, so each rounds at a few ulp of the largest coordinate (ulp(1 m) = 2.2e-10 µm); on a
/// gantry whose tool branch reaches 3.6 m up (headhead-xyzca) that floor is ~1e-9 µm itself (the R-test on the table reaches 1.6e-9 µm there: seven ulp), so
/// the tolerance scales with the reach (`max(1, |f_p_tool|, |f_p_workpiece|, |w_p_tool|)` in m).
const TOL_UM: f64 = 2e-9;

/// An artefact probed at commanded positions `q` (the features' nominal centres) is modelled
/// to first order: the plugin drops `e(q*) − e(q)`, the change of the machine's error between
/// where it probed and where it reports the centre `q*` (its crate docs estimate 1e-4 µm).
/// Those runs are held to this, in µm; and, with the dropped term formed from mtcal's own
/// model (`p_act(q*) − p_act(q) − (q* − q)`) and added back, to [`TOL_UM`]. Runs whose axis
/// columns are the reported centres (the dropped term exactly zero) are held to [`TOL_UM`].
const COMMANDED_ARTEFACT_TOL_UM: f64 = 1e-2;

const MACHINES: [&str; 6] = [
    "mcu630-cafyxz.urdf",
    "mcv754-zfyx.urdf",
    "headhead-xyzca.urdf",
    "mcv1000-5ax220-bc.urdf",
    "mixed-c-table-b-head.urdf",
    "mu6300-caxfyz.urdf",
];

/// Per instrument: the largest |ours − mtcal|, the number of readings compared and the largest
/// |reading| (µm; µrad for angular laser optics).
#[derive(Default, Debug)]
struct Worst {
    by_instrument: Vec<(String, f64, usize, f64)>,
}

impl Worst {
    fn add(&mut self, instrument: &str, diff: f64, reading: f64) {
        match self
            .by_instrument
            .iter_mut()
            .find(|(n, ..)| n == instrument)
        {
            Some(e) => {
                e.1 = e.1.max(diff);
                e.2 += 1;
                e.3 = e.3.max(reading.abs());
            }
            None => self
                .by_instrument
                .push((instrument.to_string(), diff, 1, reading.abs())),
        }
    }
}

fn deg(d: f64) -> f64 {
    d.to_radians()
}

/// A plan that exercises every instrument the machine fits, around the pose with the linear
/// axes mid-stroke and the rotary axes at zero.
fn plan_for(machine: &Machine, urdf: &Path, mount: Mount, write_mount_key: bool) -> Plan {
    let n = machine.n_axes();
    let mut home = vec![0.0; n];
    for (i, j) in machine.joints.iter().enumerate() {
        if j.kind == JointKind::Linear {
            let (lo, hi) = j.stroke();
            home[i] = 0.5 * (lo + hi);
        }
    }
    let p_home = translation_of(&machine.tool_in_workpiece(&home, None));
    let mm = |v: Vector3<f64>| [v.x * 1e3, v.y * 1e3, v.z * 1e3];
    let hold_lin: Vec<(char, f64)> = machine
        .joints
        .iter()
        .zip(&home)
        .filter(|(j, _)| j.kind == JointKind::Linear)
        .map(|(j, &v)| (j.letter, v))
        .collect();
    let rotary: Vec<char> = machine
        .joints
        .iter()
        .filter(|j| j.kind == JointKind::Rotary)
        .map(|j| j.letter)
        .collect();
    // A rotary angle inside the axis' limits (a B head of −105..15°, say).
    let clip = |c: char, v: f64| match machine.joints[machine.index(c).unwrap()].limits {
        Some((lo, hi)) => v.clamp(lo + 0.01, hi - 0.01),
        None => v,
    };
    let mut setups = Vec::new();
    let mut runs = Vec::new();
    let mut labelled = |name: String, setup: &str, poses, labels| {
        runs.push(RunPlan {
            name,
            setup: setup.into(),
            validate: false,
            poses,
            labels,
            interval_s: None,
            pause_before_s: None,
        })
    };
    let mut run = |name: String, setup: &str, poses| labelled(name, setup, poses, Vec::new());

    if !rotary.is_empty() {
        let ball = p_home + Vector3::new(0.06, 0.04, 0.0);
        setups.push(SetupPlan {
            name: "rtest".into(),
            instrument: Instrument::RTest {
                ball_mm: mm(ball),
                mount,
                write_mount_key,
            },
        });
        for &c in &rotary {
            let sweep = [(c, clip(c, deg(-20.0)), clip(c, deg(25.0)))];
            let poses = paths::follow_ball(machine, ball, &sweep, &[], 19).unwrap();
            run(format!("rtest-{c}"), "rtest", poses);
        }
        if rotary.len() == 2 {
            let sweep = [
                (
                    rotary[0],
                    clip(rotary[0], deg(15.0)),
                    clip(rotary[0], deg(-20.0)),
                ),
                (
                    rotary[1],
                    clip(rotary[1], deg(-25.0)),
                    clip(rotary[1], deg(20.0)),
                ),
            ];
            let poses = paths::follow_ball(machine, ball, &sweep, &[], 19).unwrap();
            run("rtest-both".into(), "rtest", poses);
        }
    }

    // Ball bar: an XY circle with the rotary axes turned by 10°.
    setups.push(SetupPlan {
        name: "bar".into(),
        instrument: Instrument::BallBar {
            pivot_mm: mm(p_home),
            length_mm: 80.0,
        },
    });
    let hold_rot: Vec<(char, f64)> = rotary.iter().map(|&c| (c, clip(c, deg(10.0)))).collect();
    let poses = paths::circle(machine, p_home, 0.08, (0, 1), true, &hold_rot, 37).unwrap();
    run("ballbar-xy".into(), "bar", poses);

    // Laser: a linear run along each linear axis, a straightness run along the first; the beam
    // along the nominal travel, the optic off the tool point (Abbe offsets). Angular optics
    // along each linear axis about two directions across the beam (pitch and yaw on an axis whose beam is a machine axis), and along
    // the first again with the rotary axes held at their 10° (the rotation read in the
    // workpiece frame, not the tool's). Diagonal and step-diagonal runs along the four body
    // diagonals of the work volume.
    let lin: Vec<usize> = (0..n)
        .filter(|&i| machine.joints[i].kind == JointKind::Linear)
        .collect();
    let nominal_travel = |poses: &[Vec<f64>]| {
        let a = translation_of(&machine.tool_in_workpiece(&poses[0], None));
        let b = translation_of(&machine.tool_in_workpiece(poses.last().unwrap(), None));
        (b - a).normalize()
    };
    let laser = |mode, dir: Vector3<f64>, across: Vector3<f64>| Instrument::Laser {
        mode,
        direction: [dir.x, dir.y, dir.z],
        across: [across.x, across.y, across.z],
        optic_offset_mm: [20.0, -15.0, 80.0],
    };
    for (k, &i) in lin.iter().enumerate() {
        let j = &machine.joints[i];
        let (lo, hi) = j.stroke();
        let line = |hold: &[(char, f64)]| {
            paths::line(
                machine,
                j.letter,
                0.8 * lo + 0.2 * hi,
                0.2 * lo + 0.8 * hi,
                11,
                hold,
            )
            .unwrap()
        };
        let poses = line(&hold_lin);
        let dir = nominal_travel(&poses);
        let sense = dir.cross(&Vector3::new(0.3, 0.5, 0.8)).normalize();
        let modes: &[LaserMode] = if k == 0 {
            &[LaserMode::Linear, LaserMode::Straightness]
        } else {
            &[LaserMode::Linear]
        };
        for &mode in modes {
            let name = format!("laser-{}-{}", j.letter, mode.key());
            setups.push(SetupPlan {
                name: name.clone(),
                instrument: laser(mode, dir, sense),
            });
            run(name.clone(), &name, poses.clone());
        }
        let mut angular = vec![
            ("about-1", poses.clone(), dir, sense),
            ("about-2", poses.clone(), dir, dir.cross(&sense)),
        ];
        if k == 0 && !rotary.is_empty() {
            let mut hold = hold_lin.clone();
            hold.extend(&hold_rot);
            let turned = line(&hold);
            let dir = nominal_travel(&turned);
            let about = dir.cross(&Vector3::new(-0.6, 0.2, 0.7)).normalize();
            angular.push(("turned", turned, dir, about));
        }
        for (what, poses, dir, about) in angular {
            let name = format!("laser-{}-angular-{what}", j.letter);
            setups.push(SetupPlan {
                name: name.clone(),
                instrument: laser(LaserMode::Angular, dir, about),
            });
            run(name.clone(), &name, poses);
        }
    }
    for (k, signs) in [
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [1.0, -1.0, 1.0],
        [1.0, 1.0, -1.0],
    ]
    .into_iter()
    .enumerate()
    {
        for (mode, steps) in [
            (LaserMode::Diagonal, false),
            (LaserMode::StepDiagonal, true),
        ] {
            let poses = paths::diagonal(machine, 0.6, signs, 9, steps, &[]).unwrap();
            let dir = nominal_travel(&poses);
            let name = format!("laser-{}-{k}", mode.key());
            setups.push(SetupPlan {
                name: name.clone(),
                instrument: laser(mode, dir, Vector3::zeros()),
            });
            run(name.clone(), &name, poses);
        }
    }

    // Tracer: a grid from two stations with two reflectors.
    let grid = paths::grid(machine, 0.6, [3, 3, 3], &hold_rot).unwrap();
    for (k, (station, reflector)) in [
        (Vector3::new(0.6, 0.4, -0.3), [0.0, 0.0, 100.0]),
        (Vector3::new(-0.5, 0.6, 0.2), [50.0, 30.0, 80.0]),
    ]
    .into_iter()
    .enumerate()
    {
        let name = format!("tracer-{k}");
        setups.push(SetupPlan {
            name: name.clone(),
            instrument: Instrument::Tracer {
                station_mm: mm(p_home + station),
                reflector_mm: reflector,
            },
        });
        run(name.clone(), &name, grid.clone());
    }

    // Displacement sensors against the mandrel held at home (rotary axes at zero), columns in
    // an order that is not the plugin's sorted one; sensors touching the mandrel up the tool
    // only where the nominal tool frame is the workpiece frame's there (the plugin's documented
    // approximation). With rotary axes, again held at their 10° (touching at the tool point).
    let sensor = |name: &str, direction, at_mm| DisplacementSensor {
        name: name.into(),
        direction,
        at_mm,
    };
    let axis = |letter, negative| SensorDirection::Axis { letter, negative };
    let aligned = |q: &[f64]| {
        (rotation_of(&machine.tool_in_workpiece(q, None)) - Matrix3::identity()).amax() < 1e-15
    };
    let mut sensors = vec![
        sensor("x1", axis('X', false), None),
        sensor("ch5", SensorDirection::Unknown, None),
        sensor("tilt", SensorDirection::Vector([0.3, -0.5, 0.8]), None),
        sensor("ny", axis('Y', true), None),
        sensor("z", axis('Z', false), None),
    ];
    if aligned(&home) {
        sensors.push(sensor("xa", axis('X', false), Some([0.0, 0.0, 50.0])));
        sensors.push(sensor(
            "v-a",
            SensorDirection::Vector([0.2, 0.9, -0.1]),
            Some([10.0, -20.0, 60.0]),
        ));
    }
    let mut held = vec![("disp-home", home.clone(), sensors.clone())];
    if !rotary.is_empty() {
        let mut q = home.clone();
        for &(c, v) in &hold_rot {
            q[machine.index(c).unwrap()] = v;
        }
        let plain: Vec<DisplacementSensor> = sensors
            .iter()
            .filter(|s| s.at_mm.is_none())
            .cloned()
            .collect();
        held.push(("disp-rot", q, plain));
    }
    for (name, q, sensors) in held {
        setups.push(SetupPlan {
            name: name.into(),
            instrument: Instrument::Displacement {
                position_mm: mm(translation_of(&machine.tool_in_workpiece(&q, None))),
                sensors,
            },
        });
        run(name.into(), name, vec![q; 5]);
    }

    // Artefact plates, where the nominal X, Y, Z move the tool point along the workpiece
    // axes (rotary axes at zero): a 2-D plate at three placements (moved, turned by 90°,
    // turned by 30° and flipped), probed with the axis columns the reported centres and again
    // commanded to the nominal centres, and a 3-D plate at one placement (bare labels).
    if plate_machine(machine) {
        let xyz: Vec<usize> = ['X', 'Y', 'Z']
            .iter()
            .map(|&l| machine.index(l).unwrap())
            .collect();
        let mut zero_rot = home.clone();
        for (i, j) in machine.joints.iter().enumerate() {
            if j.kind == JointKind::Rotary {
                zero_rot[i] = 0.0;
            }
        }
        let home_mm = [0, 1, 2].map(|c| home[xyz[c]] * 1e3);
        let shifted =
            |dx: f64, dy: f64, dz: f64| [home_mm[0] + dx, home_mm[1] + dy, home_mm[2] + dz];
        let place = |name: &str, origin_mm, rotation_deg, flipped| PlatePlacement {
            name: name.into(),
            origin_mm,
            rotation_deg,
            flipped,
        };
        let flat: Vec<(String, Vec<f64>)> = [
            ("h00", [0.0, 0.0]),
            ("h01", [0.0, 60.0]),
            ("h10", [80.0, 0.0]),
            ("h11", [80.0, 60.0]),
            ("c.5", [40.0, 30.0]),
        ]
        .iter()
        .map(|(n, p)| (n.to_string(), p.to_vec()))
        .collect();
        let solid: Vec<(String, Vec<f64>)> = [
            ("b1", [0.0, 0.0, 0.0]),
            ("b2", [70.0, 0.0, 20.0]),
            ("b3", [0.0, 50.0, -30.0]),
            ("b4", [60.0, 40.0, 40.0]),
        ]
        .iter()
        .map(|(n, p)| (n.to_string(), p.to_vec()))
        .collect();
        let flat_places = vec![
            place("p1", shifted(-40.0, -30.0, 0.0), 0.0, false),
            place("p2", shifted(30.0, -40.0, 0.0), 90.0, false),
            place("p3", shifted(-30.0, 20.0, 10.0), 30.0, true),
        ];
        let solid_places = vec![place("only", shifted(-20.0, -10.0, -20.0), 45.0, false)];
        for (name, features, placements, probed) in [
            ("artefact-2d", &flat, &flat_places, Probed::Reported),
            ("artefact-cmd-2d", &flat, &flat_places, Probed::Commanded),
            ("artefact-3d", &solid, &solid_places, Probed::Reported),
            ("artefact-cmd-3d", &solid, &solid_places, Probed::Commanded),
        ] {
            // Visit every feature of every placement at its nominal centre (axis coordinates).
            let mut poses = Vec::new();
            let mut labels = Vec::new();
            for p in placements {
                let (s, c) = p.rotation_deg.to_radians().sin_cos();
                let sign = if p.flipped { -1.0 } else { 1.0 };
                for (f, x) in features {
                    let (fx, fy, fz) = (x[0], sign * x[1], sign * x.get(2).copied().unwrap_or(0.0));
                    let at = [c * fx - s * fy, s * fx + c * fy, fz];
                    let mut q = zero_rot.clone();
                    for k in 0..3 {
                        q[xyz[k]] = (p.origin_mm[k] + at[k]) * 1e-3;
                    }
                    poses.push(q);
                    labels.push(if placements.len() == 1 {
                        f.clone()
                    } else {
                        format!("{}/{f}", p.name)
                    });
                }
            }
            setups.push(SetupPlan {
                name: name.into(),
                instrument: Instrument::Artefact {
                    features: features.clone(),
                    placements: placements.clone(),
                    probed,
                },
            });
            labelled(name.into(), name, poses, labels);
        }
    }
    Plan {
        machine_urdf: urdf.to_path_buf(),
        setups,
        runs,
        effects: Vec::new(),
    }
}

/// Whether the nominal X, Y, Z (other axes at zero) move the tool point along the workpiece
/// frame's X, Y, Z: where machine coordinates of a plate mean workpiece coordinates.
fn plate_machine(machine: &Machine) -> bool {
    let zero = vec![0.0; machine.n_axes()];
    let p0 = translation_of(&machine.tool_in_workpiece(&zero, None));
    ['X', 'Y', 'Z'].iter().enumerate().all(|(c, &l)| {
        machine.index(l).is_some_and(|i| {
            let mut q = zero.clone();
            q[i] = 0.1;
            let moved = translation_of(&machine.tool_in_workpiece(&q, None)) - p0;
            (moved - Vector3::ith(c, 0.1)).norm() < 1e-9
        })
    })
}

/// Writes the session for `file`, reads it back with mtcal, and returns the worst differences.
fn compare(file: &str, mount: Mount, write_mount_key: bool, seed: u64) -> Worst {
    let urdf = shipped_machine(file);
    let machine = Machine::from_urdf_file(&urdf).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut truth = Truth::random(&machine, &mut rng, 1.0);
    truth.randomise_extras(&machine, &mut rng, 1.0);
    let plan = plan_for(&machine, &urdf, mount, write_mount_key);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("session");
    write_session(&dir, &machine, &truth, &plan, &Realism::ideal()).unwrap();

    // mtcal's side, from the files only.
    let session = mtcal_session::load_session(&dir).unwrap();
    let mpath = session.machine_path.clone().expect("a URDF path");
    let m = mtcal_machine::urdf::load_urdf_file(&mpath).unwrap();
    let (model, coeffs) = truth_model(&dir, &m);
    let mut ws = model.workspace();
    let mut worst = Worst::default();
    for run in &session.runs {
        let common::MtcalRun {
            setup,
            recorded: table,
            clean,
        } = read_mtcal_run(&dir, &session, run, &m);
        let names: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
        let nuis = vec![0.0; setup.nuisance().len()];
        let mut out = vec![0.0; names.len()];
        let mut first: Option<Vec<f64>> = None;
        let q_all = positions_si(&table, &m);
        // A diagonal is the path the plugin plans between the run's end targets (its path
        // checks that the tool point travels along the set-up's beam): same poses.
        let mode = session.setup_of(run).get("mode").and_then(|v| v.as_str());
        if let Some(steps) = match mode {
            Some("diagonal") => Some(false),
            Some("step-diagonal") => Some(true),
            _ => None,
        } {
            let corner = |q: &[f64]| {
                let mut t = toml::Table::new();
                for (i, a) in m.axes().iter().enumerate() {
                    if a.kind() == mtcal_kinematics::AxisKind::Linear {
                        t.insert(a.letter().to_string(), (q[i] * 1e3).into());
                    }
                }
                toml::Value::Table(t)
            };
            let targets = if steps {
                (q_all.len() - 1) / 3 + 1
            } else {
                q_all.len()
            };
            let mut path = toml::Table::new();
            path.insert("from".into(), corner(&q_all[0]));
            path.insert("to".into(), corner(q_all.last().unwrap()));
            path.insert("points".into(), (targets as i64).into());
            path.insert("bidirectional".into(), false.into());
            let loaded = mtcal_laser::load(
                session.setup_of(run),
                &mtcal_instrument::SetupContext { machine: &m },
            )
            .unwrap_or_else(|e| panic!("{file} run {}: the set-up: {e}", run.name));
            let planned = mtcal_laser::path(&mtcal_instrument::PathSpec {
                path: &path,
                setup: &loaded,
                machine: &m,
            })
            .unwrap_or_else(|e| panic!("{file} run {}: the plugin's path: {e}", run.name));
            assert_eq!(planned.len(), q_all.len(), "{file} run {}", run.name);
            for (k, (a, b)) in planned.iter().zip(&q_all).enumerate() {
                // Axis positions (m, rad; µm in the table below, against 0 as the reading).
                let off = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(
                    off < 1e-12,
                    "{file} run {} sample {k}: the plugin plans {a:?}, indsim {b:?}",
                    run.name
                );
                worst.add(&format!("laser {} path", mode.unwrap()), off * 1e6, 0.0);
            }
        }
        // The readings as the model reads them (SI): the file's values in SI units, then the
        // plugin's own preparation (the artefact's measured centre minus the probed position).
        let mut prepared: Vec<f64> = (0..table.len())
            .flat_map(|k| {
                table
                    .reading_row(k)
                    .unwrap()
                    .iter()
                    .zip(setup.channels())
                    .map(|(v, c)| v / c.unit.per_si())
                    .collect::<Vec<_>>()
            })
            .collect();
        let q_flat: Vec<f64> = q_all.iter().flatten().copied().collect();
        setup
            .prepare_readings(
                &RunData {
                    q: &q_flat,
                    t: &table.t,
                    context: &[],
                },
                &mut prepared,
            )
            .unwrap();
        let commanded_artefact = run.name.starts_with("artefact-cmd");
        let xyz = ['X', 'Y', 'Z'].map(|l| m.axis_index(l).unwrap_or(0));
        let inst_label = if commanded_artefact {
            "artefact (commanded)".to_string()
        } else if run.instrument == "laser" {
            let mode = session.setup_of(run)["mode"].as_str().unwrap();
            format!("laser {mode}")
        } else {
            run.instrument.clone()
        };
        for k in 0..table.len() {
            let q = &q_all[k];
            let label = if setup.label_columns().is_empty() {
                0
            } else {
                setup.resolve_label(&table.label_row(k)).unwrap()
            };
            let pose = model.tool_pose(q, &coeffs, &mut ws);
            let reach = [Side::Tool, Side::Workpiece]
                .iter()
                .map(|&s| translation_of(&machine.branch_pose(s, q, None)).norm())
                // The R-test on the table subtracts the tool point in the workpiece frame
                // from the ball: its size counts too.
                .chain(std::iter::once(pose.t.norm()))
                .fold(1.0, f64::max);
            let at = At {
                q,
                t: table.t[k],
                w_t_t: &pose,
                label,
            };
            setup.predict(&at, &nuis, &mut out);
            // Both sides in µm (every plugin here models deviations in metres; an angular laser
            // in rad, so µrad).
            let pred: Vec<f64> = out.iter().map(|v| v * 1e6).collect();
            let unit = if mode == Some("angular") {
                "µrad"
            } else {
                "µm"
            };
            // Laser and tracer readings are zeroed at the first sample; mtcal's free zero /
            // dead path carries that constant. Compare changes from the first sample.
            let relative = matches!(run.instrument.as_str(), "laser" | "tracer");
            let base = first.get_or_insert_with(|| pred.clone()).clone();
            let written = table.reading_row(k).unwrap();
            let written_clean = clean.reading_row(k).unwrap();
            let ours: Vec<f64> = prepared[k * names.len()..(k + 1) * names.len()]
                .iter()
                .map(|v| v * 1e6)
                .collect();
            let tol = if commanded_artefact {
                COMMANDED_ARTEFACT_TOL_UM
            } else {
                TOL_UM * reach
            };
            if commanded_artefact {
                // The plugin's dropped term from mtcal's own model: the reported centre
                // q* = q + reading, and e(q*) − e(q) = p_act(q*) − p_act(q) − (q* − q) (the
                // nominal tool point moves one for one with X, Y, Z on these machines).
                let nc = names.len();
                let mut q_star = q.clone();
                for c in 0..nc {
                    q_star[xyz[c]] += prepared[k * nc + c];
                }
                let p_star = model.tool_pose(&q_star, &coeffs, &mut ws).t;
                for c in 0..nc {
                    let dropped = ((p_star[c] - pose.t[c]) - prepared[k * nc + c]) * 1e6;
                    let diff = (ours[c] - (pred[c] - dropped)).abs();
                    worst.add("artefact (commanded, dropped term added)", diff, ours[c]);
                    assert!(
                        diff < TOL_UM * reach,
                        "{file} run {} sample {k} channel {}: indsim {} µm, mtcal {} µm with \
                         the dropped term {dropped} µm (diff {diff:e})",
                        run.name,
                        names[c],
                        ours[c],
                        pred[c] - dropped
                    );
                }
            }
            for c in 0..names.len() {
                let theirs = if relative { pred[c] - base[c] } else { pred[c] };
                assert_eq!(
                    written[c], written_clean[c],
                    "ideal realism writes the clean readings"
                );
                let diff = (ours[c] - theirs).abs();
                worst.add(&inst_label, diff, ours[c]);
                assert!(
                    diff < tol,
                    "{file} run {} sample {k} channel {}: indsim {} {unit}, mtcal {} {unit} (diff \
                     {diff:e})",
                    run.name,
                    names[c],
                    ours[c],
                    theirs
                );
            }
        }
    }
    worst
}

#[test]
fn readings_agree_with_mtcal_on_every_shipped_machine() {
    for (k, file) in MACHINES.iter().enumerate() {
        let worst = compare(file, Mount::BallInSpindle, true, 100 + k as u64);
        for (inst, d, n, size) in &worst.by_instrument {
            eprintln!(
                "{file:28} {inst:42} readings {n:5} up to {size:9.3} max |indsim - mtcal| = {d:.3e}"
            );
        }
    }
}

#[test]
fn ball_on_table_readings_agree_with_mtcal() {
    for (k, file) in MACHINES.iter().enumerate() {
        compare(file, Mount::BallOnTable, true, 200 + k as u64);
    }
}

/// With a realistic measurement the newer instruments' and laser modes' files still load in
/// mtcal (an angular laser states its σ as `sigma_urad`), and the noise is the stated µm in
/// their own units (the artefact's readings are in mm, the angular laser's in µrad).
#[test]
fn realistic_files_of_the_newer_instruments_load_with_noise_in_their_units() {
    let file = "mcv754-zfyx.urdf";
    let urdf = shipped_machine(file);
    let machine = Machine::from_urdf_file(&urdf).unwrap();
    let truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(7), 1.0);
    let mut plan = plan_for(&machine, &urdf, Mount::BallOnTable, true);
    plan.runs.retain(|r| {
        ["disp", "artefact", "laser-diagonal", "laser-step-diagonal"]
            .iter()
            .any(|p| r.name.starts_with(p))
            || r.name.contains("angular")
    });
    assert!(plan.runs.iter().any(|r| r.name.contains("angular")));
    let realism = Realism::realistic(11);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("session");
    write_session(&dir, &machine, &truth, &plan, &realism).unwrap();
    let session = mtcal_session::load_session(&dir).unwrap();
    let m = mtcal_machine::urdf::load_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
    let mut noise_um = Vec::new();
    for run in &session.runs {
        let common::MtcalRun {
            setup,
            recorded: table,
            clean,
        } = read_mtcal_run(&dir, &session, run, &m);
        for k in 0..table.len() {
            for (c, ch) in setup.channels().iter().enumerate() {
                let um_per_unit = 1e6 / ch.unit.per_si();
                noise_um.push(
                    (table.reading_row(k).unwrap()[c] - clean.reading_row(k).unwrap()[c])
                        * um_per_unit,
                );
            }
        }
    }
    let rms = (noise_um.iter().map(|e| e * e).sum::<f64>() / noise_um.len() as f64).sqrt();
    assert!(
        (0.15..0.6).contains(&rms),
        "noise rms {rms} µm over {} readings, stated 0.3 µm",
        noise_um.len()
    );
}
