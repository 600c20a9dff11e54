//! Ready-made sessions for the identification tests: their machines, set-ups, runs and timing.

use std::path::Path;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::effects::{Effect, HeatSource, Programme, TemperatureProgramme};
use crate::instruments::{Instrument, LaserMode, Mount};
use crate::machine::{Machine, translation_of};
use crate::session::{Plan, Realism, RunPlan, SetupPlan, SimError, Written, write_session};
use crate::truth::Truth;
use crate::volumetric::{
    Schedule, StreamOptions, VolumetricBall, VolumetricPlan, VolumetricPoint, VolumetricWritten,
    write_volumetric,
};
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
                    interval_s: None,
                    pause_before_s: None,
                },
                RunPlan {
                    name: "ballbar-xy-cw".into(),
                    setup: "bar1".into(),
                    validate: false,
                    poses: circle(false)?,
                    labels: Vec::new(),
                    interval_s: None,
                    pause_before_s: None,
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
        interval_s: None,
        pause_before_s: None,
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
        interval_s: None,
        pause_before_s: None,
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
        interval_s: None,
        pause_before_s: None,
    });
    Ok(())
}

/// The five-axis layouts with a ready-made half-hour session ([`Campaign::five_axis_check`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FiveAxisLayout {
    /// `machines/mcu630-cafyxz.urdf`: a C table in an A cradle
    /// ([`Campaign::trunnion_thermal_check`]).
    Trunnion,
    /// `machines/mcv1000-5ax220-bc.urdf`: a C plate on a B tilting table
    /// ([`Campaign::table_table_check`]).
    TableTable,
    /// `machines/headhead-xyzca.urdf`: a C head carrying an A fork head
    /// ([`Campaign::head_head_check`]).
    HeadHead,
    /// `machines/mixed-c-table-b-head.urdf`: a C table and a B swivel head
    /// ([`Campaign::mixed_check`]).
    Mixed,
}

impl FiveAxisLayout {
    /// Every layout.
    pub const ALL: [FiveAxisLayout; 4] = [
        FiveAxisLayout::Trunnion,
        FiveAxisLayout::TableTable,
        FiveAxisLayout::HeadHead,
        FiveAxisLayout::Mixed,
    ];

    /// The shipped machine's file name in `machines/` ([`crate::shipped_machine`]).
    pub fn urdf_file(self) -> &'static str {
        match self {
            FiveAxisLayout::Trunnion => TRUNNION,
            FiveAxisLayout::TableTable => TABLE_TABLE.file,
            FiveAxisLayout::HeadHead => HEAD_HEAD.file,
            FiveAxisLayout::Mixed => MIXED.file,
        }
    }

    /// The shipped machine, parsed.
    pub fn machine(self) -> Result<Machine, SimError> {
        Ok(Machine::from_urdf_file(&shipped_machine(self.urdf_file()))?)
    }
}

/// [`Campaign::three_axis_ballbar_planes`]: the bar's length, mm.
pub const PLANES_BAR_MM: f64 = 150.0;
/// [`Campaign::three_axis_ballbar_planes`]: time between runs on one plane, s.
pub const PLANES_PAUSE_S: f64 = 15.0;
/// [`Campaign::three_axis_ballbar_planes`]: time to turn the bar to the next plane, s.
pub const PLANES_CHANGE_S: f64 = 120.0;

impl Campaign {
    /// The half-hour R-test and ball-bar session of `layout`'s shipped machine with `truth` and
    /// `effects` planted: [`Self::trunnion_thermal_check`], [`Self::table_table_check`],
    /// [`Self::head_head_check`] or [`Self::mixed_check`].
    pub fn five_axis_check(
        layout: FiveAxisLayout,
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        match layout {
            FiveAxisLayout::Trunnion => Self::trunnion_thermal_check(dir, truth, effects, realism),
            FiveAxisLayout::TableTable => {
                five_axis_session(&TABLE_TABLE, dir, truth, effects, realism)
            }
            FiveAxisLayout::HeadHead => five_axis_session(&HEAD_HEAD, dir, truth, effects, realism),
            FiveAxisLayout::Mixed => five_axis_session(&MIXED, dir, truth, effects, realism),
        }
    }

    /// The shipped table-table machine `machines/mcv1000-5ax220-bc.urdf` (a NIKKEN tilting
    /// rotary table: B tilt −105…15°, C plate, on the X table; spindle on Z) with `truth` and
    /// `effects` planted, into `dir`, timed as [`Self::trunnion_thermal_check`]
    /// ([`TRUNNION_EFFECTS_INTERVAL_S`] between samples, [`TRUNNION_EFFECTS_PAUSE_S`] between
    /// runs; the random draws `realism`'s). Set-ups (R-test ball on the table,
    /// `mount = "ball-on-table"`; positions in the workpiece frame, the plate-top centre):
    /// `ball1` at [100, 0, 100] mm (off the C axis), `ball2` at [0, 0, 150] mm (on it), ball bar
    /// `bar1` (pivot [0, 0, 100] mm, 100 mm). Runs in time order (R-test runs follow the ball
    /// with X, Y, Z):
    /// `rtest-c` (ball1, C 0→360° at B = 0, 145 samples), `ballbar-xy-ccw` (XY circle at
    /// B = C = 0, 361), `rtest-b` (ball2, B −90→15° at C = 0, 85), `ballbar-xy-cw` (361),
    /// `rtest-validate` (validation: ball1, B −20→−70° with C 0→180°, 37), `rtest-bc` (ball1,
    /// B 0→−60° with C 0→360°, 289), `ballbar-xy-c90` (the circle with C held at 90°, 361),
    /// `rtest-c-b-45` (C turn at B = −45°, 145), `ballbar-validate` (validation: circle with C
    /// at 45°, 91), `rtest-c-b-75` (C turn at B = −75°, 145), `rtest-validate-b-30`
    /// (validation: C 0→360° at B = −30°, 73), `ballbar-validate-c180` (validation: clockwise
    /// circle with C at 180°, 91), `rtest-b-c90` (ball1, B −90→15° at C = 90°, 85), and
    /// `rtest-c-end` (`rtest-c` repeated, fitted). 14 runs, 2414 samples, 33.3 min.
    ///
    /// The C turns at three B tilts see where C's line lies relative to B's (its position in
    /// X and Y and its tilts); the B sweeps with the ball on and off C's line see B's line (its
    /// position in X and Z and its tilts about X and Z).
    pub fn table_table_check(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        five_axis_session(&TABLE_TABLE, dir, truth, effects, realism)
    }

