//! Effects a geometric error model leaves out, planted by their physics: lost motion (uniform,
//! or varying along a worn screw with an unknown start), a servo lag, reversal spikes and
//! stick-slip, thermal growth of the spindle head and of the spindle along its axis, screw
//! pitch errors, scale expansion, table twist, sag, a carriage rocking in its guideway
//! clearance, a dent in a guideway, the spindle head turning as a cross-beam twists with a
//! drive's temperature, a step of the room temperature, the ball bar's own expansion and a
//! set-up settling; and temperature sensors that only log.
//!
//! Formulated here from the physics of each effect, not from mtcal's effect formulas. Every
//! value is SI inside (m, rad, s, K); a field whose unit is not SI says so in its name.
//!
//! # How effects enter the chain
//! Effects act along the session's timeline: the runs in the order of the plan (which is their
//! time order), each sample at the time its `t` column says, state carried from one run into the
//! next (the lost motion of the last sample of a run is where the next run starts from).
//! Validation runs get the same physics as fitted runs. At each sample:
//! 1. **axis effects** ([`Effect::Backlash`], [`Effect::LostMotion`], [`Effect::ServoLag`],
//!    [`Effect::ReversalSpike`], [`Effect::StickSlip`], [`Effect::ScrewError`],
//!    [`Effect::ThermalScale`]) move an axis' *actual* position `a` away from its command `c`;
//!    several on one axis add, each evaluated at the command (`a = c + Σ δ_i(c)`; the error of an
//!    error is left out). The written axis columns stay the commands. The ones that follow the
//!    direction of motion (lost motion, lateral play, reversal spike, stick-slip) read it from
//!    the commanded sequence, the move from one run's last command to the next run's first
//!    included; moves under 1 nm (1 nrad) are no motion;
//! 2. the machine's branches are evaluated at the actual positions with the truth's geometric
//!    errors ([`Machine::branch_pose`]): `f_T_w(a)`, `f_T_t(a)` in the machine frame `f`;
//! 3. **tool effects** ([`Effect::Thermal`], [`Effect::Twist`], [`Effect::Sag`],
//!    [`Effect::LateralPlay`], [`Effect::GuidewayBump`], [`Effect::AmbientStep`]) are a
//!    translation `d` of the tool point relative to the workpiece in machine directions,
//!    pre-multiplied on the tool branch's pose: `w_T_t = f_T_w(a)⁻¹ · Trans(d) · f_T_t(a)`.
//!    (A workpiece-side deformation such as the twist is the same relative motion: the
//!    workpiece moving by −d is the tool moving by +d.) [`Effect::HeadRotationX`] turns the
//!    tool branch about a fixed line, `H(θ) = Trans(c)·Rot_x(θ)·Trans(−c)`, pre-multiplied
//!    after the translation (the head, grown, turns as a whole). [`Effect::SpindleGrowth`] is a
//!    translation `(0, 0, −g)` in the tool frame, post-multiplied. Together:
//!    `w_T_t = f_T_w(a)⁻¹ · H(θ) · Trans(d) · f_T_t(a) · Trans(0, 0, −g)` (several head
//!    rotations multiply in plan order, `H = H_1·H_2·…`).
//!
//! Every instrument reads that actual pose, so the effects reach the R-test (both mounts), the
//! ball bar, every laser mode, the tracer, displacement sensors and artefact plates alike. The
//! exceptions are the instrument's own: [`Effect::BallBarThermal`], the bar's expansion, and
//! [`Effect::SetupCreep`], a set-up's fixed element settling, which only the readings of their
//! set-up see. Laser and tracer readings stay zeroed at the run's first sample,
//! so they see an effect's change within the run.
//!
//! # Context columns
//! [`Effect::ThermalScale`] and [`Effect::TemperatureSensor`] write their temperature as a
//! column `T_<name>` (°C) in every run, [`Effect::HeadRotationX`] and [`Effect::AmbientStep`]
//! when given a column; [`Effect::BallBarThermal`] may write the bar's temperature in its
//! set-up's runs;
//! [`Effect::SpindleSpeed`] writes `S` (rpm) in every run, exactly the programme's value at the
//! sample time. Temperatures are what a sensor reads: the true value plus [`crate::Realism`]'s
//! `temperature_sigma_k` of white noise (its own random stream of the realism seed), quantised
//! to `temperature_resolution_k`. The physics uses the true temperature. The columns follow
//! the reading (and label) columns, in the order of the plan's effects.

use std::fmt::Write as _;

use nalgebra::{Matrix4, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::SimError;
use crate::instruments::{ActualPoses, Instrument, SetupPlan};
use crate::machine::{
    ActualErrors, JointKind, Machine, Side, exp_rotation, rigid, rigid_inverse, translation,
};
use crate::truth::Truth;

/// A piecewise-constant function of the session time.
#[derive(Clone, Debug, PartialEq)]
pub enum Programme {
    /// `(from_s, value)` pairs, `from_s` strictly increasing: the value holds from `from_s`
    /// until the next step; before the first step the value is 0.
    Steps(Vec<(f64, f64)>),
    /// The session's spindle speed ([`Effect::SpindleSpeed`]) in thousands of rpm: the power a
    /// spindle's bearings and motor turn into heat, taken as proportional to the speed (viscous
    /// bearing friction grows somewhat faster; the proportional law keeps the driver plain).
    SpindleKrpm,
}

impl Programme {
    /// Steps from a slice (see [`Programme::Steps`]).
    pub fn steps(steps: &[(f64, f64)]) -> Self {
        Programme::Steps(steps.to_vec())
    }

    /// `value` from the start of the session on.
    pub fn constant(value: f64) -> Self {
        Programme::Steps(vec![(0.0, value)])
    }
}

/// A first-order thermal node: `τ dx/dt = p(t) − x`, `x(0) = 0` (the machine starts cold, in
/// equilibrium with its surroundings), `p` the programme. At steady state `x = p`; the node
/// adds `gain · x(t)` to what it drives. Integrated exactly: between breakpoints of `p`,
/// `x(t) = p + (x(t₀) − p)·e^{−(t − t₀)/τ}`.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatSource {
    /// What one unit of node state adds at steady state: m ([`Effect::Thermal`]) or K (a
    /// [`TemperatureProgramme`]'s rise).
    pub gain: f64,
    /// Time constant, s.
    pub tau_s: f64,
    pub power: Programme,
}

impl HeatSource {
    /// The node a step drives: `power` 0 before `at_s` and 1 from then on, so that the node's
    /// contribution rises as `gain·(1 − e^{−(t − at_s)/τ})` after it. A sensor (or a drive's
    /// temperature) that follows a step of the room by `gain` K with its lag `tau_s`
    /// ([`Effect::AmbientStep`]).
    pub fn after_step(at_s: f64, gain: f64, tau_s: f64) -> Self {
        HeatSource {
            gain,
            tau_s,
            power: Programme::steps(&[(at_s, 1.0)]),
        }
    }
}

/// A temperature over the session: `T(t) = ambient_c + drift_k_per_h·t/3600 + Σ gain_i·x_i(t)`,
/// each rise a first-order node ([`HeatSource`], gains in K). Only `T(t) − T(0)` acts.
#[derive(Clone, Debug, PartialEq)]
pub struct TemperatureProgramme {
    /// °C at the start of the session.
    pub ambient_c: f64,
    /// Steady drift of the surroundings, K per hour.
    pub drift_k_per_h: f64,
    pub rises: Vec<HeatSource>,
}

impl TemperatureProgramme {
    /// A constant temperature.
    pub fn constant(ambient_c: f64) -> Self {
        TemperatureProgramme {
            ambient_c,
            drift_k_per_h: 0.0,
            rises: Vec::new(),
        }
    }
}

