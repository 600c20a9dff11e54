//! Ready-made sessions for the identification tests: their machines, set-ups, runs and timing.

use std::path::Path;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::effects::Effect;
use crate::instruments::{Instrument, LaserMode, Mount};
use crate::machine::{Machine, translation_of};
use crate::session::{Plan, Realism, RunPlan, SetupPlan, SimError, Written, write_session};
use crate::truth::Truth;
use crate::{paths, shipped_machine};

/// The five-axis trunnion of [`Campaign::trunnion_rtest_ballbar`].
const TRUNNION: &str = "mcu630-cafyxz.urdf";
/// The three-axis machine of [`Campaign::three_axis_ballbar`] and
/// [`Campaign::three_axis_laser_tracer`].
const THREE_AXIS: &str = "mcv754-zfyx.urdf";

/// [`Campaign::trunnion_rtest_ballbar_effects`]: time between samples, s (an R-test or ball-bar
/// sample with its move and dwell).
pub const TRUNNION_EFFECTS_INTERVAL_S: f64 = 0.75;
/// [`Campaign::trunnion_rtest_ballbar_effects`]: time between runs, s.
pub const TRUNNION_EFFECTS_PAUSE_S: f64 = 15.0;
/// [`Campaign::three_axis_laser_tracer`]: time between samples, s (a laser target's or a tracer
/// point's move and dwell).
pub const THREE_AXIS_INTERVAL_S: f64 = 1.5;
/// [`Campaign::three_axis_laser_tracer`]: time between runs, s.
pub const THREE_AXIS_PAUSE_S: f64 = 15.0;

/// Ready-made sessions for the identification tests.
#[derive(Debug)]
pub struct Campaign;