    /// The shipped head-head gantry `machines/headhead-xyzca.urdf` (C head carrying an A fork
    /// head, 200 mm pivot; fixed table) with `truth` and `effects` planted, into `dir`, timed
    /// as [`Self::table_table_check`]. Set-ups (R-test ball on the table on a riser,
    /// `mount = "ball-on-table"`; the workpiece frame is the table-top centre): `ball1` at
    /// [150, −100, 300] mm, `ball2` at [0, 0, 300] mm, ball bar `bar1` (pivot [0, 0, 250] mm,
    /// 100 mm). Runs in time order (R-test runs follow the ball with X, Y, Z):
    /// `rtest-c` (ball1, C 0→360° at A = 30°, 145), `ballbar-xy-ccw` (XY circle at
    /// A = C = 0, 361), `rtest-a` (ball2, A −60→60° at C = 0, 97), `ballbar-xy-cw` (361),
    /// `rtest-validate` (validation: ball1, A 45→−45° with C 0→180°, 37), `rtest-ac` (ball1,
    /// A −45→45° with C 0→360°, 289), `ballbar-xy-a+30` (the circle with the head tilted,
    /// A = 30°, 361), `rtest-c-a-30` (C turn at A = −30°, 145), `ballbar-validate`
    /// (validation: circle at A = 15°, C = 45°, 91), `rtest-c-a+50` (C turn at A = 50°, 145),
    /// `rtest-validate-a-15` (validation: C 0→360° at A = −15°, 73), `ballbar-validate-c90`
    /// (validation: clockwise circle at A = −20°, C = 90°, 91), `rtest-a-c90` (ball1, A −60→60°
    /// at C = 90°, 97), `rtest-c-end` (`rtest-c` repeated, fitted). 14 runs, 2438 samples,
    /// 33.6 min.
    ///
    /// The C turns with the fork tilted both ways see A's line relative to C's (the tool point
    /// circles C's line); the A sweeps at two C angles see A's line in both horizontal
    /// directions.
    pub fn head_head_check(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        five_axis_session(&HEAD_HEAD, dir, truth, effects, realism)
    }

    /// The shipped mixed machine `machines/mixed-c-table-b-head.urdf` (a C table on the X
    /// slide, a B swivel head with a 300 mm pivot on Z) with `truth` and `effects` planted,
    /// into `dir`, timed as [`Self::table_table_check`]. Set-ups (R-test ball on the table,
    /// `mount = "ball-on-table"`; the workpiece frame is the C table-top centre): `ball1` at
    /// [150, 0, 300] mm (off the C axis, on a riser), `ball2` at [0, 0, 300] mm (on it), ball
    /// bar `bar1` (pivot [0, 0, 200] mm, 100 mm). Runs in time order (R-test runs follow the
    /// ball with X, Y, Z):
    /// `rtest-c` (ball1, C 0→360° at B = 0, 145), `ballbar-xy-ccw` (XY circle at B = C = 0,
    /// 361), `rtest-b` (ball2, B −50→50° at C = 0, 81), `ballbar-xy-cw` (361),
    /// `rtest-validate` (validation: ball1, B 35→−35° with C 0→180°, 37), `rtest-bc` (ball1,
    /// B −30→30° with C 0→360°, 289), `ballbar-xy-c90` (the circle with C held at 90°, 361),
    /// `rtest-c-b+30` (C turn at B = 30°, 145), `ballbar-validate` (validation: circle with C
    /// at 45° and B at 10°, 91), `rtest-c-b-30` (C turn at B = −30°, 145),
    /// `rtest-validate-b+15` (validation: C 0→360° at B = 15°, 73), `ballbar-validate-c180`
    /// (validation: clockwise circle with C at 180°, 91), `rtest-b-c90` (ball1, B −50→50° at
    /// C = 90°, 81), `rtest-c-end` (`rtest-c` repeated, fitted). 14 runs, 2406 samples,
    /// 33.2 min.
    ///
    /// The C turns at three B angles see C's line on the table and B's offset from it (the
    /// head tilted carries the tool point round a different circle); the B sweeps with the ball
    /// on and off C's line, at two C angles, see B's line.
    pub fn mixed_check(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        five_axis_session(&MIXED, dir, truth, effects, realism)
    }