/// A physical effect planted in a session (see the module docs for how each enters the chain).
#[derive(Clone, Debug, PartialEq)]
pub enum Effect {
    /// Play with lost motion `B` (`lost_motion`, m on a linear axis, rad on a rotary one)
    /// between the drive and the carriage: the actual position `a` follows the command `c` only
    /// once the command has taken up the play. Along the session's commanded sequence: if
    /// `c − a > B/2` then `a = c − B/2`; if `c − a < −B/2` then `a = c + B/2`; otherwise `a`
    /// stays. The axis was brought to its first commanded position from below (`a = c − B/2`).
    /// Moving up, the axis lags B/2 behind; after a reversal it stands still until the command
    /// has travelled B, then lags B/2 the other way.
    Backlash { axis: char, lost_motion: f64 },
    /// The spindle head grows: the tool point moves relative to the machine frame by
    /// `Σ_i gain_i·x_i(t)` along the unit `direction` (machine frame, normalised when used), each
    /// source a first-order node ([`HeatSource`], gains in m). A vertical spindle whose shaft
    /// elongates towards the table with positive gains: `direction = [0, 0, −1]`; a column
    /// lifting the head: `[0, 0, 1]`.
    Thermal {
        direction: [f64; 3],
        sources: Vec<HeatSource>,
    },
    /// The screw's lead varies periodically: the actual position is
    /// `c + Σ a_k·sin(2π·k·c/pitch + φ_k)`, `harmonics` the `(k, a_k, φ_k)` (order ≥ 1, amplitude
    /// m or rad, phase rad), `pitch` m (rad on a rotary axis: a worm's period). A positive
    /// amplitude at a positive sine puts the axis beyond its command.
    ScrewError {
        axis: char,
        pitch: f64,
        harmonics: Vec<(u32, f64, f64)>,
    },
    /// The scale (or screw) of a linear axis expands with its temperature: the actual position
    /// is `c + α·(T(t) − T(0))·(c − reference)`, `α = ppm_per_k·10⁻⁶`, `reference` (m) where
    /// the scale is fixed (no error there). Warmer and α > 0: the axis ends up further from the
    /// reference than commanded. `T` is written as the context column `column` (`T_<name>`,
    /// °C) in every run. (A rotary axis is refused: a uniform expansion keeps angles.)
    ThermalScale {
        axis: char,
        ppm_per_k: f64,
        reference: f64,
        temperature: TemperatureProgramme,
        column: String,
    },
    /// The table (or fixture) twists: the tool point relative to the workpiece is displaced
    /// along machine +Z by `k·x·y`, `k = per_m2` (m per m²), `x`, `y` the actual positions of
    /// the linear axes X and Y (m). A pure translation of the tool point, not an error of an
    /// axis. The machine needs linear X and Y axes.
    Twist { per_m2: f64 },
    /// A member sags as `axis` (linear) moves out: the tool point relative to the workpiece is
    /// displaced along machine `direction` (`X`, `Y` or `Z`) by `k·q²`, `k = per_m2` (m per m²),
    /// `q` the actual position of `axis` from its zero (m). A ram sagging downwards as it
    /// extends: `direction = 'Z'`, `per_m2 < 0`.
    Sag {
        axis: char,
        direction: char,
        per_m2: f64,
    },
    /// The ball bar's own length grows with its temperature, and its transducer's reference
    /// with it: the `dr` reading (bar length minus nominal) drops by
    /// `α·(T(t) − T(0))·L_nominal`, `α = ppm_per_k·10⁻⁶`, `L_nominal` the set-up's stated length,
    /// in the runs of set-up `setup` (a ball bar). With `column`, the bar's temperature is
    /// written there (`T_<name>`, °C) in that set-up's runs.
    BallBarThermal {
        setup: String,
        ppm_per_k: f64,
        temperature: TemperatureProgramme,
        column: Option<String>,
    },
    /// The axis' position loop trails its command by `lag_s` (s): the actual position is the
    /// command as it was `lag_s` earlier, `a(t) = c(t − T)`, interpolated linearly between the
    /// run's commands (before a run's first sample the axis stood at its first command). A
    /// following error `T·v` along the motion; one axis lagging more than another (a gain
    /// mismatch) draws the ball bar's ellipse at 45° that turns with the direction.
    ServoLag { axis: char, lag_s: f64 },
    /// The set-up's fixed element — the R-test's ball (or nest) on the table, the ball bar's
    /// table pivot — settles after it is mounted, as a magnetic base or a clamp does: it moves
    /// in the workpiece frame by `settle·(1 − e^{−(t − t_s)/τ})`, `t_s` the time of the set-up's
    /// first sample in the session (when it was mounted), `settle` m, `tau_s` s. Only that
    /// set-up's readings see it. An R-test or a ball bar (the laser and the tracer re-zero every
    /// run, the others are refused).
    SetupCreep {
        setup: String,
        settle: [f64; 3],
        tau_s: f64,
    },
    /// The spindle turns at `rpm` (a [`Programme::Steps`] of rpm); written as the context column
    /// `S` in every run. Moves nothing by itself: heat sources with
    /// [`Programme::SpindleKrpm`] follow it.
    SpindleSpeed { rpm: Programme },
    /// A worn screw and nut: lost motion like [`Effect::Backlash`] whose width varies along the
    /// stroke, `B(c) = lost_motion_low + (lost_motion_high − lost_motion_low)·f`,
    /// `f = (c − lo)/(hi − lo)` clamped to `[0, 1]`, `lo..hi` the axis' limits (one turn
    /// −180°..180° on a continuous axis; beyond it the width holds its end value), both
    /// widths m on a linear axis, rad on a rotary one. The dead band is Backlash's at the
    /// width of the command: moving up the axis lags `B(c)/2` behind, after a reversal it
    /// stands still until the command has taken up the play. Where the nut stands in its play
    /// when a run starts is `approach`'s ([`Approach`]): carried along the commanded sequence,
    /// or a side drawn at random before every run (an approach move the file does not
    /// record).
    LostMotion {
        axis: char,
        lost_motion_low: f64,
        lost_motion_high: f64,
        approach: Approach,
    },
    /// The carriage of `axis` (linear or rotary) rocks across its guideway clearance: the
    /// friction at the guideway's flanks pushes it against one flank moving up, the other
    /// moving down. The tool point relative to the workpiece is displaced by `p·u`, `u` the
    /// unit vector of `across` (machine directions, normalised when used), `p` between
    /// `+play/2` (moving +) and `−play/2` (moving −), `play` m. After a reversal the carriage
    /// crosses the clearance while the command travels `take_up` (m or rad): from where it
    /// was at the reversal, `p₀`, to the new flank `s·play/2` (`s` the new direction) as
    /// `p = p₀ + (s·play/2 − p₀)·(1 − cos(π·d/take_up))/2` for `d < take_up`, `d` the
    /// commanded travel since the reversal, and on the flank after (`take_up = 0`: a step).
    /// The axis was brought to its first commanded position from below (on the + flank).
    LateralPlay {
        axis: char,
        across: [f64; 3],
        play: f64,
        take_up: f64,
    },
    /// At a reversal of `axis` the friction force flips sign and the position loop's
    /// integrator needs time to build up the new force: the axis trails its command by
    /// `−s·height·(1 + Δt/T)·e^{−Δt/T}` (a critically damped recovery), `s` the new direction
    /// of motion (±1), `Δt` the time since the reversal, `T = recovery_s` (s), `height` m (rad
    /// on a rotary axis). Time-based: the spike decays while the axis moves or stands. A
    /// reversal is where the commanded direction changes sign along the session's commanded
    /// sequence (moves smaller than 1 nm or 1 nrad ignored); its time is that of the last sample
    /// at the turning point.
    ReversalSpike {
        axis: char,
        height: f64,
        recovery_s: f64,
    },
    /// Stick-slip after a reversal of `axis`: the carriage stands (sticks) while the drive
    /// winds up elastically, until the wind-up reaches what static friction holds beyond
    /// kinetic friction, `height` = (F_s − F_k)/k (m or rad; the wind-up of kinetic friction
    /// itself is a constant lost motion, [`Effect::Backlash`]'s); it then breaks away and the
    /// excess wind-up is released over a slip travel `λ = slip_travel` as the loop damps the
    /// carriage's jump critically. With `d` the commanded travel since the reversal and `s`
    /// the new direction, the actual position is the command plus
    /// `−s·d` while `d < height` (standing at the turning point), then
    /// `−s·height·(1 + u)·e^{−u}`, `u = (d − height)/λ` (continuous, with a flat start).
    /// Travel-based: standing still changes nothing. Reversals as for
    /// [`Effect::ReversalSpike`]; before the session's first reversal nothing.
    StickSlip {
        axis: char,
        height: f64,
        slip_travel: f64,
    },
    /// A local dent or worn patch of the guideway of the linear `axis`: the tool point
    /// relative to the workpiece is displaced along the unit `direction` (machine directions,
    /// normalised when used) by the raised cosine
    /// `height·(1 + cos(2π·(q − centre)/width))/2` for `|q − centre| < width/2`, zero
    /// elsewhere, `q` the axis' actual position (m); `centre`, `width`, `height` m. A
    /// translation of the tool point, like [`Effect::Twist`].
    GuidewayBump {
        axis: char,
        direction: [f64; 3],
        centre: f64,
        width: f64,
        height: f64,
    },
    /// The spindle grows along its own axis as it warms: the tool point moves out of the
    /// spindle by `g(t) = Σ_i gain_i·x_i(t)` (nodes as [`Effect::Thermal`]'s, gains in m),
    /// i.e. along −z of the tool frame (the tool link's +z points from the tool point into the
    /// spindle). A translation in the tool frame, post-multiplied on the tool branch
    /// (`… · f_T_t(a) · Trans(0, 0, −g)`): on a head whose rotary axes tilt the tool the growth
    /// turns with it.
    SpindleGrowth { sources: Vec<HeatSource> },
    /// The spindle head turns about a line parallel to machine X, as a cross-beam (or a
    /// column) twists when a drive on one side of it warms: by
    /// `θ(t) = urad_per_k·10⁻⁶·(T(t) − T(0))` (rad, right-handed about +X), `T` the drive's
    /// temperature, about the line through `(·, pivot_y, pivot_z)` (m, machine frame; the line
    /// stays where it is whatever the axes do). The tool branch turns about it as a whole,
    /// pre-multiplied (module docs): `H(θ) = Trans(c)·Rot_x(θ)·Trans(−c)`,
    /// `c = (0, pivot_y, pivot_z)`. The tool point at machine `p` moves by
    /// `(Rot_x(θ) − I)·(p − c)`, to first order `Δy = −θ·(p_z − pivot_z)`,
    /// `Δz = θ·(p_y − pivot_y)`: the lever arm, and with it the displacement, differs between
    /// points of the work volume (with the pivot above them and θ > 0, points lower down move
    /// further towards +Y), and the tool (an R-test nest on it) tilts by θ. Warmer with
    /// `urad_per_k > 0`: θ > 0. `T` is written as `column` (`T_<name>`, °C) in every run when
    /// given; leave it `None` when another effect writes the same drive's temperature (the
    /// drive's [`Effect::ThermalScale`]) and give both the same programme.
    HeadRotationX {
        pivot_y: f64,
        pivot_z: f64,
        urad_per_k: f64,
        temperature: TemperatureProgramme,
        column: Option<String>,
    },
    /// The room's temperature steps by `step_k` (K) at `at_s` (s) from `ambient_c` (°C) — an
    /// air-conditioning failure. The structure follows through one first-order node of time
    /// constant `tau_s`: the tool point relative to the workpiece moves uniformly (the same at
    /// every point of the work volume, a translation like [`Effect::Thermal`]'s) by
    /// `shift_per_k·step_k·x(t)`, `x(t) = 1 − e^{−(t − at_s)/τ}` from `at_s` on (0 before),
    /// `shift_per_k` m per K in machine directions (the room cooling by 4 K with
    /// `shift_per_k = [0, 0, 2e-6]`: the tool ends 8 µm lower relative to the workpiece). With
    /// `column`, an air sensor (`T_<name>`, °C) reads `ambient_c` before `at_s` and
    /// `ambient_c + step_k` from then on, in every run. Other sensors follow the step with
    /// lags of their own: add [`HeatSource::after_step`] to their programmes.
    AmbientStep {
        ambient_c: f64,
        at_s: f64,
        step_k: f64,
        tau_s: f64,
        shift_per_k: [f64; 3],
        column: Option<String>,
    },
    /// A rotary axis' line moves as its bearing housings warm unevenly (an A cradle's drive
    /// heating one side, a C table's motor under its top): its location error `parameter`
    /// (`EY0A`, `EB0C`: a position or a tilt of the line across its own direction, in the
    /// truth's own convention, [`Truth::set`]) becomes its value plus
    /// `per_k·(T(t) − T(0))` (m or rad per K). What that error means: the parts the axis
    /// carries turn about the moved line, and where they stand at the axis' zero does not
    /// change. `T` is written as `column` (`T_<name>`, °C) in every run when given.
    AxisLineDrift {
        parameter: String,
        per_k: f64,
        temperature: TemperatureProgramme,
        column: Option<String>,
    },
    /// A temperature sensor that only logs (a spindle housing, a ball-screw nut): its
    /// `temperature` written as `column` (`T_<name>`, °C) in every run, as a sensor reads it.
    /// Moves nothing: the context a thermal test records besides the temperatures that drive
    /// planted effects.
    TemperatureSensor {
        column: String,
        temperature: TemperatureProgramme,
    },
}