impl Campaign {
    /// The shipped five-axis trunnion `machines/mcu630-cafyxz.urdf` (A cradle carrying a C
    /// table, spindle on X Y Z), a random truth from `seed` ([`Truth::random`], scale 1), and
    /// into `dir`:
    /// - R-test, ball on the table (`mount = "ball-on-table"` written), one shared
    ///   set-up `ball1` at [150, 0, 200] mm: `rtest-xyc` (C 0→360°, 145 samples), the same at
    ///   A = ±30° (`rtest-xyc-a+30`, `rtest-xyc-a-30`), `rtest-xyzac` (A −30→30° with C
    ///   0→360°, 289), and set-up `ball2` on the C axis at [0, 0, 200] mm: `rtest-yza`
    ///   (A −30→90°, 97);
    /// - ball bar, set-up `bar1` (pivot [0, 0, 200] mm, 100 mm): `ballbar-xy-ccw`,
    ///   `ballbar-xy-cw` (XY circles at A = C = 0, 361 samples), `ballbar-xy-c90` (the same
    ///   circle with C held at 90°);
    /// - validation runs: `rtest-validate` (ball1, A 20→−20° with C 0→180°, 37 samples),
    ///   `ballbar-validate` (bar1, an XY circle with C held at 45°, 91), `rtest-validate-a15`
    ///   (ball1, XYC at A = 15°, 73) and `ballbar-validate-c180` (bar1, the XY circle clockwise
    ///   with C held at 180°, 91).
    pub fn trunnion_rtest_ballbar(
        dir: &Path,
        seed: u64,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let machine = Machine::from_urdf_file(&shipped_machine(TRUNNION))?;
        let truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0);
        Self::trunnion_rtest_ballbar_with(dir, &truth, realism)
    }

    /// [`Self::trunnion_rtest_ballbar`] with a given truth (e.g. a random draw with the rotary
    /// axes' component errors removed).
    pub fn trunnion_rtest_ballbar_with(
        dir: &Path,
        truth: &Truth,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(TRUNNION);
        let machine = Machine::from_urdf_file(&urdf)?;
        let plan = trunnion_plan(&machine, &urdf, Vec::new())?;
        write_session(dir, &machine, truth, &plan, realism)
    }

    /// [`Self::trunnion_rtest_ballbar_with`]'s runs with `effects` planted
    /// ([`crate::effects`]), timed as a real session: [`TRUNNION_EFFECTS_INTERVAL_S`] between
    /// samples and [`TRUNNION_EFFECTS_PAUSE_S`] between runs (instead of `realism`'s), so that
    /// the session lasts about half an hour (2196 samples: 30.1 min from the first sample to
    /// the last) and thermal effects have time to show. The random draws are `realism`'s.
    pub fn trunnion_rtest_ballbar_effects(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(TRUNNION);
        let machine = Machine::from_urdf_file(&urdf)?;
        let plan = trunnion_plan(&machine, &urdf, effects.to_vec())?;
        let timed = Realism {
            interval_s: TRUNNION_EFFECTS_INTERVAL_S,
            pause_s: TRUNNION_EFFECTS_PAUSE_S,
            ..realism.clone()
        };
        write_session(dir, &machine, truth, &plan, &timed)
    }

    /// [`Self::trunnion_rtest_ballbar_effects`] with the runs in the order an engineer who
    /// expects the machine to drift would measure them: R-test and ball-bar runs alternating,
    /// the validation runs spread over the session, and the first XYC repeated at the end
    /// (`rtest-xyc-end`, fitted), so that every time of the session is seen by some fitted run
    /// that reads Z and every validation run lies inside the fitted time span:
    /// `rtest-xyc`, `ballbar-xy-ccw`, `rtest-yza`, `ballbar-xy-cw`, `rtest-validate`,
    /// `rtest-xyzac`, `ballbar-xy-c90`, `rtest-xyc-a+30`, `ballbar-validate`, `rtest-xyc-a-30`,
    /// `rtest-validate-a15`, `ballbar-validate-c180`, `rtest-xyc-end` (2341 samples, 32.5 min).
    pub fn trunnion_thermal_check(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(TRUNNION);
        let machine = Machine::from_urdf_file(&urdf)?;
        let mut plan = trunnion_plan(&machine, &urdf, effects.to_vec())?;
        let order = [
            "rtest-xyc",
            "ballbar-xy-ccw",
            "rtest-yza",
            "ballbar-xy-cw",
            "rtest-validate",
            "rtest-xyzac",
            "ballbar-xy-c90",
            "rtest-xyc-a+30",
            "ballbar-validate",
            "rtest-xyc-a-30",
            "rtest-validate-a15",
            "ballbar-validate-c180",
        ];
        let mut runs = Vec::with_capacity(order.len() + 1);
        for name in order {
            let k = plan
                .runs
                .iter()
                .position(|r| r.name == name)
                .ok_or_else(|| SimError::Plan(format!("the trunnion plan has no run {name}")))?;
            runs.push(plan.runs.swap_remove(k));
        }
        let mut end = runs[0].clone();
        end.name = "rtest-xyc-end".into();
        runs.push(end);
        plan.runs = runs;
        let timed = Realism {
            interval_s: TRUNNION_EFFECTS_INTERVAL_S,
            pause_s: TRUNNION_EFFECTS_PAUSE_S,
            ..realism.clone()
        };
        write_session(dir, &machine, truth, &plan, &timed)
    }

    /// The shipped three-axis `machines/mcv754-zfyx.urdf` (X and Y carry the table, Z the
    /// spindle), a random truth from `seed`, and into `dir` one ball bar (set-up `bar1`, pivot
    /// [0, 0, 100] mm, 150 mm) on an XY circle counter-clockwise (`ballbar-xy-ccw`) and
    /// clockwise (`ballbar-xy-cw`), 361 samples each.
    pub fn three_axis_ballbar(
        dir: &Path,
        seed: u64,
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(THREE_AXIS);
        let machine = Machine::from_urdf_file(&urdf)?;
        let truth = Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0);
        let pivot = [0.0, 0.0, 100.0];
        let centre = Vector3::new(pivot[0], pivot[1], pivot[2]) * 1e-3;
        let circle = |ccw| paths::circle(&machine, centre, 0.15, (0, 1), ccw, &[], 361);
        let plan = Plan {
            machine_urdf: urdf.clone(),
            setups: vec![SetupPlan {
                name: "bar1".into(),
                instrument: Instrument::BallBar {
                    pivot_mm: pivot,
                    length_mm: 150.0,
                },
            }],
            runs: vec![
                RunPlan {
                    name: "ballbar-xy-ccw".into(),
                    setup: "bar1".into(),
                    validate: false,
                    poses: circle(true)?,
                    labels: Vec::new(),
                },
                RunPlan {
                    name: "ballbar-xy-cw".into(),
                    setup: "bar1".into(),
                    validate: false,
                    poses: circle(false)?,
                    labels: Vec::new(),
                },
            ],
            effects: Vec::new(),
        };
        write_session(dir, &machine, &truth, &plan, realism)
    }

    /// The shipped three-axis `machines/mcv754-zfyx.urdf` with `truth` and `effects` planted
    /// ([`crate::effects`]; none for the geometric model alone): a laser-interferometer and a
    /// laser-tracer campaign, as `examples/three-axis` measures that machine, into `dir`. Each
    /// run has a set-up of its own (named after it) except the tracer check.
    /// - ISO 230-2 positioning (laser `linear`, beam along the axis, optic 80 mm below the
    ///   gauge point): 11 targets, 3 bidirectional cycles, 5 mm overrun (73 samples each):
    ///   `laser-x` (X −350…350 mm at Y = 0, Z = −250), `laser-y` (Y −250…250 at X = 0,
    ///   Z = −250), `laser-z` (Z −500…−40 at X = Y = 0);
    /// - straightness (laser `straightness`): `laser-x-straightness-y` (X −350…350 mm, 15
    ///   points, read along Y) and `laser-y-straightness-x` (Y −250…250, 11, read along X);
    /// - laser tracer: stations on the table at [420, 320, 0], [−420, 320, 80],
    ///   [−420, −320, 20] and [420, −320, 150] mm, each with three reflector positions (at the
    ///   tool point, [0, 0, −120] and [120, 80, −60] mm in the tool frame):
    ///   `tracer-s<1..4>-r<1..3>`, the same 4 × 4 × 4 grid over 80 % of the strokes (64
    ///   samples) from each;
    /// - validation: `laser-diagonal` (the body diagonal from −X −Y −Z to +X +Y +Z over 80 %
    ///   of the strokes, 11 targets) and `tracer-check` (set-up `tracer-s2-r3`, a 3 × 3 × 3
    ///   grid over half the strokes, 27 samples).
    ///
    /// 19 runs, 1051 samples, timed as a real session: [`THREE_AXIS_INTERVAL_S`] between samples
    /// and [`THREE_AXIS_PAUSE_S`] between runs (instead of `realism`'s): 30.5 min from the first
    /// sample to the last. The random draws are `realism`'s.
    pub fn three_axis_laser_tracer(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(THREE_AXIS);
        let machine = Machine::from_urdf_file(&urdf)?;
        let mut plan = Plan {
            machine_urdf: urdf,
            setups: Vec::new(),
            runs: Vec::new(),
            effects: effects.to_vec(),
        };
        laser_runs(&machine, &mut plan)?;
        tracer_runs(&machine, &mut plan)?;
        validation_runs(&machine, &mut plan)?;
        let timed = Realism {
            interval_s: THREE_AXIS_INTERVAL_S,
            pause_s: THREE_AXIS_PAUSE_S,
            ..realism.clone()
        };
        write_session(dir, &machine, truth, &plan, &timed)
    }
}