    /// The shipped three-axis `machines/mcv754-zfyx.urdf` with `truth` and `effects` planted:
    /// a ball-bar-only session in three planes, as a ball bar is used (ISO 230-4), into `dir`.
    /// One set-up `bar1`: the centre pivot on the table at [0, 0, 160] mm, a
    /// [`PLANES_BAR_MM`] bar. Each plane is measured counter-clockwise and clockwise at 1000
    /// and 3000 mm/min; the bar is turned to the next plane between them:
    /// - XY, full circles (361 samples, 1° apart, from +X): `ballbar-xy-ccw-f1000`,
    ///   `ballbar-xy-cw-f1000`, `ballbar-xy-ccw-f3000`, `ballbar-xy-cw-f3000`, and
    ///   `ballbar-xy-cw-f2000` (validation);
    /// - YZ, 220° arcs above the pivot (the spindle cannot pass below it; 221 samples, angle
    ///   from +Y towards +Z, −20° → 200° counter-clockwise and back clockwise):
    ///   `ballbar-yz-ccw-f1000`, `ballbar-yz-cw-f1000`, `ballbar-yz-ccw-f3000`,
    ///   `ballbar-yz-cw-f3000`;
    /// - ZX, 220° arcs above the pivot (angle from +Z towards +X, −110° → 110°
    ///   counter-clockwise and back clockwise): `ballbar-zx-ccw-f1000`, `ballbar-zx-cw-f1000`,
    ///   `ballbar-zx-ccw-f3000`, `ballbar-zx-cw-f3000`, and `ballbar-zx-ccw-f2000`
    ///   (validation).
    ///
    /// Timed by the feed: the samples 1° of arc apart, `150 mm · π/180` over the feed (0.157 s
    /// at 1000 mm/min, 0.052 s at 3000); [`PLANES_PAUSE_S`] between runs on a plane,
    /// [`PLANES_CHANGE_S`] to turn the bar to the next plane. 14 runs, 3794 samples, 13.1 min.
    /// The random draws are `realism`'s (its interval and pause are not used).
    pub fn three_axis_ballbar_planes(
        dir: &Path,
        truth: &Truth,
        effects: &[Effect],
        realism: &Realism,
    ) -> Result<Written, SimError> {
        let urdf = shipped_machine(THREE_AXIS);
        let machine = Machine::from_urdf_file(&urdf)?;
        let pivot = [0.0, 0.0, 160.0];
        let centre = Vector3::new(pivot[0], pivot[1], pivot[2]) * 1e-3;
        let radius = PLANES_BAR_MM * 1e-3;
        let deg = f64::to_radians;
        // (plane tag, plane (e1, e2), counter-clockwise from..to in degrees, samples,
        // validation (direction, feed)).
        type Plane = (
            &'static str,
            (usize, usize),
            (f64, f64),
            usize,
            Option<(bool, f64)>,
        );
        let planes: [Plane; 3] = [
            ("xy", (0, 1), (0.0, 360.0), 361, Some((false, 2000.0))),
            ("yz", (1, 2), (-20.0, 200.0), 221, None),
            ("zx", (2, 0), (-110.0, 110.0), 221, Some((true, 2000.0))),
        ];
        let mut runs = Vec::new();
        for (p, &(tag, plane, (from, to), samples, validation)) in planes.iter().enumerate() {
            let mut these = Vec::new();
            let mut one = |ccw: bool, feed: f64, validate: bool| -> Result<(), SimError> {
                let (a, b) = if ccw { (from, to) } else { (to, from) };
                let poses = paths::arc(
                    &machine,
                    centre,
                    radius,
                    plane,
                    (deg(a), deg(b)),
                    &[],
                    samples,
                )?;
                let step_mm = PLANES_BAR_MM * deg((to - from) / (samples - 1) as f64);
                these.push(RunPlan {
                    name: format!("ballbar-{tag}-{}-f{feed}", if ccw { "ccw" } else { "cw" }),
                    setup: "bar1".into(),
                    validate,
                    poses,
                    labels: Vec::new(),
                    interval_s: Some(step_mm / (feed / 60.0)),
                    pause_before_s: Some(PLANES_PAUSE_S),
                });
                Ok(())
            };
            for feed in [1000.0, 3000.0] {
                one(true, feed, false)?;
                one(false, feed, false)?;
            }
            if let Some((ccw, feed)) = validation {
                one(ccw, feed, true)?;
            }
            if p > 0 {
                these[0].pause_before_s = Some(PLANES_CHANGE_S);
            }
            runs.extend(these);
        }
        let plan = Plan {
            machine_urdf: urdf,
            setups: vec![SetupPlan {
                name: "bar1".into(),
                instrument: Instrument::BallBar {
                    pivot_mm: pivot,
                    length_mm: PLANES_BAR_MM,
                },
            }],
            runs,
            effects: effects.to_vec(),
        };
        write_session(dir, &machine, truth, &plan, realism)
    }
}

/// A five-axis R-test and ball-bar session ([`five_axis_session`]): one rotary axis turned
/// once round (`turn`), the other swept over part of its stroke (`tilt`). Angles in degrees,
/// positions in mm.
struct FiveAxisSpec {
    file: &'static str,
    /// Off and on the turning axis' line.
    ball1: [f64; 3],
    ball2: [f64; 3],
    pivot: [f64; 3],
    bar_mm: f64,
    turn: char,
    tilt: char,
    /// Tilt settings of the fitted turns (the first opens and closes the session).
    turn_at: [f64; 3],
    /// The tilt sweep (ball2 at turn 0, ball1 at turn `tilt_c`), its samples.
    tilt_range: (f64, f64),
    tilt_samples: usize,
    tilt_c: f64,
    /// The combined run's tilt range (the turn 0→360°).
    combined: (f64, f64),
    /// What the third fitted circle holds, and its tag.
    bar_hold: (char, f64),
    /// Validation: the combined sweep's tilt range (turn 0→180°), the tilt of the turn, the
    /// two circles' holds (counter-clockwise and clockwise) and the clockwise one's tag.
    validate_sweep: (f64, f64),
    validate_turn_at: f64,
    validate_bar: [(f64, f64); 2],
    validate_bar_tag: &'static str,
}