/// Where the nut of an axis with [`Effect::LostMotion`] stands in its play when a run starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Approach {
    /// As [`Effect::Backlash`]: the state carried along the session's commanded sequence (the
    /// move from one run's last command to the next run's first counts), the first command
    /// approached from below.
    Carried,
    /// Before every run the axis approaches the run's first command from below or from above,
    /// drawn at random per run (one fair draw per run in plan order, from a ChaCha8 stream
    /// seeded with `seed`): from below the axis stands `B/2` short of the command, from above
    /// `B/2` beyond it. The approach move is not recorded.
    RandomPerRun { seed: u64 },
}

/// `x(t)` of `τ dx/dt = p(t) − x`, `x(0) = 0`, `p` piecewise constant (`steps`, see
/// [`Programme::Steps`]): the exact exponential between the breakpoints up to `t`. 0 for
/// `t ≤ 0`.
pub fn first_order_response(steps: &[(f64, f64)], tau_s: f64, t: f64) -> f64 {
    if t <= 0.0 {
        return 0.0;
    }
    // x relaxes towards p: x + (p − x)(1 − e^{−Δt/τ}), with expm1 keeping the digits of short
    // intervals.
    let relax = |x: f64, p: f64, dt: f64| x - (p - x) * (-dt / tau_s).exp_m1();
    let (mut x, mut from, mut p) = (0.0, 0.0, value_at(steps, 0.0));
    for &(at, value) in steps.iter().filter(|s| s.0 > 0.0) {
        if at >= t {
            break;
        }
        x = relax(x, p, at - from);
        (from, p) = (at, value);
    }
    relax(x, p, t - from)
}

/// The value of a piecewise-constant programme at `t` (0 before its first step).
fn value_at(steps: &[(f64, f64)], t: f64) -> f64 {
    steps
        .iter()
        .take_while(|s| s.0 <= t)
        .last()
        .map_or(0.0, |s| s.1)
}

/// A heat source with its programme resolved to steps.
#[derive(Clone, Debug)]
struct Node {
    gain: f64,
    tau_s: f64,
    steps: Vec<(f64, f64)>,
}

impl Node {
    fn at(&self, t: f64) -> f64 {
        self.gain * first_order_response(&self.steps, self.tau_s, t)
    }
}

/// A temperature programme, resolved.
#[derive(Clone, Debug)]
struct Temperature {
    ambient_c: f64,
    drift_k_per_s: f64,
    nodes: Vec<Node>,
}

impl Temperature {
    /// `T(t) − T(0)`, K.
    fn rise(&self, t: f64) -> f64 {
        self.drift_k_per_s * t + self.nodes.iter().map(|n| n.at(t)).sum::<f64>()
    }

    fn celsius(&self, t: f64) -> f64 {
        self.ambient_c + self.rise(t)
    }
}

#[derive(Clone, Debug)]
struct Scale {
    axis: usize,
    alpha_per_k: f64,
    reference: f64,
    temperature: Temperature,
}

#[derive(Clone, Debug)]
struct Screw {
    axis: usize,
    pitch: f64,
    harmonics: Vec<(u32, f64, f64)>,
}

impl Screw {
    fn error(&self, c: f64) -> f64 {
        let turns = std::f64::consts::TAU * c / self.pitch;
        self.harmonics
            .iter()
            .map(|&(k, a, phase)| a * (f64::from(k) * turns + phase).sin())
            .sum()
    }
}

#[derive(Clone, Debug)]
struct Bar {
    setup: String,
    /// `α·L_nominal`, m per K.
    m_per_k: f64,
    temperature: Temperature,
}

/// What a context column shows.
#[derive(Clone, Debug)]
enum Shows {
    /// The spindle speed, rpm, exactly.
    Spindle,
    /// A scale's temperature (index into `scales`), °C, as a sensor reads it.
    ScaleTemperature(usize),
    /// A bar's temperature (index into `bars`), °C, as a sensor reads it.
    BarTemperature(usize),
    /// A head rotation's drive temperature (index into `rotations`), °C, as a sensor reads it.
    RotationTemperature(usize),
    /// The air's temperature of an ambient step (index into `ambient`), °C, as a sensor reads
    /// it.
    Air(usize),
    /// A logging sensor's temperature (index into `sensors`), °C, as a sensor reads it.
    Sensor(usize),
    /// An axis line's temperature (index into `lines`), °C, as a sensor reads it.
    LineTemperature(usize),
}

#[derive(Clone, Debug)]
struct Column {
    name: String,
    shows: Shows,
    /// Only in the runs of this set-up (`None`: every run).
    setup: Option<String>,
}

/// A plan's effects checked against its machine and set-ups, in the form the timeline uses.
#[derive(Clone, Debug, Default)]
pub(crate) struct Resolved {
    backlash: Vec<(usize, f64)>,
    screws: Vec<Screw>,
    scales: Vec<Scale>,
    /// Unit direction and nodes (gains in m) of each thermal growth.
    growth: Vec<(Vector3<f64>, Vec<Node>)>,
    /// `(X index, Y index, k)`.
    twist: Vec<(usize, usize, f64)>,
    /// `(axis index, machine direction 0..3, k)`.
    sag: Vec<(usize, usize, f64)>,
    bars: Vec<Bar>,
    creeps: Vec<Creep>,
    /// `(axis index, lag s)`.
    lags: Vec<(usize, f64)>,
    spindle_rpm: Option<Vec<(f64, f64)>>,
    columns: Vec<Column>,
    worn: Vec<Worn>,
    lateral: Vec<Lateral>,
    /// `(axis index, height, recovery s)`.
    spikes: Vec<(usize, f64, f64)>,
    /// `(axis index, height, slip travel)`.
    sticks: Vec<(usize, f64, f64)>,
    bumps: Vec<Bump>,
    /// Nodes (gains in m) of each spindle growth along the tool axis.
    spindle_growth: Vec<Vec<Node>>,
    rotations: Vec<Rotation>,
    ambient: Vec<Ambient>,
    /// The logging sensors' temperatures ([`Effect::TemperatureSensor`]).
    sensors: Vec<Temperature>,
    lines: Vec<LineDrift>,
}

/// A rotary axis' line moving with a temperature ([`Effect::AxisLineDrift`]).
#[derive(Clone, Debug)]
struct LineDrift {
    /// The axis (joint index) and the location error's direction (0..6: δx δy δz εx εy εz).
    axis: usize,
    direction: usize,
    /// m or rad per K.
    per_k: f64,
    temperature: Temperature,
}

/// The truth with the axis lines moved: `(axis, direction, change)` added to its location
/// errors.
struct MovedLines<'a> {
    truth: &'a Truth,
    changes: &'a [(usize, usize, f64)],
}

impl ActualErrors for MovedLines<'_> {
    fn axis_errors(&self, machine: &Machine, i: usize, q: f64) -> ([f64; 6], [f64; 6]) {
        let (comp, mut loc) = self.truth.axis_errors(machine, i, q);
        for &(axis, d, v) in self.changes {
            if axis == i {
                loc[d] += v;
            }
        }
        (comp, loc)
    }
    fn workpiece(&self) -> [f64; 6] {
        self.truth.workpiece
    }
    fn tool(&self) -> [f64; 3] {
        self.truth.tool
    }
}

