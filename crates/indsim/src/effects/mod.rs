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

mod check;
mod resolve;
mod sample;
mod table;

use check::*;
pub(crate) use resolve::*;
pub(crate) use sample::*;
use table::*;

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

#[cfg(test)]
mod tests;
#[cfg(test)]
mod volumetric_tests;