const TABLE_TABLE: FiveAxisSpec = FiveAxisSpec {
    file: "mcv1000-5ax220-bc.urdf",
    ball1: [100.0, 0.0, 100.0],
    ball2: [0.0, 0.0, 150.0],
    pivot: [0.0, 0.0, 100.0],
    bar_mm: 100.0,
    turn: 'C',
    tilt: 'B',
    turn_at: [0.0, -45.0, -75.0],
    tilt_range: (-90.0, 15.0),
    tilt_samples: 85,
    tilt_c: 90.0,
    combined: (0.0, -60.0),
    bar_hold: ('C', 90.0),
    validate_sweep: (-20.0, -70.0),
    validate_turn_at: -30.0,
    // (tilt, turn)
    validate_bar: [(0.0, 45.0), (0.0, 180.0)],
    validate_bar_tag: "c180",
};

const HEAD_HEAD: FiveAxisSpec = FiveAxisSpec {
    file: "headhead-xyzca.urdf",
    ball1: [150.0, -100.0, 300.0],
    ball2: [0.0, 0.0, 300.0],
    pivot: [0.0, 0.0, 250.0],
    bar_mm: 100.0,
    turn: 'C',
    tilt: 'A',
    turn_at: [30.0, -30.0, 50.0],
    tilt_range: (-60.0, 60.0),
    tilt_samples: 97,
    tilt_c: 90.0,
    combined: (-45.0, 45.0),
    bar_hold: ('A', 30.0),
    validate_sweep: (45.0, -45.0),
    validate_turn_at: -15.0,
    validate_bar: [(15.0, 45.0), (-20.0, 90.0)],
    validate_bar_tag: "c90",
};

const MIXED: FiveAxisSpec = FiveAxisSpec {
    file: "mixed-c-table-b-head.urdf",
    ball1: [150.0, 0.0, 300.0],
    ball2: [0.0, 0.0, 300.0],
    pivot: [0.0, 0.0, 200.0],
    bar_mm: 100.0,
    turn: 'C',
    tilt: 'B',
    turn_at: [0.0, 30.0, -30.0],
    tilt_range: (-50.0, 50.0),
    tilt_samples: 81,
    tilt_c: 90.0,
    combined: (-30.0, 30.0),
    bar_hold: ('C', 90.0),
    validate_sweep: (35.0, -35.0),
    validate_turn_at: 15.0,
    validate_bar: [(10.0, 45.0), (0.0, 180.0)],
    validate_bar_tag: "c180",
};

/// A tilt setting's tag: the axis letter and the signed angle (`b-45`, `a+30`).
fn tilt_tag(axis: char, deg: f64) -> String {
    format!("{}{deg:+}", axis.to_ascii_lowercase())
}

/// [`FiveAxisSpec`]'s session (see [`Campaign::table_table_check`] for the runs' pattern).
fn five_axis_session(
    spec: &FiveAxisSpec,
    dir: &Path,
    truth: &Truth,
    effects: &[Effect],
    realism: &Realism,
) -> Result<Written, SimError> {
    let urdf = shipped_machine(spec.file);
    let machine = Machine::from_urdf_file(&urdf)?;
    let deg = f64::to_radians;
    let at = |v: [f64; 3]| Vector3::new(v[0], v[1], v[2]) * 1e-3;
    let (turn, tilt) = (spec.turn, spec.tilt);
    let (tn, tl) = (turn.to_ascii_lowercase(), tilt.to_ascii_lowercase());
    let rtest = |ball_mm| Instrument::RTest {
        ball_mm,
        mount: Mount::BallOnTable,
        write_mount_key: true,
    };
    let run = |name: String, setup: &str, validate, poses| RunPlan {
        name,
        setup: setup.into(),
        validate,
        poses,
        labels: Vec::new(),
        interval_s: None,
        pause_before_s: None,
    };
    // The turning axis once round with the tilt held.
    let turn_run = |tilt_deg: f64, n| {
        paths::follow_ball(
            &machine,
            at(spec.ball1),
            &[(turn, 0.0, deg(360.0))],
            &[(tilt, deg(tilt_deg))],
            n,
        )
    };
    let tilt_run = |ball, turn_deg: f64| {
        paths::follow_ball(
            &machine,
            at(ball),
            &[(tilt, deg(spec.tilt_range.0), deg(spec.tilt_range.1))],
            &[(turn, deg(turn_deg))],
            spec.tilt_samples,
        )
    };
    let circle = |ccw, hold: &[(char, f64)], n| {
        paths::circle(
            &machine,
            at(spec.pivot),
            spec.bar_mm * 1e-3,
            (0, 1),
            ccw,
            hold,
            n,
        )
    };
    let first = run(
        format!("rtest-{tn}"),
        "ball1",
        false,
        turn_run(spec.turn_at[0], 145)?,
    );
    let mut end = first.clone();
    end.name = format!("rtest-{tn}-end");
    let (hold_axis, hold_deg) = spec.bar_hold;
    let hold_tag = if hold_axis == turn {
        format!("{tn}{hold_deg}")
    } else {
        tilt_tag(hold_axis, hold_deg)
    };
    let [(v1_tilt, v1_turn), (v2_tilt, v2_turn)] = spec.validate_bar;
    let runs = vec![
        first,
        run(
            "ballbar-xy-ccw".into(),
            "bar1",
            false,
            circle(true, &[], 361)?,
        ),
        run(
            format!("rtest-{tl}"),
            "ball2",
            false,
            tilt_run(spec.ball2, 0.0)?,
        ),
        run(
            "ballbar-xy-cw".into(),
            "bar1",
            false,
            circle(false, &[], 361)?,
        ),
        run(
            "rtest-validate".into(),
            "ball1",
            true,
            paths::follow_ball(
                &machine,
                at(spec.ball1),
                &[
                    (tilt, deg(spec.validate_sweep.0), deg(spec.validate_sweep.1)),
                    (turn, 0.0, deg(180.0)),
                ],
                &[],
                37,
            )?,
        ),
        run(
            format!("rtest-{tl}{tn}"),
            "ball1",
            false,
            paths::follow_ball(
                &machine,
                at(spec.ball1),
                &[
                    (tilt, deg(spec.combined.0), deg(spec.combined.1)),
                    (turn, 0.0, deg(360.0)),
                ],
                &[],
                289,
            )?,
        ),
        run(
            format!("ballbar-xy-{hold_tag}"),
            "bar1",
            false,
            circle(true, &[(hold_axis, deg(hold_deg))], 361)?,
        ),
        run(
            format!("rtest-{tn}-{}", tilt_tag(tilt, spec.turn_at[1])),
            "ball1",
            false,
            turn_run(spec.turn_at[1], 145)?,
        ),
        run(
            "ballbar-validate".into(),
            "bar1",
            true,
            circle(true, &[(tilt, deg(v1_tilt)), (turn, deg(v1_turn))], 91)?,
        ),
        run(
            format!("rtest-{tn}-{}", tilt_tag(tilt, spec.turn_at[2])),
            "ball1",
            false,
            turn_run(spec.turn_at[2], 145)?,
        ),
        run(
            format!("rtest-validate-{}", tilt_tag(tilt, spec.validate_turn_at)),
            "ball1",
            true,
            turn_run(spec.validate_turn_at, 73)?,
        ),
        run(
            format!("ballbar-validate-{}", spec.validate_bar_tag),
            "bar1",
            true,
            circle(false, &[(tilt, deg(v2_tilt)), (turn, deg(v2_turn))], 91)?,
        ),
        run(
            format!("rtest-{tl}-{tn}{}", spec.tilt_c),
            "ball1",
            false,
            tilt_run(spec.ball1, spec.tilt_c)?,
        ),
        end,
    ];
    let plan = Plan {
        machine_urdf: urdf,
        setups: vec![
            SetupPlan {
                name: "ball1".into(),
                instrument: rtest(spec.ball1),
            },
            SetupPlan {
                name: "ball2".into(),
                instrument: rtest(spec.ball2),
            },
            SetupPlan {
                name: "bar1".into(),
                instrument: Instrument::BallBar {
                    pivot_mm: spec.pivot,
                    length_mm: spec.bar_mm,
                },
            },
        ],
        runs,
        effects: effects.to_vec(),
    };
    let timed = Realism {
        interval_s: TRUNNION_EFFECTS_INTERVAL_S,
        pause_s: TRUNNION_EFFECTS_PAUSE_S,
        ..realism.clone()
    };
    write_session(dir, &machine, truth, &plan, &timed)
}