/// The head turning about a line parallel to X ([`Effect::HeadRotationX`]).
#[derive(Clone, Debug)]
struct Rotation {
    /// A point of the line, machine frame, m.
    pivot: Vector3<f64>,
    rad_per_k: f64,
    temperature: Temperature,
}

impl Rotation {
    /// `H(θ(t)) = Trans(c)·Rot_x(θ)·Trans(−c)`.
    fn turn(&self, t: f64) -> Matrix4<f64> {
        let theta = self.rad_per_k * self.temperature.rise(t);
        let r = exp_rotation(&Vector3::new(theta, 0.0, 0.0));
        rigid(&r, &(self.pivot - r * self.pivot))
    }
}

/// A step of the room temperature ([`Effect::AmbientStep`]).
#[derive(Clone, Debug)]
struct Ambient {
    ambient_c: f64,
    at_s: f64,
    step_k: f64,
    tau_s: f64,
    /// m per K, machine directions.
    shift_per_k: Vector3<f64>,
}

impl Ambient {
    /// The structure's uniform displacement at `t`, m.
    fn shift(&self, t: f64) -> Vector3<f64> {
        let x = first_order_response(&[(self.at_s, 1.0)], self.tau_s, t);
        self.shift_per_k * (self.step_k * x)
    }

    /// The air's temperature at `t`, °C.
    fn air_c(&self, t: f64) -> f64 {
        if t >= self.at_s {
            self.ambient_c + self.step_k
        } else {
            self.ambient_c
        }
    }
}

/// A lost motion whose width varies along the stroke ([`Effect::LostMotion`]).
#[derive(Clone, Debug)]
struct Worn {
    axis: usize,
    low: f64,
    high: f64,
    /// The stroke the width varies over.
    stroke: (f64, f64),
    /// The seed of the per-run approach side (`None`: carried).
    random_seed: Option<u64>,
}

impl Worn {
    /// `B(c)`.
    fn width(&self, c: f64) -> f64 {
        let (lo, hi) = self.stroke;
        let f = ((c - lo) / (hi - lo)).clamp(0.0, 1.0);
        self.low + (self.high - self.low) * f
    }
}

/// A carriage rocking across its guideway clearance ([`Effect::LateralPlay`]).
#[derive(Clone, Debug)]
struct Lateral {
    axis: usize,
    across: Vector3<f64>,
    play: f64,
    take_up: f64,
}

impl Lateral {
    /// Where the carriage sits across its clearance (m along `across`), having been at `from`
    /// at the last reversal, moving in `sense` for `travel` since.
    fn offset(&self, from: f64, sense: f64, travel: f64) -> f64 {
        let flank = 0.5 * self.play * sense;
        let u = if self.take_up > 0.0 {
            (travel / self.take_up).min(1.0)
        } else {
            1.0
        };
        from + (flank - from) * 0.5 * (1.0 - (std::f64::consts::PI * u).cos())
    }
}

/// A local bump on a guideway ([`Effect::GuidewayBump`]).
#[derive(Clone, Debug)]
struct Bump {
    axis: usize,
    direction: Vector3<f64>,
    centre: f64,
    width: f64,
    height: f64,
}

impl Bump {
    /// The raised cosine at the actual position `q`.
    fn rise(&self, q: f64) -> f64 {
        let off = q - self.centre;
        if off.abs() < 0.5 * self.width {
            0.5 * self.height * (1.0 + (std::f64::consts::TAU * off / self.width).cos())
        } else {
            0.0
        }
    }
}

/// A set-up's fixed element settling ([`Effect::SetupCreep`]).
#[derive(Clone, Debug)]
struct Creep {
    setup: String,
    /// Where it ends up, m (workpiece frame).
    settle: Vector3<f64>,
    tau_s: f64,
}

/// A context column of one run: its name, the true values and whether a sensor reads it (a
/// temperature: noise and quantisation apply) or it is exact (the spindle speed).
#[derive(Clone, Debug)]
pub(crate) struct ContextValues {
    pub name: String,
    pub values: Vec<f64>,
    pub sensed: bool,
}

fn plan_error(message: String) -> SimError {
    SimError::Plan(message)
}

impl Resolved {
    /// Checks every effect of `effects` against `machine` and `setups`; a clear
    /// [`SimError::Plan`] names the effect and what is wrong.
    pub(crate) fn new(
        machine: &Machine,
        setups: &[SetupPlan],
        effects: &[Effect],
    ) -> Result<Resolved, SimError> {
        let mut out = Resolved {
            spindle_rpm: spindle_programme(effects)?,
            ..Resolved::default()
        };
        for (k, e) in effects.iter().enumerate() {
            out.add(machine, setups, e)
                .map_err(|m| plan_error(format!("effect {} ({}): {m}", k + 1, kind_name(e))))?;
        }
        let mut seen: Vec<&str> = Vec::new();
        for c in &out.columns {
            if seen.contains(&c.name.as_str()) {
                return Err(plan_error(format!(
                    "context column {} is written by two effects",
                    c.name
                )));
            }
            seen.push(&c.name);
        }
        Ok(out)
    }

    fn add(&mut self, machine: &Machine, setups: &[SetupPlan], e: &Effect) -> Result<(), String> {
        match e {
            Effect::Backlash { axis, lost_motion } => {
                let i = axis_index(machine, *axis)?;
                finite_at_least("lost_motion", *lost_motion, 0.0)?;
                self.backlash.push((i, *lost_motion));
            }
            Effect::Thermal { direction, sources } => {
                let d = unit("direction", direction)?;
                let nodes = self.nodes(sources)?;
                self.growth.push((d, nodes));
            }
            Effect::ScrewError {
                axis,
                pitch,
                harmonics,
            } => {
                let i = axis_index(machine, *axis)?;
                positive("pitch", *pitch)?;
                for &(k, a, phase) in harmonics {
                    if k == 0 || !a.is_finite() || !phase.is_finite() {
                        return Err(format!(
                            "harmonic ({k}, {a}, {phase}): the order is 1 or more, amplitude \
                             and phase finite"
                        ));
                    }
                }
                self.screws.push(Screw {
                    axis: i,
                    pitch: *pitch,
                    harmonics: harmonics.clone(),
                });
            }
            Effect::ThermalScale {
                axis,
                ppm_per_k,
                reference,
                temperature,
                column,
            } => {
                let i = linear_axis(machine, *axis, "a thermal scale")?;
                finite("ppm_per_k", *ppm_per_k)?;
                finite("reference", *reference)?;
                self.log_temperature(column, Shows::ScaleTemperature(self.scales.len()))?;
                self.scales.push(Scale {
                    axis: i,
                    alpha_per_k: ppm_per_k * 1e-6,
                    reference: *reference,
                    temperature: self.temperature(temperature)?,
                });
            }
            Effect::Twist { per_m2 } => {
                finite("per_m2", *per_m2)?;
                let x = linear_axis(machine, 'X', "a twist")?;
                let y = linear_axis(machine, 'Y', "a twist")?;
                self.twist.push((x, y, *per_m2));
            }
            Effect::Sag {
                axis,
                direction,
                per_m2,
            } => {
                finite("per_m2", *per_m2)?;
                let i = linear_axis(machine, *axis, "a sag")?;
                let d = "XYZ".find(*direction).ok_or_else(|| {
                    format!("direction {direction}: a machine direction is X, Y or Z")
                })?;
                self.sag.push((i, d, *per_m2));
            }
            Effect::BallBarThermal {
                setup,
                ppm_per_k,
                temperature,
                column,
            } => self.add_bar(setups, setup, *ppm_per_k, temperature, column)?,
            Effect::SetupCreep {
                setup,
                settle,
                tau_s,
            } => self.add_creep(setups, setup, settle, *tau_s)?,
            Effect::ServoLag { axis, lag_s } => {
                let i = axis_index(machine, *axis)?;
                finite_at_least("lag_s", *lag_s, 0.0)?;
                self.lags.push((i, *lag_s));
            }
            Effect::SpindleSpeed { .. } => self.columns.push(Column {
                name: "S".into(),
                shows: Shows::Spindle,
                setup: None,
            }),
            Effect::LostMotion {
                axis,
                lost_motion_low,
                lost_motion_high,
                approach,
            } => {
                let i = axis_index(machine, *axis)?;
                finite_at_least("lost_motion_low", *lost_motion_low, 0.0)?;
                finite_at_least("lost_motion_high", *lost_motion_high, 0.0)?;
                self.worn.push(Worn {
                    axis: i,
                    low: *lost_motion_low,
                    high: *lost_motion_high,
                    stroke: machine.joints[i].stroke(),
                    random_seed: match approach {
                        Approach::Carried => None,
                        Approach::RandomPerRun { seed } => Some(*seed),
                    },
                });
            }
            Effect::LateralPlay {
                axis,
                across,
                play,
                take_up,
            } => {
                let i = axis_index(machine, *axis)?;
                let across = unit("across", across)?;
                finite_at_least("play", *play, 0.0)?;
                finite_at_least("take_up", *take_up, 0.0)?;
                self.lateral.push(Lateral {
                    axis: i,
                    across,
                    play: *play,
                    take_up: *take_up,
                });
            }
            Effect::ReversalSpike {
                axis,
                height,
                recovery_s,
            } => {
                let i = axis_index(machine, *axis)?;
                finite("height", *height)?;
                positive("recovery_s", *recovery_s)?;
                self.spikes.push((i, *height, *recovery_s));
            }
            Effect::StickSlip {
                axis,
                height,
                slip_travel,
            } => {
                let i = axis_index(machine, *axis)?;
                finite_at_least("height", *height, 0.0)?;
                positive("slip_travel", *slip_travel)?;
                self.sticks.push((i, *height, *slip_travel));
            }
            Effect::GuidewayBump {
                axis,
                direction,
                centre,
                width,
                height,
            } => {
                let i = linear_axis(machine, *axis, "a guideway bump")?;
                let direction = unit("direction", direction)?;
                finite("centre", *centre)?;
                positive("width", *width)?;
                finite("height", *height)?;
                self.bumps.push(Bump {
                    axis: i,
                    direction,
                    centre: *centre,
                    width: *width,
                    height: *height,
                });
            }
            Effect::SpindleGrowth { sources } => {
                let nodes = self.nodes(sources)?;
                self.spindle_growth.push(nodes);
            }
            Effect::HeadRotationX {
                pivot_y,
                pivot_z,
                urad_per_k,
                temperature,
                column,
            } => {
                finite("pivot_y", *pivot_y)?;
                finite("pivot_z", *pivot_z)?;
                finite("urad_per_k", *urad_per_k)?;
                if let Some(name) = column {
                    self.log_temperature(name, Shows::RotationTemperature(self.rotations.len()))?;
                }
                self.rotations.push(Rotation {
                    pivot: Vector3::new(0.0, *pivot_y, *pivot_z),
                    rad_per_k: urad_per_k * 1e-6,
                    temperature: self.temperature(temperature)?,
                });
            }
            Effect::AxisLineDrift {
                parameter,
                per_k,
                temperature,
                column,
            } => {
                finite("per_k", *per_k)?;
                let (axis, direction) = line_location(machine, parameter)?;
                if let Some(name) = column {
                    self.log_temperature(name, Shows::LineTemperature(self.lines.len()))?;
                }
                self.lines.push(LineDrift {
                    axis,
                    direction,
                    per_k: *per_k,
                    temperature: self.temperature(temperature)?,
                });
            }
            Effect::AmbientStep {
                ambient_c,
                at_s,
                step_k,
                tau_s,
                shift_per_k,
                column,
            } => {
                finite("ambient_c", *ambient_c)?;
                finite("at_s", *at_s)?;
                finite("step_k", *step_k)?;
                positive("tau_s", *tau_s)?;
                for v in shift_per_k {
                    finite("shift_per_k", *v)?;
                }
                if let Some(name) = column {
                    self.log_temperature(name, Shows::Air(self.ambient.len()))?;
                }
                self.ambient.push(Ambient {
                    ambient_c: *ambient_c,
                    at_s: *at_s,
                    step_k: *step_k,
                    tau_s: *tau_s,
                    shift_per_k: Vector3::from(*shift_per_k),
                });
            }
            Effect::TemperatureSensor {
                column,
                temperature,
            } => {
                self.log_temperature(column, Shows::Sensor(self.sensors.len()))?;
                let temperature = self.temperature(temperature)?;
                self.sensors.push(temperature);
            }
        }
        Ok(())
    }