/// The trunnion campaign's set-ups and runs ([`Campaign::trunnion_rtest_ballbar`]).
fn trunnion_plan(machine: &Machine, urdf: &Path, effects: Vec<Effect>) -> Result<Plan, SimError> {
    let deg = f64::to_radians;
    let ball1 = [150.0, 0.0, 200.0];
    let ball2 = [0.0, 0.0, 200.0];
    let rtest = |ball_mm| Instrument::RTest {
        ball_mm,
        mount: Mount::BallOnTable,
        write_mount_key: true,
    };
    let at = |v: [f64; 3]| Vector3::new(v[0], v[1], v[2]) * 1e-3;
    let pivot = [0.0, 0.0, 200.0];
    let circle =
        |ccw, hold: &[(char, f64)], n| paths::circle(machine, at(pivot), 0.1, (0, 1), ccw, hold, n);
    // Source 000's XYC: C turned once round with the cradle held at `a_deg`.
    let xyc = |a_deg: f64, n| {
        paths::follow_ball(
            machine,
            at(ball1),
            &[('C', 0.0, deg(360.0))],
            &[('A', deg(a_deg))],
            n,
        )
    };
    let run = |name: &str, setup: &str, validate, poses| RunPlan {
        name: name.into(),
        setup: setup.into(),
        validate,
        poses,
        labels: Vec::new(),
    };
    Ok(Plan {
        machine_urdf: urdf.to_path_buf(),
        setups: vec![
            SetupPlan {
                name: "ball1".into(),
                instrument: rtest(ball1),
            },
            SetupPlan {
                name: "ball2".into(),
                instrument: rtest(ball2),
            },
            SetupPlan {
                name: "bar1".into(),
                instrument: Instrument::BallBar {
                    pivot_mm: pivot,
                    length_mm: 100.0,
                },
            },
        ],
        runs: vec![
            run("rtest-xyc", "ball1", false, xyc(0.0, 145)?),
            run(
                "rtest-yza",
                "ball2",
                false,
                paths::follow_ball(machine, at(ball2), &[('A', deg(-30.0), deg(90.0))], &[], 97)?,
            ),
            run(
                "rtest-xyzac",
                "ball1",
                false,
                paths::follow_ball(
                    machine,
                    at(ball1),
                    &[('A', deg(-30.0), deg(30.0)), ('C', 0.0, deg(360.0))],
                    &[],
                    289,
                )?,
            ),
            // The XYC at the cradle tilted both ways: the C axis' location relative to
            // the A axis, seen from three A angles.
            run("rtest-xyc-a+30", "ball1", false, xyc(30.0, 145)?),
            run("rtest-xyc-a-30", "ball1", false, xyc(-30.0, 145)?),
            run("ballbar-xy-ccw", "bar1", false, circle(true, &[], 361)?),
            run("ballbar-xy-cw", "bar1", false, circle(false, &[], 361)?),
            // The same circle with the table turned a quarter: the pivot's offset from
            // C's axis line separates from the line's own position.
            run(
                "ballbar-xy-c90",
                "bar1",
                false,
                circle(true, &[('C', deg(90.0))], 361)?,
            ),
            run(
                "rtest-validate",
                "ball1",
                true,
                paths::follow_ball(
                    machine,
                    at(ball1),
                    &[('A', deg(20.0), deg(-20.0)), ('C', 0.0, deg(180.0))],
                    &[],
                    37,
                )?,
            ),
            run(
                "ballbar-validate",
                "bar1",
                true,
                circle(true, &[('C', deg(45.0))], 91)?,
            ),
            // An XYC between the tilts measured (within what the fitted runs determine),
            // and the circle with the table turned half a revolution, clockwise (which,
            // like the one at 45°, also sees C's radial motion at that angle).
            run("rtest-validate-a15", "ball1", true, xyc(15.0, 73)?),
            run(
                "ballbar-validate-c180",
                "bar1",
                true,
                circle(false, &[('C', deg(180.0))], 91)?,
            ),
        ],
        effects,
    })
}