/// Which load heats the machine in the phases between the measuring cycles of a volumetric
/// thermal test ([`Campaign::volumetric_trunnion`], [`Campaign::volumetric_three_axis`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumetricLoad {
    /// The spindle turns at [`VOLUMETRIC_SPINDLE_RPM`] (`S`): the spindle head grows towards
    /// the table, uniformly (two first-order nodes of the speed), and the Z nut warms a little
    /// (`T_znut`), growing the Z screw (a small dependence on Z); `T_spindle` logs the housing.
    Spindle,
    /// The Y drive reciprocates: its temperature (`T_ydrive`, one node of the load) turns the
    /// spindle head about X (a lever arm that changes with Y and Z) and grows the Y scale.
    YDrive,
    /// Source 000's A/C load cycles on the trunnion, measured by R-test sets between them:
    /// the loaded phases swing the A cradle and turn the C table in turn (A first). The A
    /// drive's temperature (`T_adrive`) moves A's line in Y, the C motor's (`T_cdrive`) moves
    /// C's line in X ([`Effect::AxisLineDrift`]); the points are R-test sets
    /// ([`VolumetricSite::trunnion_rtest_sets`]). The trunnion only.
    RotaryDrives,
}

/// The room's temperature steps during a volumetric thermal test ([`Effect::AmbientStep`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AmbientChange {
    pub at_s: f64,
    pub step_k: f64,
}

impl AmbientChange {
    /// Source 000's Z-drive test: the air conditioning failed at about the 4th hour and the
    /// hall cooled by about 4 K.
    pub fn air_conditioning_failure() -> Self {
        AmbientChange {
            at_s: 4.0 * 3600.0,
            step_k: -4.0,
        }
    }
}

/// A volumetric thermal test's course: the load, the cycles, what is written.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumetricSpec {
    pub load: VolumetricLoad,
    /// Measuring cycles.
    pub cycles: usize,
    /// How many of the phases between cycles are loaded, from the first on; the machine rests
    /// (cools) in the others.
    pub loaded_phases: usize,
    /// The room's temperature steps (`None`: constant; `T_ambient` is logged either way).
    pub ambient_step: Option<AmbientChange>,
    /// The withheld cycle (1-based), written as validation runs.
    pub validate_cycle: Option<usize>,
    /// At each ball, s (a whole number of 8 ms).
    pub dwell_s: f64,
    /// Each phase between cycles, s (a whole number of log intervals).
    pub load_s: f64,
    /// The log's interval, s.
    pub log_interval_s: f64,
    /// σ of the head's white sensor noise per stream sample, µm.
    pub stream_noise_um: f64,
    /// `None`: no `stream/` (the per-visit session and the truth are the same).
    pub stream: Option<StreamOptions>,
}

impl VolumetricSpec {
    /// Source 000's course: 36 cycles (about 9 h), the first 24 phases between them loaded
    /// (6 h), then 3 h of cooling; 10 min phases, a 2 s dwell, the log every 10 s, the 24th
    /// cycle (the last one under load) withheld, 0.2 µm of sensor noise per sample, the stream
    /// with the end stop at 2000 µm.
    pub fn new(load: VolumetricLoad) -> Self {
        VolumetricSpec {
            load,
            cycles: 36,
            loaded_phases: 24,
            ambient_step: None,
            validate_cycle: Some(24),
            dwell_s: 2.0,
            load_s: 600.0,
            log_interval_s: 10.0,
            stream_noise_um: 0.2,
            stream: Some(StreamOptions::default()),
        }
    }