    /// A temperature written as column `name` (`T_<name>`) in every run, showing `shows`.
    fn log_temperature(&mut self, name: &str, shows: Shows) -> Result<(), String> {
        check_temperature_column(name)?;
        self.columns.push(Column {
            name: name.to_string(),
            shows,
            setup: None,
        });
        Ok(())
    }

    fn add_bar(
        &mut self,
        setups: &[SetupPlan],
        setup: &str,
        ppm_per_k: f64,
        temperature: &TemperatureProgramme,
        column: &Option<String>,
    ) -> Result<(), String> {
        finite("ppm_per_k", ppm_per_k)?;
        let length_mm = match instrument_of(setups, setup)? {
            Instrument::BallBar { length_mm, .. } => *length_mm,
            other => {
                return Err(format!(
                    "set-up {setup} is not a ball bar (its instrument is {})",
                    other.plugin_name()
                ));
            }
        };
        if self.bars.iter().any(|b| b.setup == setup) {
            return Err(format!("set-up {setup} already has a bar temperature"));
        }
        if let Some(name) = column {
            check_temperature_column(name)?;
            self.columns.push(Column {
                name: name.clone(),
                shows: Shows::BarTemperature(self.bars.len()),
                setup: Some(setup.to_string()),
            });
        }
        self.bars.push(Bar {
            setup: setup.to_string(),
            m_per_k: ppm_per_k * 1e-6 * length_mm * 1e-3,
            temperature: self.temperature(temperature)?,
        });
        Ok(())
    }

    fn add_creep(
        &mut self,
        setups: &[SetupPlan],
        setup: &str,
        settle: &[f64; 3],
        tau_s: f64,
    ) -> Result<(), String> {
        for v in settle {
            finite("settle", *v)?;
        }
        positive("tau_s", tau_s)?;
        match instrument_of(setups, setup)? {
            Instrument::RTest { .. } | Instrument::BallBar { .. } => {}
            other => {
                return Err(format!(
                    "set-up {setup} is a {}; a set-up creep is planted on an R-test or a ball bar",
                    other.plugin_name()
                ));
            }
        }
        if self.creeps.iter().any(|c| c.setup == setup) {
            return Err(format!("set-up {setup} already creeps"));
        }
        self.creeps.push(Creep {
            setup: setup.to_string(),
            settle: Vector3::from(*settle),
            tau_s,
        });
        Ok(())
    }

    fn nodes(&self, sources: &[HeatSource]) -> Result<Vec<Node>, String> {
        sources
            .iter()
            .map(|s| {
                finite("gain", s.gain)?;
                positive("tau_s", s.tau_s)?;
                let steps = match &s.power {
                    Programme::Steps(steps) => {
                        check_steps("power", steps)?;
                        steps.clone()
                    }
                    Programme::SpindleKrpm => self
                        .spindle_rpm
                        .as_ref()
                        .ok_or("a heat source follows the spindle speed, but the plan has no SpindleSpeed")?
                        .iter()
                        .map(|&(t, rpm)| (t, rpm * 1e-3))
                        .collect(),
                };
                Ok(Node {
                    gain: s.gain,
                    tau_s: s.tau_s,
                    steps,
                })
            })
            .collect()
    }

    fn temperature(&self, p: &TemperatureProgramme) -> Result<Temperature, String> {
        finite("ambient_c", p.ambient_c)?;
        finite("drift_k_per_h", p.drift_k_per_h)?;
        Ok(Temperature {
            ambient_c: p.ambient_c,
            drift_k_per_s: p.drift_k_per_h / 3600.0,
            nodes: self.nodes(&p.rises)?,
        })
    }

    /// Whether any effect changes the actual tool pose (the bar's own expansion and the
    /// spindle speed do not).
    fn moves_the_machine(&self) -> bool {
        !(self.backlash.is_empty()
            && self.lags.is_empty()
            && self.screws.is_empty()
            && self.scales.is_empty()
            && self.growth.is_empty()
            && self.twist.is_empty()
            && self.sag.is_empty()
            && self.worn.is_empty()
            && self.lateral.is_empty()
            && self.spikes.is_empty()
            && self.sticks.is_empty()
            && self.bumps.is_empty()
            && self.spindle_growth.is_empty()
            && self.rotations.is_empty()
            && self.ambient.is_empty()
            && self.lines.is_empty())
    }

    /// What the instrument of `setup` reads besides the machine, m, at each of `times`: the
    /// ball bar's own expansion (zero for any other set-up).
    pub(crate) fn instrument_own(&self, setup: &str, times: &[f64]) -> Option<Vec<f64>> {
        let bar = self.bars.iter().find(|b| b.setup == setup)?;
        Some(
            times
                .iter()
                .map(|&t| -bar.m_per_k * bar.temperature.rise(t))
                .collect(),
        )
    }

    /// How far the fixed element of `setup` has moved (m, workpiece frame) at each of `times`,
    /// the set-up mounted at `mounted_s`; `None` where it does not creep.
    pub(crate) fn setup_shift(
        &self,
        setup: &str,
        mounted_s: f64,
        times: &[f64],
    ) -> Option<Vec<Vector3<f64>>> {
        let c = self.creeps.iter().find(|c| c.setup == setup)?;
        Some(
            times
                .iter()
                .map(|&t| c.settle * -(-(t - mounted_s).max(0.0) / c.tau_s).exp_m1())
                .collect(),
        )
    }

    /// The context columns of a run of `setup` at `times`, true values.
    pub(crate) fn context(&self, setup: &str, times: &[f64]) -> Vec<ContextValues> {
        self.columns
            .iter()
            .filter(|c| c.setup.as_deref().is_none_or(|s| s == setup))
            .map(|c| {
                let value = |t: f64| match c.shows {
                    Shows::Spindle => value_at(self.spindle_rpm.as_deref().unwrap_or(&[]), t),
                    Shows::ScaleTemperature(i) => self.scales[i].temperature.celsius(t),
                    Shows::BarTemperature(i) => self.bars[i].temperature.celsius(t),
                    Shows::RotationTemperature(i) => self.rotations[i].temperature.celsius(t),
                    Shows::Air(i) => self.ambient[i].air_c(t),
                    Shows::Sensor(i) => self.sensors[i].celsius(t),
                    Shows::LineTemperature(i) => self.lines[i].temperature.celsius(t),
                };
                ContextValues {
                    name: c.name.clone(),
                    values: times.iter().map(|&t| value(t)).collect(),
                    sensed: !matches!(c.shows, Shows::Spindle),
                }
            })
            .collect()
    }
}