/// Adds a run with a set-up of its own, both called `name`.
fn own_setup(
    plan: &mut Plan,
    name: &str,
    instrument: Instrument,
    validate: bool,
    poses: Vec<Vec<f64>>,
) {
    plan.setups.push(SetupPlan {
        name: name.into(),
        instrument,
    });
    plan.runs.push(RunPlan {
        name: name.into(),
        setup: name.into(),
        validate,
        poses,
        labels: Vec::new(),
    });
}

/// [`Campaign::three_axis_laser_tracer`]'s moving optic: on a holder 80 mm below the spindle's
/// gauge point (the tool's +z points into the spindle), an Abbe offset for the angular errors
/// to act through.
const LASER_OPTIC_MM: [f64; 3] = [0.0, 0.0, -80.0];

/// The laser runs of [`Campaign::three_axis_laser_tracer`]: ISO 230-2 positioning of each
/// axis and two straightness runs.
fn laser_runs(machine: &Machine, plan: &mut Plan) -> Result<(), SimError> {
    let mm = 1e-3;
    let laser = |mode, direction, across| Instrument::Laser {
        mode,
        direction,
        across,
        optic_offset_mm: LASER_OPTIC_MM,
    };
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let iso = |axis, from: f64, to: f64, hold: &[(char, f64)]| {
        paths::bidirectional(machine, axis, from * mm, to * mm, 11, 3, 5.0 * mm, hold)
    };
    let at_z = [('Z', -250.0 * mm)];
    let runs = [
        (
            "laser-x",
            x,
            iso('X', -350.0, 350.0, &[('Y', 0.0), at_z[0]])?,
        ),
        (
            "laser-y",
            y,
            iso('Y', -250.0, 250.0, &[('X', 0.0), at_z[0]])?,
        ),
        ("laser-z", z, iso('Z', -500.0, -40.0, &[])?),
    ];
    for (name, dir, poses) in runs {
        own_setup(
            plan,
            name,
            laser(LaserMode::Linear, dir, [0.0; 3]),
            false,
            poses,
        );
    }
    let straight = [
        (
            "laser-x-straightness-y",
            x,
            y,
            paths::line(machine, 'X', -0.35, 0.35, 15, &at_z)?,
        ),
        (
            "laser-y-straightness-x",
            y,
            x,
            paths::line(machine, 'Y', -0.25, 0.25, 11, &at_z)?,
        ),
    ];
    for (name, dir, sense, poses) in straight {
        own_setup(
            plan,
            name,
            laser(LaserMode::Straightness, dir, sense),
            false,
            poses,
        );
    }
    Ok(())
}