    /// A short course for tests: `cycles` cycles, every phase between them loaded, the last
    /// cycle withheld (with two or more), otherwise as [`VolumetricSpec::new`].
    pub fn short(load: VolumetricLoad, cycles: usize) -> Self {
        VolumetricSpec {
            cycles,
            loaded_phases: cycles,
            validate_cycle: (cycles >= 2).then_some(cycles),
            ..VolumetricSpec::new(load)
        }
    }
}

/// The machine of a volumetric thermal test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumetricMachine {
    /// `machines/mcu630-cafyxz.urdf`: source 000's MCU 630.
    Trunnion,
    /// `machines/mcv754-zfyx.urdf`.
    ThreeAxis,
}

/// The spindle speed of [`VolumetricLoad::Spindle`]'s load phases, rpm (source 000, Tab. 5).
pub const VOLUMETRIC_SPINDLE_RPM: f64 = 7500.0;
/// The measuring feed, mm/min (source 000, §3.5).
pub const VOLUMETRIC_FEED_MM_PER_MIN: f64 = 2000.0;

/// The room's temperature, °C.
const AIR_C: f64 = 20.0;
/// The structure's time constant after an ambient step, s, and its uniform displacement per K
/// of the room (m/K, machine directions: warmer, the tool rises and moves towards +Y).
const STRUCTURE_TAU_S: f64 = 2400.0;
const AMBIENT_SHIFT_PER_K: [f64; 3] = [0.5e-6, 1.5e-6, 2.5e-6];

/// What differs between the two machines of the test.
struct VolumetricSite {
    file: &'static str,
    balls: Vec<VolumetricBall>,
    points: Vec<VolumetricPoint>,
    /// The head's rise between balls, mm.
    clearance_mm: f64,
    /// The head rotation's line (machine frame, m) and the screws' fixed ends (m).
    pivot_y: f64,
    pivot_z: f64,
    y_reference: f64,
    z_reference: f64,
}

fn ball(name: &str, ball_mm: [f64; 3]) -> VolumetricBall {
    VolumetricBall {
        name: name.into(),
        ball_mm,
    }
}

impl VolumetricSite {
    /// Source 000 §3.5 on the MCU 630: five balls of a ball beam (UMTK-1620, every other ball:
    /// 100 mm apart, the beam inclined on CFRP tubes: 140 → 300 mm above the table) visited at
    /// C = 0, 120 and 240° (A = 0): 15 points, `ball<k>@C<C>`, the beam run forwards at 0 and
    /// 240° and backwards at 120°. The cross-beam's line at mid-Y, 1.1 m above the table; the Y
    /// screw fixed at the −Y end of the stroke, the Z screw at the top.
    fn trunnion() -> Self {
        let balls = vec![
            ball("ball1", [-180.0, -40.0, 140.0]),
            ball("ball2", [-90.0, -20.0, 180.0]),
            ball("ball3", [0.0, 0.0, 220.0]),
            ball("ball4", [90.0, 20.0, 260.0]),
            ball("ball5", [180.0, 40.0, 300.0]),
        ];
        let mut points = Vec::new();
        for c in [0.0, 120.0, 240.0] {
            let order: Vec<usize> = if c == 120.0 {
                (0..5).rev().collect()
            } else {
                (0..5).collect()
            };
            for b in order {
                points.push(VolumetricPoint {
                    name: format!("{}@C{c}", balls[b].name),
                    ball: b,
                    rotary_deg: vec![('A', 0.0), ('C', c)],
                });
            }
        }
        VolumetricSite {
            file: TRUNNION,
            balls,
            points,
            clearance_mm: 150.0,
            pivot_y: 0.0,
            pivot_z: 1.1,
            y_reference: -0.41,
            z_reference: 0.0,
        }
    }

    /// Source 000 §5.5's R-test sets on the MCU 630, repeated between load cycles of the
    /// rotary axes: three balls on the C table (workpiece frame), an XYC set (`ball1`, 150 mm
    /// off C's centre, 160 mm up, at C = 0, 90, 180 and 270°, A = 0; `ball2`, 260 mm up, at C = 0, 120 and
    /// 240°) and a YZA set (`ball3`, 120 mm across, at A = −15, 30, 60 and 90°, C = 0): 11
    /// points, `ball<k>@A<A>C<C>`.
    fn trunnion_rtest_sets() -> Self {
        let balls = vec![
            ball("ball1", [150.0, 0.0, 160.0]),
            ball("ball2", [0.0, -100.0, 260.0]),
            ball("ball3", [0.0, -120.0, 160.0]),
        ];
        let mut points = Vec::new();
        let mut put = |b: usize, a: f64, c: f64| {
            points.push(VolumetricPoint {
                name: format!("{}@A{a}C{c}", balls[b].name),
                ball: b,
                rotary_deg: vec![('A', a), ('C', c)],
            });
        };
        for c in [0.0, 90.0, 180.0, 270.0] {
            put(0, 0.0, c);
        }
        for c in [0.0, 120.0, 240.0] {
            put(1, 0.0, c);
        }
        for a in [-15.0, 30.0, 60.0, 90.0] {
            put(2, a, 0.0);
        }
        VolumetricSite {
            balls,
            points,
            ..Self::trunnion()
        }
    }