/// The spindle speed programme of the plan, if any (at most one).
fn spindle_programme(effects: &[Effect]) -> Result<Option<Vec<(f64, f64)>>, SimError> {
    let mut found = None;
    for e in effects {
        if let Effect::SpindleSpeed { rpm } = e {
            if found.is_some() {
                return Err(plan_error("the plan has two SpindleSpeed effects".into()));
            }
            let Programme::Steps(steps) = rpm else {
                return Err(plan_error(
                    "SpindleSpeed: the speed is a Programme::Steps of rpm".into(),
                ));
            };
            check_steps("rpm", steps).map_err(|m| plan_error(format!("SpindleSpeed: {m}")))?;
            found = Some(steps.clone());
        }
    }
    Ok(found)
}

fn kind_name(e: &Effect) -> &'static str {
    match e {
        Effect::Backlash { .. } => "backlash",
        Effect::Thermal { .. } => "thermal",
        Effect::ScrewError { .. } => "screw-error",
        Effect::ThermalScale { .. } => "thermal-scale",
        Effect::Twist { .. } => "twist",
        Effect::Sag { .. } => "sag",
        Effect::BallBarThermal { .. } => "ballbar-thermal",
        Effect::SetupCreep { .. } => "setup-creep",
        Effect::ServoLag { .. } => "servo-lag",
        Effect::SpindleSpeed { .. } => "spindle-speed",
        Effect::LostMotion { .. } => "lost-motion",
        Effect::LateralPlay { .. } => "lateral-play",
        Effect::ReversalSpike { .. } => "reversal-spike",
        Effect::StickSlip { .. } => "stick-slip",
        Effect::GuidewayBump { .. } => "guideway-bump",
        Effect::SpindleGrowth { .. } => "spindle-growth",
        Effect::HeadRotationX { .. } => "head-rotation-x",
        Effect::AmbientStep { .. } => "ambient-step",
        Effect::AxisLineDrift { .. } => "axis-line-drift",
        Effect::TemperatureSensor { .. } => "temperature-sensor",
    }
}

/// The instrument of the plan's set-up `name`.
fn instrument_of<'p>(setups: &'p [SetupPlan], name: &str) -> Result<&'p Instrument, String> {
    setups
        .iter()
        .find(|s| s.name == name)
        .map(|s| &s.instrument)
        .ok_or_else(|| format!("no set-up {name}"))
}

fn axis_index(machine: &Machine, letter: char) -> Result<usize, String> {
    machine.index(letter).ok_or_else(|| {
        format!(
            "no axis {letter}: the machine's axes are {}",
            machine.letters()
        )
    })
}

fn linear_axis(machine: &Machine, letter: char, what: &str) -> Result<usize, String> {
    let i = axis_index(machine, letter)?;
    match machine.joints[i].kind {
        JointKind::Linear => Ok(i),
        JointKind::Rotary => Err(format!(
            "{what} needs a linear axis {letter}; {letter} is rotary here"
        )),
    }
}

/// A direction's unit vector (machine directions), or why it is none.
fn unit(name: &str, v: &[f64; 3]) -> Result<Vector3<f64>, String> {
    let d = Vector3::from(*v);
    if d.iter().all(|x| x.is_finite()) && d.norm() > 0.0 {
        Ok(d.normalize())
    } else {
        Err(format!("{name} {v:?} is not a direction"))
    }
}

fn finite(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{name} = {v} is not a finite number"))
    }
}

fn positive(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} = {v}: expected a positive number"))
    }
}

fn finite_at_least(name: &str, v: f64, min: f64) -> Result<(), String> {
    if v.is_finite() && v >= min {
        Ok(())
    } else {
        Err(format!("{name} = {v}: expected a finite number ≥ {min}"))
    }
}

fn check_steps(name: &str, steps: &[(f64, f64)]) -> Result<(), String> {
    if steps.iter().any(|s| !(s.0.is_finite() && s.1.is_finite())) {
        return Err(format!("{name}: every step time and value is finite"));
    }
    if steps.windows(2).any(|w| w[1].0 <= w[0].0) {
        return Err(format!("{name}: step times must increase strictly"));
    }
    Ok(())
}

/// FORMATS.md's temperature columns: `T_<name>`, a name of letters, digits and `_`.
/// The rotary axis and the direction across it of location error `name` (`EY0A`).
fn line_location(machine: &Machine, name: &str) -> Result<(usize, usize), String> {
    const DIRECTIONS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];
    let c: Vec<char> = name.chars().collect();
    let found = (c.len() == 4 && c[0] == 'E' && c[2] == '0')
        .then(|| {
            (
                DIRECTIONS.iter().position(|&x| x == c[1]),
                machine.index(c[3]),
            )
        })
        .and_then(|(d, i)| Some((i?, d?)));
    let (i, d) = found.ok_or_else(|| {
        format!("an axis line drift: `{name}` is not a location error (EY0A) of this machine")
    })?;
    let j = &machine.joints[i];
    if j.kind != JointKind::Rotary || d % 3 == j.own_direction() {
        return Err(format!(
            "an axis line drift: `{name}` is not a location error across a rotary axis"
        ));
    }
    Ok((i, d))
}

fn check_temperature_column(name: &str) -> Result<(), String> {
    let ok = name.strip_prefix("T_").is_some_and(|rest| {
        !rest.is_empty() && rest.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    });
    if ok {
        Ok(())
    } else {
        Err(format!(
            "column {name:?}: a temperature column is T_<name> (letters, digits, _)"
        ))
    }
}

/// The effects' state at one sample: what turns a commanded pose into the actual one.
#[derive(Clone, Debug)]
pub(crate) struct SampleState<'a> {
    effects: &'a Resolved,
    /// Per backlash effect: actual minus commanded position, as the dead band left it here.
    lost: Vec<f64>,
    /// Per servo lag: the command `T` earlier minus the command now.
    trail: Vec<f64>,
    /// Per thermal scale: `α·(T(t) − T(0))`.
    strain: Vec<f64>,
    /// The spindle head's thermal growth, machine frame, m.
    growth: Vector3<f64>,
    /// Per worn lost motion, per reversal spike, per stick-slip: actual minus commanded
    /// position.
    worn: Vec<f64>,
    spike: Vec<f64>,
    stick: Vec<f64>,
    /// The carriages' displacement across their guideways, machine frame, m.
    lateral: Vector3<f64>,
    /// The spindle's growth along the tool axis (out of the spindle), m.
    spindle: f64,
    /// The structure's uniform displacement after ambient steps, machine frame, m.
    air: Vector3<f64>,
    /// The head's turn about its lines, `H = H_1·H_2·…` (`None`: no head rotation).
    head: Option<Matrix4<f64>>,
    /// The axis lines' changes: `(axis, direction, m or rad)`.
    lines: Vec<(usize, usize, f64)>,
}

impl SampleState<'_> {
    /// The actual axis positions for the commands `q` (SI): lost motion frozen as the
    /// sample's approach left it, screw and scale errors at `q`.
    pub(crate) fn axes(&self, q: &[f64]) -> Vec<f64> {
        let e = self.effects;
        let mut a = q.to_vec();
        for (&(i, _), lost) in e.backlash.iter().zip(&self.lost) {
            a[i] += lost;
        }
        for (&(i, _), trail) in e.lags.iter().zip(&self.trail) {
            a[i] += trail;
        }
        for s in &e.screws {
            a[s.axis] += s.error(q[s.axis]);
        }
        for (s, strain) in e.scales.iter().zip(&self.strain) {
            a[s.axis] += strain * (q[s.axis] - s.reference);
        }
        for (w, lost) in e.worn.iter().zip(&self.worn) {
            a[w.axis] += lost;
        }
        for (&(i, ..), v) in e.spikes.iter().zip(&self.spike) {
            a[i] += v;
        }
        for (&(i, ..), v) in e.sticks.iter().zip(&self.stick) {
            a[i] += v;
        }
        a
    }

    /// The tool point's displacement relative to the workpiece, machine frame (m), at the
    /// actual axis positions `a`.
    pub(crate) fn tool_shift(&self, a: &[f64]) -> Vector3<f64> {
        let e = self.effects;
        let mut d = self.growth + self.lateral + self.air;
        for b in &e.bumps {
            d += b.direction * b.rise(a[b.axis]);
        }
        for &(x, y, k) in &e.twist {
            d.z += k * a[x] * a[y];
        }
        for &(i, dir, k) in &e.sag {
            d[dir] += k * a[i] * a[i];
        }
        d
    }

    /// The actual tool pose in the workpiece frame at the commands `q`:
    /// `f_T_w(a)⁻¹ · H · Trans(d) · f_T_t(a) · Trans(0, 0, −g)` (module docs, `H` the head's
    /// turn, `g` the spindle's growth); exactly the geometric model's pose when no effect moves
    /// the machine.
    pub(crate) fn tool_in_workpiece(
        &self,
        machine: &Machine,
        truth: &Truth,
        q: &[f64],
    ) -> Matrix4<f64> {
        if !self.effects.moves_the_machine() {
            return machine.tool_in_workpiece(q, Some(truth));
        }
        let a = self.axes(q);
        let d = self.tool_shift(&a);
        let moved = MovedLines {
            truth,
            changes: &self.lines,
        };
        let actual: &dyn ActualErrors = if self.lines.is_empty() { truth } else { &moved };
        let w = machine.branch_pose(Side::Workpiece, &a, Some(actual));
        let mut t = machine.branch_pose(Side::Tool, &a, Some(actual));
        if d != Vector3::zeros() {
            t = translation(&d) * t;
        }
        if let Some(h) = &self.head {
            t = h * t;
        }
        if self.spindle != 0.0 {
            t *= translation(&Vector3::new(0.0, 0.0, -self.spindle));
        }
        rigid_inverse(&w) * t
    }
}