/// The tracer runs of [`Campaign::three_axis_laser_tracer`]: one grid from four stations with
/// three reflector offsets.
fn tracer_runs(machine: &Machine, plan: &mut Plan) -> Result<(), SimError> {
    let stations = [
        [420.0, 320.0, 0.0],
        [-420.0, 320.0, 80.0],
        [-420.0, -320.0, 20.0],
        [420.0, -320.0, 150.0],
    ];
    let reflectors = [[0.0, 0.0, 0.0], [0.0, 0.0, -120.0], [120.0, 80.0, -60.0]];
    let grid = paths::grid(machine, 0.8, [4, 4, 4], &[])?;
    for (r, reflector_mm) in reflectors.iter().enumerate() {
        for (s, station_mm) in stations.iter().enumerate() {
            let name = format!("tracer-s{}-r{}", s + 1, r + 1);
            let instrument = Instrument::Tracer {
                station_mm: *station_mm,
                reflector_mm: *reflector_mm,
            };
            own_setup(plan, &name, instrument, false, grid.clone());
        }
    }
    Ok(())
}

/// The validation runs of [`Campaign::three_axis_laser_tracer`]: a body diagonal with the
/// laser (a set-up of its own) and a tracer run on another grid from a fitted set-up.
fn validation_runs(machine: &Machine, plan: &mut Plan) -> Result<(), SimError> {
    // The beam along the diagonal's nominal travel.
    let poses = paths::diagonal(machine, 0.8, [1.0, 1.0, 1.0], 11, false, &[])?;
    let ends = [&poses[0], &poses[poses.len() - 1]]
        .map(|q| translation_of(&machine.tool_in_workpiece(q, None)));
    let beam = (ends[1] - ends[0]).normalize();
    let laser = Instrument::Laser {
        mode: LaserMode::Diagonal,
        direction: [beam.x, beam.y, beam.z],
        across: [0.0; 3],
        optic_offset_mm: LASER_OPTIC_MM,
    };
    own_setup(plan, "laser-diagonal", laser, true, poses);
    plan.runs.push(RunPlan {
        name: "tracer-check".into(),
        setup: "tracer-s2-r3".into(),
        validate: true,
        poses: paths::grid(machine, 0.5, [3, 3, 3], &[])?,
        labels: Vec::new(),
    });
    Ok(())
}