    /// Source 000 §3.3's modular frame on a three-axis machine: 15 balls on CFRP tubes in three
    /// levels (six at 120 mm above the table, three at 270, six at 420, offset so that no ball
    /// sits under another), each visited once per cycle. The head nods about the Z guideway's
    /// line on the column (450 mm behind the spindle, 850 mm up); the Y screw fixed at the −Y
    /// end, the Z screw at the top.
    fn three_axis() -> Self {
        let mut balls = Vec::new();
        let mut put = |x: f64, y: f64, z: f64| {
            let k = balls.len() + 1;
            balls.push(ball(&format!("ball{k}"), [x, y, z]));
        };
        for (x, y) in [
            (-250.0, -170.0),
            (0.0, -170.0),
            (250.0, -170.0),
            (250.0, 170.0),
            (0.0, 170.0),
            (-250.0, 170.0),
        ] {
            put(x, y, 120.0);
        }
        for x in [-125.0, 0.0, 125.0] {
            put(x, 0.0, 270.0);
        }
        for (x, y) in [
            (200.0, -90.0),
            (0.0, -90.0),
            (-200.0, -90.0),
            (-200.0, 90.0),
            (0.0, 90.0),
            (200.0, 90.0),
        ] {
            put(x, y, 420.0);
        }
        let points = balls
            .iter()
            .enumerate()
            .map(|(b, ball)| VolumetricPoint {
                name: ball.name.clone(),
                ball: b,
                rotary_deg: Vec::new(),
            })
            .collect();
        VolumetricSite {
            file: THREE_AXIS,
            balls,
            points,
            clearance_mm: 130.0,
            pivot_y: 0.45,
            pivot_z: 0.85,
            y_reference: -0.27,
            z_reference: 0.0,
        }
    }
}

impl Campaign {
    /// The machine, plan and effects of a volumetric thermal test ([`crate::volumetric`]) on
    /// `which` as `spec` runs it, the head's path rounded as `realism`'s controller writes it.
    /// The head passes 150 mm (trunnion) or 130 mm (three-axis) above the balls and turns the
    /// table at that height above the highest ball. The effects, by the load's phases
    /// ([`Schedule::between_s`], the first `spec.loaded_phases` of them loaded):
    /// - always the air: `T_ambient` (20 °C); with [`VolumetricSpec::ambient_step`] an
    ///   [`Effect::AmbientStep`] (the structure's node 2400 s, 0.5 / 1.5 / 2.5 µm per K along
    ///   X / Y / Z, uniform), and every other sensor follows the step with its lag
    ///   ([`HeatSource::after_step`]);
    /// - [`VolumetricLoad::Spindle`]: `S` = [`VOLUMETRIC_SPINDLE_RPM`] in the loaded phases, 0
    ///   otherwise; the head's growth towards the table ([`Effect::Thermal`] along −Z: 8 µm
    ///   per 1000 rpm with τ = 40 min and 6 µm per 1000 rpm with τ = 2.5 h); `T_spindle`
    ///   (20.8 °C + 1.5 K per 1000 rpm, τ = 30 min, ambient lag 20 min) logged only; the Z
    ///   screw 2 ppm/K about Z = 0 with `T_znut` (20.5 °C + 0.7 K per 1000 rpm, τ = 1.5 h,
    ///   ambient lag 1 h);
    /// - [`VolumetricLoad::YDrive`]: `T_ydrive` = 20.6 °C + 15 K × a node of the load (τ =
    ///   1.5 h; about 10 K at the cycles' duty), ambient lag 1 h; the Y scale 1.5 ppm/K about
    ///   the −Y end of the stroke ([`Effect::ThermalScale`], which writes `T_ydrive`) and the
    ///   head turning 3 µrad/K about the machine's line ([`Effect::HeadRotationX`], the same
    ///   temperature): the trunnion's cross-beam at mid-Y 1.1 m above the table, the
    ///   three-axis machine's Z guideway on the column (y = 450 mm, z = 850 mm).
    pub fn volumetric_plan(
        which: VolumetricMachine,
        spec: &VolumetricSpec,
        realism: &Realism,
    ) -> Result<(Machine, VolumetricPlan, Vec<Effect>), SimError> {
        let site = match (which, spec.load) {
            (VolumetricMachine::Trunnion, VolumetricLoad::RotaryDrives) => {
                VolumetricSite::trunnion_rtest_sets()
            }
            (VolumetricMachine::ThreeAxis, VolumetricLoad::RotaryDrives) => {
                return Err(SimError::Plan(
                    "a rotary drives' load needs the trunnion's rotary axes".into(),
                ));
            }
            (VolumetricMachine::Trunnion, _) => VolumetricSite::trunnion(),
            (VolumetricMachine::ThreeAxis, _) => VolumetricSite::three_axis(),
        };
        let urdf = shipped_machine(site.file);
        let machine = Machine::from_urdf_file(&urdf)?;
        // The tool point's height above the workpiece frame with every axis at zero.
        let zero = vec![0.0; machine.n_axes()];
        let z0_mm = translation_of(&machine.tool_in_workpiece(&zero, None)).z * 1e3;
        let top_mm = site
            .balls
            .iter()
            .map(|b| b.ball_mm[2])
            .fold(f64::NEG_INFINITY, f64::max);
        let plan = VolumetricPlan {
            machine_urdf: urdf,
            balls: site.balls.clone(),
            points: site.points.clone(),
            cycles: spec.cycles,
            validate_cycle: spec.validate_cycle,
            feed_mm_per_min: VOLUMETRIC_FEED_MM_PER_MIN,
            dwell_s: spec.dwell_s,
            clearance_mm: site.clearance_mm,
            safe_z_mm: top_mm + site.clearance_mm - z0_mm,
            load_s: spec.load_s,
            log_interval_s: spec.log_interval_s,
            stream_noise_um: spec.stream_noise_um,
            stream: spec.stream.clone(),
        };
        let schedule = plan.schedule(&machine, realism)?;
        let effects = volumetric_effects(spec, &site, &schedule);
        Ok((machine, plan, effects))
    }