/// The actual tool pose at sample `q` with its effects' state, if any.
pub(crate) fn actual_pose(
    machine: &Machine,
    truth: &Truth,
    q: &[f64],
    state: Option<&SampleState<'_>>,
) -> Matrix4<f64> {
    match state {
        Some(s) => s.tool_in_workpiece(machine, truth, q),
        None => machine.tool_in_workpiece(q, Some(truth)),
    }
}

impl ActualPoses for [SampleState<'_>] {
    fn actual_pose(&self, machine: &Machine, truth: &Truth, k: usize, q: &[f64]) -> Matrix4<f64> {
        actual_pose(machine, truth, q, self.get(k))
    }
}

/// Commanded moves smaller than this (m or rad) do not count as motion: a held axis whose
/// command differs in the last digits is not reversing.
const STILL: f64 = 1e-9;

/// The commanded motion of one axis along the session: which way it last moved, how far it
/// has travelled since it last reversed, and when that was.
#[derive(Clone, Debug)]
struct Travel {
    /// The command where the axis last moved (`None`: before the session's first sample).
    last: Option<f64>,
    /// The time of the previous sample, s.
    last_t: f64,
    /// +1 or −1: the direction of the last move (+1 before any: approached from below).
    sense: f64,
    /// Commanded travel since the last reversal (infinite before the first).
    since: f64,
    /// When the last reversal happened, s (the time of the last sample at the turning point).
    reversed_at: Option<f64>,
}

impl Travel {
    fn new() -> Self {
        Travel {
            last: None,
            last_t: 0.0,
            sense: 1.0,
            since: f64::INFINITY,
            reversed_at: None,
        }
    }

    /// Moves to command `c` at time `t`; whether the axis reversed on the way.
    fn to(&mut self, c: f64, t: f64) -> bool {
        let mut reversed = false;
        match self.last {
            None => self.last = Some(c),
            Some(from) => {
                let step = c - from;
                if step.abs() > STILL {
                    if step.signum() == self.sense {
                        self.since += step.abs();
                    } else {
                        self.sense = step.signum();
                        self.since = step.abs();
                        self.reversed_at = Some(self.last_t);
                        reversed = true;
                    }
                    self.last = Some(c);
                }
            }
        }
        self.last_t = t;
        reversed
    }
}

/// The session's timeline: the effects' state carried from sample to sample and run to run.
#[derive(Debug)]
pub(crate) struct Timeline<'a> {
    effects: &'a Resolved,
    /// Per backlash effect: the axis' actual position after the last sample (`None`: before
    /// the session's first sample).
    actual: Vec<Option<f64>>,
    /// Per worn lost motion: the same, and the random stream of its approach sides.
    worn: Vec<(Option<f64>, Option<ChaCha8Rng>)>,
    /// Per lateral play: the axis' travel and where the carriage was across at the last
    /// reversal and at the last sample (m).
    lateral: Vec<(Travel, f64, f64)>,
    /// Per reversal spike, per stick-slip: the axis' travel.
    spikes: Vec<Travel>,
    sticks: Vec<Travel>,
}

impl<'a> Timeline<'a> {
    pub(crate) fn new(effects: &'a Resolved) -> Self {
        Timeline {
            effects,
            actual: vec![None; effects.backlash.len()],
            worn: effects
                .worn
                .iter()
                .map(|w| (None, w.random_seed.map(ChaCha8Rng::seed_from_u64)))
                .collect(),
            lateral: effects
                .lateral
                .iter()
                .map(|l| (Travel::new(), 0.5 * l.play, 0.5 * l.play))
                .collect(),
            spikes: vec![Travel::new(); effects.spikes.len()],
            sticks: vec![Travel::new(); effects.sticks.len()],
        }
    }

    /// The states of the next run's samples: its commands `poses` (SI, as the machine moves
    /// there) at `times` (s).
    pub(crate) fn run(&mut self, poses: &[Vec<f64>], times: &[f64]) -> Vec<SampleState<'a>> {
        // A worn axis approached from a random side: it stands B/2 short of (from below) or
        // beyond (from above) the run's first command.
        if let Some(first) = poses.first() {
            for (w, (actual, rng)) in self.effects.worn.iter().zip(&mut self.worn) {
                if let Some(rng) = rng {
                    let c = first[w.axis];
                    let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                    *actual = Some(c - side * 0.5 * w.width(c));
                }
            }
        }
        (0..poses.len())
            .map(|k| {
                let trail = self
                    .effects
                    .lags
                    .iter()
                    .map(|&(i, lag)| command_at(poses, times, k, i, times[k] - lag) - poses[k][i])
                    .collect();
                self.sample(&poses[k], times[k], trail)
            })
            .collect()
    }

    fn sample(&mut self, q: &[f64], t: f64, trail: Vec<f64>) -> SampleState<'a> {
        let e = self.effects;
        let lost = e
            .backlash
            .iter()
            .zip(&mut self.actual)
            .map(|(&(i, b), a)| {
                let now = take_up(*a, q[i], b);
                *a = Some(now);
                now - q[i]
            })
            .collect();
        let strain = e
            .scales
            .iter()
            .map(|s| s.alpha_per_k * s.temperature.rise(t))
            .collect();
        let growth = e
            .growth
            .iter()
            .map(|(dir, nodes)| dir * nodes.iter().map(|n| n.at(t)).sum::<f64>())
            .sum();
        let worn = e
            .worn
            .iter()
            .zip(&mut self.worn)
            .map(|(w, (a, _))| {
                let c = q[w.axis];
                let now = take_up(*a, c, w.width(c));
                *a = Some(now);
                now - c
            })
            .collect();
        let mut lateral = Vector3::zeros();
        for (l, (travel, from, now)) in e.lateral.iter().zip(&mut self.lateral) {
            if travel.to(q[l.axis], t) {
                *from = *now;
            }
            *now = l.offset(*from, travel.sense, travel.since);
            lateral += l.across * *now;
        }
        let spike = e
            .spikes
            .iter()
            .zip(&mut self.spikes)
            .map(|(&(i, height, recovery_s), travel)| {
                travel.to(q[i], t);
                travel.reversed_at.map_or(0.0, |at| {
                    let r = (t - at).max(0.0) / recovery_s;
                    -travel.sense * height * (1.0 + r) * (-r).exp()
                })
            })
            .collect();
        let stick = e
            .sticks
            .iter()
            .zip(&mut self.sticks)
            .map(|(&(i, height, slip), travel)| {
                travel.to(q[i], t);
                stick_slip(travel.sense, travel.since, height, slip)
            })
            .collect();
        let spindle = e
            .spindle_growth
            .iter()
            .map(|nodes| nodes.iter().map(|n| n.at(t)).sum::<f64>())
            .sum();
        let air = e.ambient.iter().map(|a| a.shift(t)).sum();
        let head = (!e.rotations.is_empty()).then(|| {
            e.rotations
                .iter()
                .fold(Matrix4::identity(), |h, r| h * r.turn(t))
        });
        let lines = e
            .lines
            .iter()
            .map(|l| (l.axis, l.direction, l.per_k * l.temperature.rise(t)))
            .collect();
        SampleState {
            effects: e,
            lost,
            trail,
            strain,
            growth,
            worn,
            spike,
            stick,
            lateral,
            spindle,
            air,
            head,
            lines,
        }
    }
}

/// Axis `i`'s command at time `at` (s) between the run's samples up to sample `k`; before the
/// run's first sample, its first command (the axis stood there). A control interpolates a
/// smooth path between the points a file samples (a circle stays a circle), so between two
/// samples the command follows the cubic Hermite curve through them with the slopes of their
/// neighbours (Catmull–Rom); where a neighbour is missing (the run's ends), the chord's slope.
/// A straight chord instead would pull a trailing axis inside a circle by up to `R·Δθ²/8`
/// and draw an ellipse no machine has.
fn command_at(poses: &[Vec<f64>], times: &[f64], k: usize, i: usize, at: f64) -> f64 {
    let mut j = k;
    while j > 0 && times[j - 1] > at {
        j -= 1;
    }
    if j == 0 || times[j] <= at {
        return poses[j][i];
    }
    let (t0, t1) = (times[j - 1], times[j]);
    let (p0, p1) = (poses[j - 1][i], poses[j][i]);
    let chord = (p1 - p0) / (t1 - t0);
    let slope = |a: usize, b: usize| (poses[b][i] - poses[a][i]) / (times[b] - times[a]);
    let m0 = if j >= 2 { slope(j - 2, j) } else { chord };
    let m1 = if j + 1 < poses.len() {
        slope(j - 1, j + 1)
    } else {
        chord
    };
    let h = t1 - t0;
    let u = (at - t0) / h;
    let (u2, u3) = (u * u, u * u * u);
    (2.0 * u3 - 3.0 * u2 + 1.0) * p0
        + (u3 - 2.0 * u2 + u) * h * m0
        + (-2.0 * u3 + 3.0 * u2) * p1
        + (u3 - u2) * h * m1
}

/// Stick-slip's actual minus commanded position ([`Effect::StickSlip`]) moving in `sense`,
/// `travel` since the last reversal (infinite: none yet).
fn stick_slip(sense: f64, travel: f64, height: f64, slip: f64) -> f64 {
    if !travel.is_finite() {
        0.0
    } else if travel < height {
        -sense * travel
    } else {
        let u = (travel - height) / slip;
        -sense * height * (1.0 + u) * (-u).exp()
    }
}

/// The dead band: where an axis with lost motion `b` ends up when the command moves to `c`
/// from actual position `a` (`None`: the first command, approached from below).
pub(crate) fn take_up(a: Option<f64>, c: f64, b: f64) -> f64 {
    let half = 0.5 * b;
    match a {
        None => c - half,
        Some(a) if c - a > half => c - half,
        Some(a) if c - a < -half => c + half,
        Some(a) => a,
    }
}

/// `truth/effects.toml`: every planted effect with its parameters, in units a person reads
/// (µm, µrad, mm, s, K, °C, rpm; the key names say which).
pub(crate) fn effects_toml(machine: &Machine, effects: &[Effect]) -> String {
    let mut list = toml::value::Array::new();
    for e in effects {
        list.push(toml::Value::Table(effect_table(machine, e)));
    }
    let mut root = toml::Table::new();
    root.insert("effect".into(), toml::Value::Array(list));
    let mut s = String::from(
        "# Effects planted by mtcal-indsim (crates/indsim/src/effects.rs gives their physics).\n\
         # Lengths in um, angles in urad, positions in mm (deg on rotary axes), times in s.\n",
    );
    write!(s, "{root}").expect("string");
    s
}

fn effect_table(machine: &Machine, e: &Effect) -> toml::Table {
    let mut t = toml::Table::new();
    let mut put = |k: &str, v: toml::Value| {
        t.insert(k.into(), v);
    };
    put("kind", kind_name(e).into());
    let rotary = |axis: char| {
        machine
            .index(axis)
            .is_some_and(|i| machine.joints[i].kind == JointKind::Rotary)
    };
    // Deviations in µm or µrad, positions in mm or degrees.
    let small = |v: f64| v * 1e6;
    let small_unit = |axis: char| if rotary(axis) { "urad" } else { "um" };
    let place = |axis: char, v: f64| {
        if rotary(axis) {
            v.to_degrees()
        } else {
            v * 1e3
        }
    };
    let place_unit = |axis: char| if rotary(axis) { "deg" } else { "mm" };
    match e {
        Effect::Backlash { axis, lost_motion } => {
            put("axis", axis.to_string().into());
            put(
                &format!("lost_motion_{}", small_unit(*axis)),
                small(*lost_motion).into(),
            );
        }
        Effect::Thermal { direction, sources } => {
            put("direction", floats(direction));
            put("source", sources_value(sources, "gain_um", 1e6));
        }
        Effect::ScrewError {
            axis,
            pitch,
            harmonics,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("pitch_{}", place_unit(*axis)),
                place(*axis, *pitch).into(),
            );
            let rows = harmonics
                .iter()
                .map(|&(k, a, phase)| {
                    let mut h = toml::Table::new();
                    h.insert("order".into(), i64::from(k).into());
                    h.insert(format!("amplitude_{}", small_unit(*axis)), small(a).into());
                    h.insert("phase_rad".into(), phase.into());
                    toml::Value::Table(h)
                })
                .collect();
            put("harmonic", toml::Value::Array(rows));
        }
        Effect::ThermalScale {
            axis,
            ppm_per_k,
            reference,
            temperature,
            column,
        } => {
            put("axis", axis.to_string().into());
            put("ppm_per_k", (*ppm_per_k).into());
            put(
                &format!("reference_{}", place_unit(*axis)),
                place(*axis, *reference).into(),
            );
            put("column", column.clone().into());
            put("temperature", temperature_value(temperature));
        }
        Effect::Twist { per_m2 } => put("um_per_m2", (per_m2 * 1e6).into()),
        Effect::Sag {
            axis,
            direction,
            per_m2,
        } => {
            put("axis", axis.to_string().into());
            put("direction", direction.to_string().into());
            put("um_per_m2", (per_m2 * 1e6).into());
        }
        Effect::BallBarThermal {
            setup,
            ppm_per_k,
            temperature,
            column,
        } => {
            put("setup", setup.clone().into());
            put("ppm_per_k", (*ppm_per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::ServoLag { axis, lag_s } => {
            put("axis", axis.to_string().into());
            put("lag_ms", (lag_s * 1e3).into());
        }
        Effect::SetupCreep {
            setup,
            settle,
            tau_s,
        } => {
            put("setup", setup.clone().into());
            put("settle_um", floats(&settle.map(|v| v * 1e6)));
            put("tau_s", (*tau_s).into());
        }
        Effect::SpindleSpeed { rpm } => put("rpm", programme_value(rpm)),
        Effect::LostMotion {
            axis,
            lost_motion_low,
            lost_motion_high,
            approach,
        } => {
            put("axis", axis.to_string().into());
            let unit = small_unit(*axis);
            put(
                &format!("lost_motion_low_{unit}"),
                small(*lost_motion_low).into(),
            );
            put(
                &format!("lost_motion_high_{unit}"),
                small(*lost_motion_high).into(),
            );
            match approach {
                Approach::Carried => put("approach", "carried".into()),
                Approach::RandomPerRun { seed } => {
                    put("approach", "random-per-run".into());
                    // A TOML integer is an i64: the seed's bits.
                    put("seed", i64::from_ne_bytes(seed.to_ne_bytes()).into());
                }
            }
        }
        Effect::LateralPlay {
            axis,
            across,
            play,
            take_up,
        } => {
            put("axis", axis.to_string().into());
            put("across", floats(across));
            put("play_um", small(*play).into());
            put(
                &format!("take_up_{}", place_unit(*axis)),
                place(*axis, *take_up).into(),
            );
        }
        Effect::ReversalSpike {
            axis,
            height,
            recovery_s,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("height_{}", small_unit(*axis)),
                small(*height).into(),
            );
            put("recovery_ms", (recovery_s * 1e3).into());
        }
        Effect::StickSlip {
            axis,
            height,
            slip_travel,
        } => {
            put("axis", axis.to_string().into());
            put(
                &format!("height_{}", small_unit(*axis)),
                small(*height).into(),
            );
            put(
                &format!("slip_travel_{}", place_unit(*axis)),
                place(*axis, *slip_travel).into(),
            );
        }
        Effect::GuidewayBump {
            axis,
            direction,
            centre,
            width,
            height,
        } => {
            put("axis", axis.to_string().into());
            put("direction", floats(direction));
            put("centre_mm", (centre * 1e3).into());
            put("width_mm", (width * 1e3).into());
            put("height_um", small(*height).into());
        }
        Effect::SpindleGrowth { sources } => {
            put("source", sources_value(sources, "gain_um", 1e6));
        }
        Effect::AxisLineDrift {
            parameter,
            per_k,
            temperature,
            column,
        } => {
            put("parameter", parameter.clone().into());
            let unit = if parameter
                .as_bytes()
                .get(1)
                .is_some_and(|b| b"ABC".contains(b))
            {
                "urad"
            } else {
                "um"
            };
            put(&format!("{unit}_per_k"), small(*per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::HeadRotationX {
            pivot_y,
            pivot_z,
            urad_per_k,
            temperature,
            column,
        } => {
            put("pivot_y_mm", (pivot_y * 1e3).into());
            put("pivot_z_mm", (pivot_z * 1e3).into());
            put("urad_per_k", (*urad_per_k).into());
            if let Some(c) = column {
                put("column", c.clone().into());
            }
            put("temperature", temperature_value(temperature));
        }
        Effect::AmbientStep {
            ambient_c,
            at_s,
            step_k,
            tau_s,
            shift_per_k,
            column,
        } => {
            put("ambient_c", (*ambient_c).into());
            put("at_s", (*at_s).into());
            put("step_k", (*step_k).into());
            put("tau_s", (*tau_s).into());
            put("shift_um_per_k", floats(&shift_per_k.map(|v| v * 1e6)));
            if let Some(c) = column {
                put("column", c.clone().into());
            }
        }
        Effect::TemperatureSensor {
            column,
            temperature,
        } => {
            put("column", column.clone().into());
            put("temperature", temperature_value(temperature));
        }
    }
    t
}

fn floats(v: &[f64]) -> toml::Value {
    toml::Value::Array(v.iter().map(|&x| x.into()).collect())
}

fn programme_value(p: &Programme) -> toml::Value {
    match p {
        Programme::Steps(steps) => {
            toml::Value::Array(steps.iter().map(|&(t, v)| floats(&[t, v])).collect())
        }
        Programme::SpindleKrpm => "spindle_krpm".into(),
    }
}

/// Heat sources as a list of tables, the gain under `gain_key` scaled by `scale`.
fn sources_value(sources: &[HeatSource], gain_key: &str, scale: f64) -> toml::Value {
    toml::Value::Array(
        sources
            .iter()
            .map(|s| {
                let mut t = toml::Table::new();
                t.insert(gain_key.into(), (s.gain * scale).into());
                t.insert("tau_s".into(), s.tau_s.into());
                t.insert("power".into(), programme_value(&s.power));
                toml::Value::Table(t)
            })
            .collect(),
    )
}

fn temperature_value(p: &TemperatureProgramme) -> toml::Value {
    let mut t = toml::Table::new();
    t.insert("ambient_c".into(), p.ambient_c.into());
    t.insert("drift_k_per_h".into(), p.drift_k_per_h.into());
    t.insert("rise".into(), sources_value(&p.rises, "gain_k", 1.0));
    toml::Value::Table(t)
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod volumetric_tests;