    /// A volumetric thermal test on the shipped trunnion `machines/mcu630-cafyxz.urdf` (source
    /// 000's MCU 630) with the geometric errors `truth`, into `dir`
    /// ([`Campaign::volumetric_plan`] gives its plan and effects, [`crate::volumetric`] the
    /// files): five balls of an artefact, one set-up each (`ball1`…`ball5`), visited at
    /// C = 0, 120 and 240°: 15 points per cycle (about 4.3 min at 2000 mm/min).
    pub fn volumetric_trunnion(
        dir: &Path,
        truth: &Truth,
        spec: &VolumetricSpec,
        realism: &Realism,
    ) -> Result<VolumetricWritten, SimError> {
        let (machine, plan, effects) =
            Self::volumetric_plan(VolumetricMachine::Trunnion, spec, realism)?;
        write_volumetric(dir, &machine, truth, &plan, &effects, realism)
    }

    /// A volumetric thermal test on the shipped three-axis `machines/mcv754-zfyx.urdf` with the
    /// geometric errors `truth`, into `dir` ([`Campaign::volumetric_plan`]): 15 balls on a
    /// frame, one set-up each (`ball1`…`ball15`), each visited once per cycle.
    pub fn volumetric_three_axis(
        dir: &Path,
        truth: &Truth,
        spec: &VolumetricSpec,
        realism: &Realism,
    ) -> Result<VolumetricWritten, SimError> {
        let (machine, plan, effects) =
            Self::volumetric_plan(VolumetricMachine::ThreeAxis, spec, realism)?;
        write_volumetric(dir, &machine, truth, &plan, &effects, realism)
    }
}

/// [`Campaign::volumetric_plan`]'s effects.
fn volumetric_effects(
    spec: &VolumetricSpec,
    site: &VolumetricSite,
    schedule: &Schedule,
) -> Vec<Effect> {
    let loaded: Vec<(f64, f64)> = schedule
        .between_s
        .iter()
        .take(spec.loaded_phases)
        .copied()
        .collect();
    // `level` in the loaded phases, 0 otherwise.
    let on_off = |level: f64| {
        Programme::Steps(
            loaded
                .iter()
                .flat_map(|&(from, to)| [(from, level), (to, 0.0)])
                .collect(),
        )
    };
    // A sensor's temperature: its own rises, and the room's step after its lag.
    let temperature = |ambient_c: f64, mut rises: Vec<HeatSource>, lag_s: f64| {
        rises.extend(
            spec.ambient_step
                .map(|a| HeatSource::after_step(a.at_s, a.step_k, lag_s)),
        );
        TemperatureProgramme {
            ambient_c,
            drift_k_per_h: 0.0,
            rises,
        }
    };
    let node = |gain: f64, tau_s: f64, power: Programme| HeatSource { gain, tau_s, power };
    let mut effects = vec![match spec.ambient_step {
        Some(a) => Effect::AmbientStep {
            ambient_c: AIR_C,
            at_s: a.at_s,
            step_k: a.step_k,
            tau_s: STRUCTURE_TAU_S,
            shift_per_k: AMBIENT_SHIFT_PER_K,
            column: Some("T_ambient".into()),
        },
        None => Effect::TemperatureSensor {
            column: "T_ambient".into(),
            temperature: TemperatureProgramme::constant(AIR_C),
        },
    }];
    match spec.load {
        VolumetricLoad::Spindle => {
            let krpm = || Programme::SpindleKrpm;
            effects.extend([
                Effect::SpindleSpeed {
                    rpm: on_off(VOLUMETRIC_SPINDLE_RPM),
                },
                Effect::Thermal {
                    direction: [0.0, 0.0, -1.0],
                    sources: vec![node(8e-6, 2400.0, krpm()), node(6e-6, 9000.0, krpm())],
                },
                Effect::TemperatureSensor {
                    column: "T_spindle".into(),
                    temperature: temperature(20.8, vec![node(1.5, 1800.0, krpm())], 1200.0),
                },
                Effect::ThermalScale {
                    axis: 'Z',
                    ppm_per_k: 2.0,
                    reference: site.z_reference,
                    temperature: temperature(20.5, vec![node(0.7, 5400.0, krpm())], 3600.0),
                    column: "T_znut".into(),
                },
            ]);
        }
        VolumetricLoad::RotaryDrives => {
            // The loaded phases take the A and the C drive in turn.
            let turns = |first: usize| {
                Programme::Steps(
                    loaded
                        .iter()
                        .skip(first)
                        .step_by(2)
                        .flat_map(|&(from, to)| [(from, 1.0), (to, 0.0)])
                        .collect(),
                )
            };
            effects.extend([
                Effect::AxisLineDrift {
                    parameter: "EY0A".into(),
                    per_k: 0.8e-6,
                    temperature: temperature(20.6, vec![node(16.0, 3600.0, turns(0))], 3600.0),
                    column: Some("T_adrive".into()),
                },
                Effect::AxisLineDrift {
                    parameter: "EX0C".into(),
                    per_k: 0.5e-6,
                    temperature: temperature(20.4, vec![node(12.0, 2700.0, turns(1))], 3600.0),
                    column: Some("T_cdrive".into()),
                },
            ]);
        }
        VolumetricLoad::YDrive => {
            let drive = temperature(20.6, vec![node(15.0, 5400.0, on_off(1.0))], 3600.0);
            effects.extend([
                Effect::ThermalScale {
                    axis: 'Y',
                    ppm_per_k: 1.5,
                    reference: site.y_reference,
                    temperature: drive.clone(),
                    column: "T_ydrive".into(),
                },
                Effect::HeadRotationX {
                    pivot_y: site.pivot_y,
                    pivot_z: site.pivot_z,
                    urad_per_k: 3.0,
                    temperature: drive,
                    column: None,
                },
            ]);
        }
    }
    effects
}
