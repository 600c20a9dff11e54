//! The volumetric thermal test (docs/VOLUMETRIC.md; source 000, §3.5–3.10, 4.1, 5.3): an
//! R-test head in the spindle visits balls spread over the work volume in short measuring
//! cycles, repeated through hours of load, while temperatures and the spindle speed are logged.
//!
//! [`write_volumetric`] runs a [`VolumetricPlan`] through the session's timeline and writes
//! what such a test leaves: the per-visit session, the head's raw stream with the NC program
//! and the log that a user keeps instead, and the truth.
//!
//! # One cycle
//! The NC program of one cycle ([`VolumetricPlan::points`] in order) starts with the head at
//! home (X = Y = 0 and every rotary axis at 0, Z at [`VolumetricPlan::safe_z_mm`]) and, for
//! each point: rises along Z to [`VolumetricPlan::clearance_mm`] above the higher of the ball
//! it leaves and the one it goes to (or, when the rotary axes turn, to the safe height, turns
//! them in a move of their own), moves the other linear axes over the next ball, plunges onto
//! it along Z and dwells [`VolumetricPlan::dwell_s`]; it ends back at the safe height. Every
//! move is a `G1` at [`VolumetricPlan::feed_mm_per_min`]: linear moves take their path length
//! over the feed, rotary-only moves their angle in degrees over it (degrees per minute). Each
//! move's end is rounded up to a tick of 2 ms, so every cycle has the same timing relative to
//! its start. The positions are those the controller writes
//! ([`Realism::position_decimals`]): the machine moves exactly there.
//!
//! # The session's timeline
//! Cycle `k` (1-based) starts at `(k − 1)·P`. After a cycle the head waits at home; the phase
//! between two cycles (load or rest, [`Schedule::between_s`]) starts one log interval after the
//! cycle's end rounded up to the log's grid, and lasts [`VolumetricPlan::load_s`]; `P` follows
//! (all on the log's grid, so that no log sample next to a visit sees a load that starts or
//! stops). The machine's effects ([`crate::effects`]) act along the commanded sequence in time
//! order: every sample of every cycle (the program's corners, the stream's samples) and the
//! machine at home during the phases between cycles (the load's own motion is not in the
//! commanded sequence).
//!
//! # The stream (`stream/`)
//! - `stream.csv`, `t,dx,dy,dz` (s, µm). The head samples at 500 Hz on a clock of its own,
//!   half a period (1 ms) after the controller's ticks, so that no sample falls on an arrival
//!   or a departure: inside a dwell from the arrival `t_a` to the departure `t_a + dwell`
//!   (a whole number `d` of ticks, a multiple of 4) the `d` samples at `t_a + 1 ms`,
//!   `t_a + 3 ms`, … `t_a + dwell − 1 ms`; off the balls a sample every
//!   [`StreamOptions::off_ball_interval_s`] and right after each departure and before each
//!   arrival (or, with [`StreamOptions::approach_ramps`], the 500 Hz samples of the first and
//!   last 2.5 mm of the rise and the plunge: the readings of the nest leaving and coming down
//!   onto the ball, by the physics, end stop while any is beyond the range). Off a ball the
//!   readings sit at the end stop: `range_um` in all three columns, or empty cells
//!   ([`OffBall`]). Times are written in ms (`1234.567`).
//! - `cycle.nc`: the program of one cycle (`G90`, `G1` moves writing the axes that change, `F`
//!   in the first, `G4 P<s>` dwells with the point in a comment, `M30`).
//! - `log.csv`, `t[,S][,T_<name>…]` every [`VolumetricPlan::log_interval_s`] from 0 to the
//!   session's end: the effects' context columns as the sensors read them ([`Realism`]'s
//!   temperature noise and resolution; `S` exact).
//!
//! A reading on a ball is the noise-free reading at the sample's time (the R-test's physics,
//! [`crate::Instrument`]), plus the head's seating on the ball at that visit (one draw per
//! visit, [`Realism::noise_sigma_um`], AR(1) with [`Realism::noise_phi`] along each ball's
//! visits in time order: the head does not sit twice the same), plus white sensor noise of
//! [`VolumetricPlan::stream_noise_um`] per sample, quantised to [`Realism::resolution_um`].
//!
//! # The per-visit session
//! One run per ball (`<ball>`, one row per visit in time order; a trunnion's ball is visited at
//! several rotary positions), the withheld cycle [`VolumetricPlan::validate_cycle`] as runs
//! `<ball>-c<k>` with `use = "validate"`; `t,<axes>,dx,dy,dz[,S][,T_<name>…]`. What the import
//! of the stream gives (docs/VOLUMETRIC.md): the plateau is a dwell's `d` samples; a visit's
//! time is its midpoint `(t_first + t_last)/2` (computed so; the dwell's midpoint
//! `t_a + dwell/2`), its reading the mean of the samples in the plateau's middle half,
//! `4·(t − t_first) ≥ L` and `4·(t_last − t) ≥ L`, `L = t_last − t_first` (samples
//! `d/4 … 3d/4 − 1`; the bounds fall a quarter of a period from the nearest samples, so no
//! rounding of the times can move them), the same noise realisation; its context the log
//! interpolated linearly to its time. The set-ups:
//! one per ball (`ball = [x, y, z]`, workpiece frame, `mount = "ball-on-table"`, the stated σ
//! [`Realism::manifest_sigma_factor`] times the seating σ, `range_um` when not 2000), each ball
//! off its stated position ([`Realism`]'s set-up draws); the one head's tool length error is
//! the same in every set-up. [`Realism::interval_s`], [`Realism::pause_s`] and
//! [`Realism::jitter_s`] are not used: the program gives the times.
//!
//! # The truth (`truth/`)
//! Besides `params.toml`, `errors.toml`, `setups.toml`, `effects.toml` and the noise-free runs
//! `<run>.csv` (the noise-free reading at the visit's time, the true context):
//! - `deformation.csv`, `t,point,ball,cycle,dx_um,dy_um,dz_um`: every visit in time order, the
//!   true deformation of its point, `d_j(t) = −(r_j(t) − r_j(t₀))` with `r` the noise-free
//!   reading (µm, machine directions: the nest's axes on a spindle that does not tilt; the head
//!   turning by θ, tens of µrad, tilts them by θ: parts in 10⁵ of the reading), `t₀` the
//!   point's first visit:
//!   the tool's displacement relative to the workpiece since then (docs/VOLUMETRIC.md);
//! - `field.csv`, the same columns: every point at each cycle's midpoint `t`, cycle by cycle —
//!   the deformation field at one instant, which the visits sample at different times of the
//!   cycle (`d_j(t)` as above: the noise-free reading at the point's commanded axes with the
//!   effects' state at `t`; an effect that follows the commanded sequence, such as lost
//!   motion, starts there from its first state);
//! - `volumetric.toml`: the schedule (cycle, period, phases between cycles), the withheld
//!   cycle, the sensor noise of the stream, and every point (ball, commanded axes).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::effects::{Effect, Resolved, Timeline, effects_toml};
use crate::error::SimError;
use crate::instruments::{Instrument, Mount, SetupPlan};
use crate::machine::{JointKind, Machine};
use crate::session::{
    Labels, Realism, Table, Written, WrittenRun, draw_offsets, relative_path, round_to, sensed,
    sidecar_setups, to_file_units, to_si, write_csv,
};
use crate::truth::Truth;

/// The stream's sample rate, Hz: times are whole ticks of 2 ms.
pub const STREAM_HZ: i64 = 500;
/// The R-test's measuring range by default, µm (the plugin's `range_um`).
pub const DEFAULT_RANGE_UM: f64 = 2000.0;
/// With approach ramps, the stream samples the last (first) this many µm beyond the range of a
/// plunge (rise) at 500 Hz.
const RAMP_BEYOND_UM: f64 = 500.0;

/// One ball of the test: a set-up of its own.
#[derive(Clone, Debug, PartialEq)]
pub struct VolumetricBall {
    pub name: String,
    /// Nominal centre, mm, workpiece frame.
    pub ball_mm: [f64; 3],
}

/// A point of the test: a ball at one commanded position of the rotary axes (the linear axes
/// put the nominal tool point on the ball).
#[derive(Clone, Debug, PartialEq)]
pub struct VolumetricPoint {
    /// Unique, without commas, quotes or spaces (`ball3@C120`).
    pub name: String,
    /// Index into [`VolumetricPlan::balls`].
    pub ball: usize,
    /// The rotary axes' commanded positions, degrees (axes not named stand at 0).
    pub rotary_deg: Vec<(char, f64)>,
}

/// How the stream shows the head off a ball.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OffBall {
    /// The sensors at their end stop: `range_um` in all three columns.
    EndStop,
    /// Empty cells.
    Empty,
}

/// What `stream/` holds ([module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct StreamOptions {
    pub off_ball: OffBall,
    /// The head's measuring range, µm (written as the set-ups' `range_um` when not 2000).
    pub range_um: f64,
    /// Sample the nest coming down onto the ball and leaving it at 500 Hz (readings on the ball
    /// that have not settled), instead of end-stop samples right before and after each dwell.
    pub approach_ramps: bool,
    /// Off a ball, one sample this often, s.
    pub off_ball_interval_s: f64,
}

impl Default for StreamOptions {
    /// End stop at 2000 µm, no ramps, a sample a second off the balls.
    fn default() -> Self {
        StreamOptions {
            off_ball: OffBall::EndStop,
            range_um: DEFAULT_RANGE_UM,
            approach_ramps: false,
            off_ball_interval_s: 1.0,
        }
    }
}

/// A volumetric thermal test on one machine ([module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct VolumetricPlan {
    pub machine_urdf: PathBuf,
    pub balls: Vec<VolumetricBall>,
    /// The points in the order a cycle visits them.
    pub points: Vec<VolumetricPoint>,
    /// Measuring cycles, ≥ 1 (≥ 2 with a withheld cycle).
    pub cycles: usize,
    /// The withheld cycle, 1-based: written as validation runs.
    pub validate_cycle: Option<usize>,
    pub feed_mm_per_min: f64,
    /// At each ball, s: a whole number of 8 ms.
    pub dwell_s: f64,
    /// From ball to ball the head passes this far above the higher of the two, mm along Z.
    pub clearance_mm: f64,
    /// The commanded Z at home, where the rotary axes turn and where the head waits between
    /// cycles, mm (above every ball).
    pub safe_z_mm: f64,
    /// The phase between two cycles, s (a whole number of log intervals).
    pub load_s: f64,
    /// The log's interval and the schedule's grid, s (a whole number of 2 ms).
    pub log_interval_s: f64,
    /// σ of the head's white sensor noise per stream sample, µm.
    pub stream_noise_um: f64,
    /// `None`: the per-visit session and the truth only (the same files as with a stream).
    pub stream: Option<StreamOptions>,
}

/// When the cycles and the phases between them are.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    /// One cycle, s: from home back to the safe height.
    pub cycle_s: f64,
    /// From one cycle's start to the next's, s.
    pub period_s: f64,
    pub cycle_start_s: Vec<f64>,
    /// The phase after each cycle but the last (load or rest): `(from, to)`, s.
    pub between_s: Vec<(f64, f64)>,
    /// The session's end: the last cycle's end rounded up to the log's grid, s.
    pub end_s: f64,
}

/// One visit of a ball, as written.
#[derive(Clone, Debug, PartialEq)]
pub struct Visit {
    /// 1-based.
    pub cycle: usize,
    pub point: String,
    pub ball: String,
    /// The run it is a row of.
    pub run: String,
    /// The dwell's midpoint, s.
    pub t: f64,
    /// The dwell, s.
    pub dwell_s: (f64, f64),
    /// Commanded axes, mm / degrees, machine order.
    pub positions: Vec<f64>,
    /// The noise-free reading at `t`, µm.
    pub clean_um: [f64; 3],
    /// The written reading (the stream's mean over the dwell's middle half), µm.
    pub written_um: [f64; 3],
    /// The true deformation `−(clean − clean at the point's first visit)`, µm.
    pub deformation_um: [f64; 3],
}

/// The true deformation of one point at one instant (`truth/field.csv`).
#[derive(Clone, Debug, PartialEq)]
pub struct FieldValue {
    /// The cycle's midpoint, s.
    pub t: f64,
    /// 1-based.
    pub cycle: usize,
    pub point: String,
    pub ball: String,
    /// `−(r(t) − r(t₀))`, µm, `t₀` the point's first visit.
    pub deformation_um: [f64; 3],
}

/// What [`write_volumetric`] wrote.
#[derive(Clone, Debug)]
pub struct VolumetricWritten {
    pub session: Written,
    pub schedule: Schedule,
    /// Every visit in time order.
    pub visits: Vec<Visit>,
    /// Every point at every cycle's midpoint, cycle by cycle in the points' order.
    pub field: Vec<FieldValue>,
    /// Rows of `stream/stream.csv` (0 without a stream).
    pub stream_rows: usize,
}

/// What a sample of the cycle is. Stream samples (`Off`, `Ramp`, `Dwell`) fall on odd
/// milliseconds, the program's instants (`Corner`, `Mid`) on even ones.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// A block's end: in the commanded sequence, not in the stream.
    Corner,
    /// Off a ball: the end stop.
    Off,
    /// The nest near point `p` in a plunge or a rise: the physics, end stop beyond the range.
    Ramp(usize),
    /// On point `p`, sample `j` of its dwell (0-based).
    Dwell(usize, i64),
    /// The midpoint of point `p`'s dwell: its noise-free reading is the visit's truth.
    Mid(usize),
}

/// A program block: a `G1` to these positions (file units), or a dwell at a point.
#[derive(Clone, Debug)]
enum Block {
    Move(Vec<f64>),
    Dwell(usize),
}

/// One cycle's samples relative to its start.
struct Cycle {
    /// Milliseconds since the cycle's start, strictly increasing.
    ms: Vec<i64>,
    /// Commanded positions, file units and SI.
    q_file: Vec<Vec<f64>>,
    q_si: Vec<Vec<f64>>,
    kinds: Vec<Kind>,
    /// Per point: the index of its dwell's first sample, and of its midpoint.
    dwell_at: Vec<usize>,
    mid_at: Vec<usize>,
    /// The cycle's last tick (at the safe height).
    end_tick: i64,
}

/// The checked plan, the program and one cycle's samples.
struct Prepared {
    blocks: Vec<Block>,
    home: Vec<f64>,
    cycle: Cycle,
    dwell_ticks: i64,
    grid_ticks: i64,
}

fn plan_error(message: impl Into<String>) -> SimError {
    SimError::Plan(message.into())
}

/// `s` seconds as whole ticks, or why not.
fn ticks_of(what: &str, s: f64, multiple_of: i64) -> Result<i64, SimError> {
    let ticks = s * STREAM_HZ as f64;
    let n = ticks.round();
    if !(s.is_finite() && (ticks - n).abs() < 1e-6 && (0.0..1e12).contains(&n)) {
        return Err(plan_error(format!(
            "{what} = {s} s: a whole number of {} ms expected",
            2 * multiple_of
        )));
    }
    let n = n as i64;
    if n % multiple_of != 0 {
        return Err(plan_error(format!(
            "{what} = {s} s: a whole number of {} ms expected",
            2 * multiple_of
        )));
    }
    Ok(n)
}

/// A tick's time, s.
fn time_of(n: i64) -> f64 {
    time_ms(n * TICK_MS)
}

/// Milliseconds as seconds: `ms/1000` rounded once, the value the decimal [`format_ms`]
/// writes reads back as.
fn time_ms(ms: i64) -> f64 {
    ms as f64 / 1000.0
}

/// Milliseconds as the stream writes them: seconds with three decimals, exactly.
fn format_ms(ms: i64) -> String {
    format!("{}.{:03}", ms / 1000, ms % 1000)
}

/// A tick in milliseconds.
const TICK_MS: i64 = 1000 / STREAM_HZ;

impl VolumetricPlan {
    fn check(&self) -> Result<(), SimError> {
        if self.balls.is_empty() || self.points.is_empty() {
            return Err(plan_error("a volumetric test needs balls and points"));
        }
        if self.cycles == 0 {
            return Err(plan_error("a volumetric test needs one cycle or more"));
        }
        if let Some(k) = self.validate_cycle
            && (k == 0 || k > self.cycles || self.cycles < 2)
        {
            return Err(plan_error(format!(
                "validate_cycle = {k}: a cycle 1..={} other than the only one",
                self.cycles
            )));
        }
        for (what, v) in [
            ("feed_mm_per_min", self.feed_mm_per_min),
            ("clearance_mm", self.clearance_mm),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(plan_error(format!(
                    "{what} = {v}: a positive number expected"
                )));
            }
        }
        if !(self.safe_z_mm.is_finite() && self.stream_noise_um.is_finite())
            || self.stream_noise_um < 0.0
        {
            return Err(plan_error(
                "safe_z_mm finite and stream_noise_um finite and ≥ 0 expected",
            ));
        }
        let mut names: Vec<&str> = self.balls.iter().map(|b| b.name.as_str()).collect();
        names.extend(self.points.iter().map(|p| p.name.as_str()));
        for b in &self.balls {
            if !plain_name(&b.name) || b.ball_mm.iter().any(|v| !v.is_finite()) {
                return Err(plan_error(format!(
                    "ball {:?}: a name of letters, digits, _ and - and a finite centre expected",
                    b.name
                )));
            }
        }
        for p in &self.points {
            let label = !p.name.is_empty()
                && !p
                    .name
                    .chars()
                    .any(|c| c == ',' || c == '"' || c.is_whitespace() || c.is_control());
            if p.ball >= self.balls.len() || !label {
                return Err(plan_error(format!(
                    "point {:?}: a name without commas, quotes or spaces and a ball of the plan \
                     expected",
                    p.name
                )));
            }
        }
        let mut sorted = self.points.iter().map(|p| &p.name).collect::<Vec<_>>();
        sorted.sort();
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            return Err(plan_error("two points have the same name"));
        }
        let mut balls = self.balls.iter().map(|b| &b.name).collect::<Vec<_>>();
        balls.sort();
        if balls.windows(2).any(|w| w[0] == w[1]) {
            return Err(plan_error("two balls have the same name"));
        }
        if let Some(s) = &self.stream
            && !(s.range_um.is_finite()
                && s.range_um > 0.0
                && s.off_ball_interval_s.is_finite()
                && s.off_ball_interval_s > 0.0)
        {
            return Err(plan_error(
                "stream: a positive range_um and off_ball_interval_s expected",
            ));
        }
        Ok(())
    }

    /// The program, its timing and one cycle's samples.
    fn prepare(&self, machine: &Machine, realism: &Realism) -> Result<Prepared, SimError> {
        self.check()?;
        let dwell_ticks = ticks_of("dwell_s", self.dwell_s, 4)?;
        if dwell_ticks == 0 {
            return Err(plan_error("dwell_s: a dwell of 8 ms or more expected"));
        }
        let grid_ticks = ticks_of("log_interval_s", self.log_interval_s, 1)?;
        if grid_ticks == 0 {
            return Err(plan_error("log_interval_s: a positive interval expected"));
        }
        let load_ticks = ticks_of("load_s", self.load_s, 1)?;
        if load_ticks % grid_ticks != 0 {
            return Err(plan_error(format!(
                "load_s = {}: a whole number of log intervals ({} s) expected",
                self.load_s, self.log_interval_s
            )));
        }
        let z = machine
            .index('Z')
            .filter(|&i| machine.joints[i].kind == JointKind::Linear)
            .ok_or_else(|| plan_error("a volumetric test needs a linear Z axis"))?;
        let n = machine.n_axes();
        // Each point's commanded axes: the rotary axes as given, the linear axes putting the
        // nominal tool point on the ball; written as the controller writes them.
        let mut points_q = Vec::with_capacity(self.points.len());
        for p in &self.points {
            let mut q = vec![0.0; n];
            for &(axis, deg) in &p.rotary_deg {
                let i = machine
                    .index(axis)
                    .filter(|&i| machine.joints[i].kind == JointKind::Rotary)
                    .ok_or_else(|| {
                        plan_error(format!("point {}: no rotary axis {axis}", p.name))
                    })?;
                q[i] = deg.to_radians();
            }
            let b = self.balls[p.ball].ball_mm;
            let target = Vector3::new(b[0], b[1], b[2]) * 1e-3;
            let q = machine.follow_point(&q, &Vector3::zeros(), &target)?;
            let file = to_file_units(machine, &[q], realism).remove(0);
            points_q.push(file);
        }
        let linear: Vec<bool> = machine
            .joints
            .iter()
            .map(|j| j.kind == JointKind::Linear)
            .collect();
        let mut home = vec![0.0; n];
        home[z] = self.safe_z_mm;
        let mut blocks = vec![Block::Move(home.clone())];
        let mut cur = home.clone();
        let mut on_ball = false;
        let push = |blocks: &mut Vec<Block>, cur: &mut Vec<f64>, to: Vec<f64>| {
            if *cur != to {
                blocks.push(Block::Move(to.clone()));
                *cur = to;
            }
        };
        for (k, target) in points_q.iter().enumerate() {
            let turns = (0..n).any(|i| !linear[i] && cur[i] != target[i]);
            let height = if turns {
                self.safe_z_mm.max(cur[z])
            } else {
                let from = if on_ball {
                    cur[z] + self.clearance_mm
                } else {
                    cur[z]
                };
                from.max(target[z] + self.clearance_mm)
            };
            let mut up = cur.clone();
            up[z] = height;
            push(&mut blocks, &mut cur, up);
            if turns {
                let mut turned = cur.clone();
                for i in (0..n).filter(|&i| !linear[i]) {
                    turned[i] = target[i];
                }
                push(&mut blocks, &mut cur, turned);
            }
            let mut over = target.clone();
            over[z] = height;
            push(&mut blocks, &mut cur, over);
            push(&mut blocks, &mut cur, target.clone());
            blocks.push(Block::Dwell(k));
            on_ball = true;
        }
        let mut up = cur.clone();
        up[z] = self.safe_z_mm.max(cur[z]);
        push(&mut blocks, &mut cur, up);
        for b in &blocks {
            if let Block::Move(q) = b
                && !machine.within_limits(&to_si(machine, std::slice::from_ref(q))[0], 1e-9)
            {
                return Err(plan_error(format!(
                    "the program leaves the axis limits at {q:?} (mm / degrees)"
                )));
            }
        }
        let cycle = self.cycle_samples(machine, &blocks, &home, &linear, z, dwell_ticks)?;
        Ok(Prepared {
            blocks,
            home,
            cycle,
            dwell_ticks,
            grid_ticks,
        })
    }

    /// The samples of one cycle ([module docs](self)): the program's instants on the ticks
    /// (even ms), the head's samples half a tick after them (odd ms).
    fn cycle_samples(
        &self,
        machine: &Machine,
        blocks: &[Block],
        home: &[f64],
        linear: &[bool],
        z: usize,
        dwell_ticks: i64,
    ) -> Result<Cycle, SimError> {
        let per_tick_mm = self.feed_mm_per_min / 60.0 / STREAM_HZ as f64;
        let stream = self.stream.clone().unwrap_or_default();
        let every = (stream.off_ball_interval_s * STREAM_HZ as f64)
            .round()
            .max(1.0) as i64;
        // The ramps sample the nest within the range (and a little beyond) of the ball.
        let ramp_ticks = ((stream.range_um + RAMP_BEYOND_UM) * 1e-3 / per_tick_mm).ceil() as i64;
        // The sample in tick `k`'s interval, and the instant of tick `k`.
        let sample = |k: i64| TICK_MS * k + TICK_MS / 2;
        let instant = |k: i64| TICK_MS * k;
        let mut out: Vec<(i64, Vec<f64>, Kind)> = vec![
            (instant(0), home.to_vec(), Kind::Corner),
            (sample(0), home.to_vec(), Kind::Off),
        ];
        let mut dwell_at = vec![usize::MAX; self.points.len()];
        let mut mid_at = vec![usize::MAX; self.points.len()];
        let mut now = 0i64;
        let mut cur = home.to_vec();
        for (b, block) in blocks.iter().enumerate() {
            match block {
                Block::Dwell(p) => {
                    // From the arrival at tick `now` to the departure `dwell_ticks` later: the
                    // head's samples in between, and the midpoint among them.
                    dwell_at[*p] = out.len();
                    for j in 0..dwell_ticks {
                        if j == dwell_ticks / 2 {
                            mid_at[*p] = out.len();
                            let mid = instant(now) + TICK_MS * dwell_ticks / 2;
                            out.push((mid, cur.clone(), Kind::Mid(*p)));
                        }
                        out.push((sample(now + j), cur.clone(), Kind::Dwell(*p, j)));
                    }
                    now += dwell_ticks;
                    out.push((instant(now), cur.clone(), Kind::Corner));
                }
                Block::Move(to) => {
                    let length = if (0..cur.len()).any(|i| linear[i] && cur[i] != to[i]) {
                        (0..cur.len())
                            .filter(|&i| linear[i])
                            .map(|i| (to[i] - cur[i]).powi(2))
                            .sum::<f64>()
                            .sqrt()
                    } else {
                        (0..cur.len())
                            .filter(|&i| !linear[i])
                            .map(|i| (to[i] - cur[i]).abs())
                            .fold(0.0, f64::max)
                    };
                    let steps = (length / per_tick_mm - 1e-9).ceil().max(0.0) as i64;
                    if steps == 0 {
                        cur = to.clone();
                        continue;
                    }
                    let (n0, n1) = (now, now + steps);
                    // The commanded position half a tick into tick `k`.
                    let at = |k: i64| -> Vec<f64> {
                        let w = ((k - n0) as f64 + 0.5) / steps as f64;
                        cur.iter().zip(to).map(|(a, b)| a + (b - a) * w).collect()
                    };
                    // The point this move plunges onto, or rises from.
                    let next = match blocks.get(b + 1) {
                        Some(Block::Dwell(p)) => Some(*p),
                        _ => None,
                    };
                    let last = match b.checked_sub(1).map(|i| &blocks[i]) {
                        Some(Block::Dwell(p)) => Some(*p),
                        _ => None,
                    };
                    // Ticks whose sample is in the stream, by kind.
                    let mut ticks: Vec<(i64, Kind)> = Vec::new();
                    let mut k = n0 + every;
                    while k < n1 {
                        ticks.push((k, Kind::Off));
                        k += every;
                    }
                    if stream.approach_ramps {
                        if let Some(p) = last {
                            for k in n0..(n0 + ramp_ticks).min(n1) {
                                ticks.push((k, Kind::Ramp(p)));
                            }
                        }
                        if let Some(p) = next {
                            for k in (n1 - ramp_ticks).max(n0)..n1 {
                                ticks.push((k, Kind::Ramp(p)));
                            }
                        }
                    } else {
                        // Off the ball right after the departure and right before the arrival.
                        if last.is_some() {
                            ticks.push((n0, Kind::Off));
                        }
                        if next.is_some() {
                            ticks.push((n1 - 1, Kind::Off));
                        }
                    }
                    // In time order, a ramp sample winning over an off-ball one at its tick.
                    ticks.sort_by_key(|&(k, kind)| (k, matches!(kind, Kind::Off)));
                    ticks.dedup_by_key(|&mut (k, _)| k);
                    for (k, kind) in ticks {
                        out.push((sample(k), at(k), kind));
                    }
                    out.push((instant(n1), to.clone(), Kind::Corner));
                    // Only Z moves in a plunge or a rise: the ramps above are along Z.
                    debug_assert!(
                        next.is_none() || (0..cur.len()).all(|i| i == z || cur[i] == to[i])
                    );
                    cur = to.clone();
                    now = n1;
                }
            }
        }
        if dwell_at.contains(&usize::MAX) || mid_at.contains(&usize::MAX) {
            return Err(plan_error("a point of the plan is not in its program"));
        }
        if out.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(plan_error("the cycle's samples are not in time order"));
        }
        let q_file: Vec<Vec<f64>> = out.iter().map(|s| s.1.clone()).collect();
        Ok(Cycle {
            ms: out.iter().map(|s| s.0).collect(),
            q_si: to_si(machine, &q_file),
            q_file,
            kinds: out.iter().map(|s| s.2).collect(),
            dwell_at,
            mid_at,
            end_tick: now,
        })
    }

    /// When the cycles and the phases between them are, for `machine` and `realism`'s
    /// position rounding ([module docs](self)).
    pub fn schedule(&self, machine: &Machine, realism: &Realism) -> Result<Schedule, SimError> {
        Ok(self.prepare(machine, realism)?.schedule(self))
    }
}

impl Prepared {
    fn schedule(&self, plan: &VolumetricPlan) -> Schedule {
        let g = self.grid_ticks;
        let end = self.cycle.end_tick;
        let rounded = (end + g - 1) / g * g;
        let load_from = rounded + g;
        let load = (plan.load_s * STREAM_HZ as f64).round() as i64;
        let period = load_from + load;
        let starts: Vec<i64> = (0..plan.cycles as i64).map(|k| k * period).collect();
        Schedule {
            cycle_s: time_of(end),
            period_s: time_of(period),
            cycle_start_s: starts.iter().map(|&s| time_of(s)).collect(),
            between_s: starts
                .iter()
                .take(plan.cycles.saturating_sub(1))
                .map(|&s| (time_of(s + load_from), time_of(s + period)))
                .collect(),
            end_s: time_of(starts.last().copied().unwrap_or(0) + rounded),
        }
    }
}

/// A name usable as a run, set-up and file name: letters, digits, `_` and `-`.
fn plain_name(s: &str) -> bool {
    !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// The AR(1) seating noise of each ball along its visits.
struct Seating {
    sigma_um: f64,
    phi: f64,
    state: Vec<Option<[f64; 3]>>,
}

impl Seating {
    fn next(&mut self, ball: usize, n: [f64; 3]) -> [f64; 3] {
        let (s, phi) = (self.sigma_um, self.phi);
        let e = match self.state[ball] {
            None => n.map(|v| s * v),
            Some(prev) => [0, 1, 2].map(|c| phi * prev[c] + (1.0 - phi * phi).sqrt() * s * n[c]),
        };
        self.state[ball] = Some(e);
        e
    }
}

/// A stream value quantised as [`Realism::resolution_um`] says. A resolution of a whole
/// fraction of a µm (0.1, 0.01) divides whole counts by the fraction's inverse, so that the
/// value is the double nearest the decimal the head shows (`1.2`, not `1.2000000000000002`).
fn quantised(v: f64, realism: &Realism) -> f64 {
    let step = realism.resolution_um;
    if step <= 0.0 {
        return v;
    }
    let per_um = (1.0 / step).round();
    if per_um >= 1.0 && (per_um * step - 1.0).abs() < 1e-12 {
        (v * per_um).round() / per_um
    } else {
        round_to(v, step)
    }
}

/// The stream's file, written as the samples come.
struct StreamFile {
    out: std::io::BufWriter<std::fs::File>,
    options: StreamOptions,
    rows: usize,
}

impl StreamFile {
    fn row(&mut self, ms: i64, reading: Option<[f64; 3]>) -> std::io::Result<()> {
        self.rows += 1;
        let t = format_ms(ms);
        match (reading, self.options.off_ball) {
            (Some([x, y, z]), _) => writeln!(self.out, "{t},{x},{y},{z}"),
            (None, OffBall::EndStop) => {
                let r = self.options.range_um;
                writeln!(self.out, "{t},{r},{r},{r}")
            }
            (None, OffBall::Empty) => writeln!(self.out, "{t},,,"),
        }
    }
}

/// A visit while the cycles run: what the files need of it.
struct Pending {
    cycle: usize,
    point: usize,
    /// The arrival on the ball, ms.
    arrival_ms: i64,
    /// The plateau's midpoint as its first and last samples give it, s.
    t: f64,
    clean_mid_um: [f64; 3],
    mean_um: [f64; 3],
}

/// Writes the volumetric thermal test `plan` on `machine` with the geometric errors `truth`
/// and `effects` ([`crate::effects`]; built for [`VolumetricPlan::schedule`]'s phases) into
/// `dir` (created): the per-visit session, `stream/` when the plan asks for it, and `truth/`
/// ([module docs](self)). The random draws are `realism`'s: the set-ups and the seating from
/// its seed, the sensors from their own stream as [`crate::write_session`] draws them, the
/// stream's sensor noise from a third.
///
/// A bad plan or effect (an unknown axis, a point off the axis limits, a dwell that is not a
/// whole number of 8 ms…) is a [`SimError::Plan`] and nothing is written.
pub fn write_volumetric(
    dir: &Path,
    machine: &Machine,
    truth: &Truth,
    plan: &VolumetricPlan,
    effects: &[Effect],
    realism: &Realism,
) -> Result<VolumetricWritten, SimError> {
    let prepared = plan.prepare(machine, realism)?;
    let schedule = prepared.schedule(plan);
    let range_um = plan
        .stream
        .as_ref()
        .map_or(DEFAULT_RANGE_UM, |s| s.range_um);
    let setups: Vec<SetupPlan> = plan
        .balls
        .iter()
        .map(|b| SetupPlan {
            name: b.name.clone(),
            instrument: Instrument::RTest {
                ball_mm: b.ball_mm,
                mount: Mount::BallOnTable,
                write_mount_key: true,
            },
        })
        .collect();
    let resolved = Resolved::new(machine, &setups, effects)?;
    std::fs::create_dir_all(dir.join("truth"))?;

    let mut rng = ChaCha8Rng::seed_from_u64(realism.seed);
    let mut offsets = draw_offsets(&setups, realism, &mut rng);
    // One head in the spindle: one tool length for every ball.
    let tool_length = offsets.first().map_or(0.0, |o| o.1.tool_length);
    for (_, o) in &mut offsets {
        o.tool_length = tool_length;
    }
    let mut sensor_rng = ChaCha8Rng::seed_from_u64(realism.seed);
    sensor_rng.set_stream(1);
    let mut fast_rng = ChaCha8Rng::seed_from_u64(realism.seed);
    fast_rng.set_stream(3);
    let mut ramp_rng = ChaCha8Rng::seed_from_u64(realism.seed);
    ramp_rng.set_stream(4);
    let mut seating = Seating {
        sigma_um: realism.noise_sigma_um,
        phi: realism.noise_phi,
        state: vec![None; plan.balls.len()],
    };

    let mut stream = match &plan.stream {
        Some(options) => {
            std::fs::create_dir_all(dir.join("stream"))?;
            let file = std::fs::File::create(dir.join("stream/stream.csv"))?;
            let mut out = std::io::BufWriter::new(file);
            writeln!(out, "t,dx,dy,dz")?;
            Some(StreamFile {
                out,
                options: options.clone(),
                rows: 0,
            })
        }
        None => None,
    };

    let cycle = &prepared.cycle;
    let instruments: Vec<&Instrument> = setups.iter().map(|s| &s.instrument).collect();
    let d = prepared.dwell_ticks;
    let home_si = to_si(machine, std::slice::from_ref(&prepared.home)).remove(0);
    let every = plan.stream.as_ref().map_or(STREAM_HZ, |s| {
        (s.off_ball_interval_s * STREAM_HZ as f64).round().max(1.0) as i64
    });
    let mut timeline = Timeline::new(&resolved);
    let mut pending: Vec<Pending> = Vec::new();
    let start_ticks: Vec<i64> = schedule
        .cycle_start_s
        .iter()
        .map(|&s| (s * STREAM_HZ as f64).round() as i64)
        .collect();
    for (c, &base_tick) in start_ticks.iter().enumerate() {
        let base = base_tick * TICK_MS;
        let times: Vec<f64> = cycle.ms.iter().map(|&m| time_ms(base + m)).collect();
        let states = timeline.run(&cycle.q_si, &times);
        // Readings on (or near) a ball, by sample; `None` off the balls.
        let mut read: Vec<Option<[f64; 3]>> = vec![None; cycle.ms.len()];
        let mut clean_at: Vec<[f64; 3]> = vec![[0.0; 3]; cycle.ms.len()];
        let visit_noise: Vec<[f64; 3]> = plan
            .points
            .iter()
            .map(|point| {
                let n: [f64; 3] = [0; 3].map(|_| StandardNormal.sample(&mut rng));
                seating.next(point.ball, n)
            })
            .collect();
        for (k, kind) in cycle.kinds.iter().enumerate() {
            let p = match kind {
                Kind::Corner | Kind::Off => continue,
                Kind::Ramp(p) | Kind::Dwell(p, _) | Kind::Mid(p) => *p,
            };
            let ball = plan.points[p].ball;
            let r = instruments[ball].readings(
                machine,
                truth,
                &cycle.q_si[k..=k],
                &[],
                &offsets[ball].1,
                &states[k..=k],
            );
            let clean = [r[0][0] * 1e6, r[0][1] * 1e6, r[0][2] * 1e6];
            clean_at[k] = clean;
            if let Kind::Mid(_) = kind {
                continue;
            }
            // The dwells' draws apart from the ramps': the visits read the same with or
            // without ramps.
            let noise_rng = match kind {
                Kind::Dwell(..) => &mut fast_rng,
                _ => &mut ramp_rng,
            };
            let fast: [f64; 3] = [0; 3].map(|_| {
                let n: f64 = StandardNormal.sample(noise_rng);
                n * plan.stream_noise_um
            });
            let seat = visit_noise[p];
            let value = [0, 1, 2].map(|i| quantised(clean[i] + seat[i] + fast[i], realism));
            let beyond = |v: &[f64; 3]| v.iter().any(|x| x.abs() >= range_um);
            if !(beyond(&clean) || beyond(&value)) {
                read[k] = Some(value);
            }
        }
        for (p, &at) in cycle.dwell_at.iter().enumerate() {
            let mut sum = [0.0; 3];
            let mut count = 0usize;
            // The dwell's `d` samples (and its midpoint among them); the middle half by time,
            // `4·(t − t_first) ≥ L` and `4·(t_last − t) ≥ L` with `L = (d − 1)` ticks, is
            // samples `d/4 ..= 3d/4 − 1` (the bounds fall a quarter of a tick from them).
            let own = at..=at + d as usize;
            let middle = own.filter_map(|k| match cycle.kinds[k] {
                Kind::Dwell(_, j) if j >= d / 4 && j < 3 * d / 4 => Some(read[k]),
                _ => None,
            });
            for v in middle {
                let v = v.ok_or_else(|| {
                    plan_error(format!(
                        "point {}: a reading beyond the head's range ({range_um} µm) in its dwell",
                        plan.points[p].name
                    ))
                })?;
                for i in 0..3 {
                    sum[i] += v[i];
                }
                count += 1;
            }
            // The plateau's midpoint as an import computes it from the first and last
            // samples' times (the dwell's midpoint, up to the last bit).
            let first = time_ms(base + cycle.ms[at]);
            let last = time_ms(base + cycle.ms[at + d as usize]);
            pending.push(Pending {
                cycle: c + 1,
                point: p,
                arrival_ms: base + cycle.ms[at] - TICK_MS / 2,
                t: 0.5 * (first + last),
                clean_mid_um: clean_at[cycle.mid_at[p]],
                mean_um: sum.map(|s| s / count as f64),
            });
        }
        if let Some(s) = &mut stream {
            for (k, &m) in cycle.ms.iter().enumerate() {
                if !matches!(cycle.kinds[k], Kind::Corner | Kind::Mid(_)) {
                    s.row(base + m, read[k])?;
                }
            }
        }
        // The machine waits at home until the next cycle: off the balls.
        let next = start_ticks
            .get(c + 1)
            .copied()
            .unwrap_or(base_tick + cycle.end_tick);
        let mut waiting = Vec::new();
        let mut k = base_tick + cycle.end_tick + every;
        while k < next {
            waiting.push(k * TICK_MS + TICK_MS / 2);
            k += every;
        }
        if !waiting.is_empty() {
            let poses = vec![home_si.clone(); waiting.len()];
            let times: Vec<f64> = waiting.iter().map(|&m| time_ms(m)).collect();
            timeline.run(&poses, &times);
            if let Some(s) = &mut stream {
                for &m in &waiting {
                    s.row(m, None)?;
                }
            }
        }
    }
    pending.sort_by_key(|v| v.arrival_ms);

    // The log, and the visits' context as its import gives it.
    let g = prepared.grid_ticks;
    let end_tick = (schedule.end_s * STREAM_HZ as f64).round() as i64;
    let log_times: Vec<f64> = (0..=end_tick / g).map(|k| time_of(k * g)).collect();
    let any_setup = setups[0].name.as_str();
    let true_log = resolved.context(any_setup, &log_times);
    let log = sensed(&true_log, realism, &mut sensor_rng);
    let visit_t: Vec<f64> = pending.iter().map(|v| v.t).collect();
    let interpolated: Vec<(String, Vec<f64>)> = log
        .iter()
        .map(|(name, values)| {
            let at = visit_t
                .iter()
                .map(|&t| {
                    let step = plan.log_interval_s;
                    let k = ((t / step).floor() as usize).min(values.len().saturating_sub(2));
                    let w = (t - log_times[k]) / step;
                    let (a, b) = (values[k], values.get(k + 1).copied().unwrap_or(values[k]));
                    a + w * (b - a)
                })
                .collect();
            (name.clone(), at)
        })
        .collect();
    let true_at_visits = resolved.context(any_setup, &visit_t);

    // The visits as written, with their deformations.
    let mut first: Vec<Option<[f64; 3]>> = vec![None; plan.points.len()];
    let run_of = |v: &Pending| {
        let ball = &plan.balls[plan.points[v.point].ball].name;
        if plan.validate_cycle == Some(v.cycle) {
            format!("{ball}-c{}", v.cycle)
        } else {
            ball.clone()
        }
    };
    let visits: Vec<Visit> = pending
        .iter()
        .zip(&visit_t)
        .map(|(v, &t)| {
            let p = &plan.points[v.point];
            let zero = *first[v.point].get_or_insert(v.clean_mid_um);
            let at = cycle.dwell_at[v.point];
            Visit {
                cycle: v.cycle,
                point: p.name.clone(),
                ball: plan.balls[p.ball].name.clone(),
                run: run_of(v),
                t,
                dwell_s: (time_ms(v.arrival_ms), time_ms(v.arrival_ms + d * TICK_MS)),
                positions: cycle.q_file[at].clone(),
                clean_um: v.clean_mid_um,
                written_um: v.mean_um,
                deformation_um: [0, 1, 2].map(|i| zero[i] - v.clean_mid_um[i]),
            }
        })
        .collect();

    // The field: every point at each cycle's midpoint, as if the head were on it then.
    let mut field = Vec::with_capacity(plan.cycles * plan.points.len());
    for (c, &base) in start_ticks.iter().enumerate() {
        let t = time_of(base + cycle.end_tick / 2);
        for (p, point) in plan.points.iter().enumerate() {
            let q = &cycle.q_si[cycle.dwell_at[p]];
            let mut fresh = Timeline::new(&resolved);
            let states = fresh.run(std::slice::from_ref(q), &[t]);
            let r = instruments[point.ball].readings(
                machine,
                truth,
                std::slice::from_ref(q),
                &[],
                &offsets[point.ball].1,
                states.as_slice(),
            );
            let zero = first[p].unwrap_or([0.0; 3]);
            field.push(FieldValue {
                t,
                cycle: c + 1,
                point: point.name.clone(),
                ball: plan.balls[point.ball].name.clone(),
                deformation_um: [0, 1, 2].map(|i| zero[i] - r[0][i] * 1e6),
            });
        }
    }

    // The runs: one per ball, then the withheld cycle's.
    let mut run_names: Vec<(String, usize, bool)> = plan
        .balls
        .iter()
        .enumerate()
        .map(|(b, ball)| (ball.name.clone(), b, false))
        .collect();
    if let Some(k) = plan.validate_cycle {
        run_names.extend(
            plan.balls
                .iter()
                .enumerate()
                .map(|(b, ball)| (format!("{}-c{k}", ball.name), b, true)),
        );
    }
    let letters: Vec<char> = machine.letters().chars().collect();
    let channels: Vec<String> = ["dx", "dy", "dz"].map(String::from).to_vec();
    let labels = Labels {
        columns: &[],
        values: &[],
    };
    let stated_sigma = (realism.noise_sigma_um > 0.0)
        .then_some(realism.noise_sigma_um * realism.manifest_sigma_factor);
    let mut manifest = String::from(
        "# Written by mtcal-indsim, an independent simulator: a volumetric thermal test \
         (docs/VOLUMETRIC.md; ground truth in truth/).\n",
    );
    let rel = relative_path(dir, &plan.machine_urdf)?;
    writeln!(manifest, "machine = \"{}\"", rel.display()).expect("string");
    for s in &setups {
        write!(
            manifest,
            "\n[setup.{}]\n{}",
            s.name,
            s.instrument.setup_toml(stated_sigma)
        )
        .expect("string");
        if range_um != DEFAULT_RANGE_UM {
            writeln!(manifest, "range_um = {range_um:?}").expect("string");
        }
    }
    let mut runs = Vec::new();
    for (name, ball, validate) in &run_names {
        let rows: Vec<usize> = (0..visits.len())
            .filter(|&i| &visits[i].run == name)
            .collect();
        if rows.is_empty() {
            continue;
        }
        let pick = |col: &[f64]| rows.iter().map(|&i| col[i]).collect::<Vec<f64>>();
        let t: Vec<f64> = rows.iter().map(|&i| visits[i].t).collect();
        let positions: Vec<Vec<f64>> = rows.iter().map(|&i| visits[i].positions.clone()).collect();
        let clean_um: Vec<Vec<f64>> = rows.iter().map(|&i| visits[i].clean_um.to_vec()).collect();
        let written_um: Vec<Vec<f64>> = rows
            .iter()
            .map(|&i| visits[i].written_um.to_vec())
            .collect();
        let context: Vec<(String, Vec<f64>)> = interpolated
            .iter()
            .map(|(n, v)| (n.clone(), pick(v)))
            .collect();
        let clean_context: Vec<(String, Vec<f64>)> = true_at_visits
            .iter()
            .map(|c| (c.name.clone(), pick(&c.values)))
            .collect();
        let file = PathBuf::from(format!("{name}.csv"));
        let table = |readings, context| Table {
            letters: &letters,
            channels: &channels,
            labels: &labels,
            t: &t,
            positions: &positions,
            readings,
            context,
        };
        write_csv(&dir.join(&file), &table(&written_um, &context))?;
        write_csv(
            &dir.join("truth").join(&file),
            &table(&clean_um, &clean_context),
        )?;
        let setup = &plan.balls[*ball].name;
        write!(
            manifest,
            "\n[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nfile = \"{}\"\nsetup = \"{setup}\"\n",
            file.display()
        )
        .expect("string");
        if *validate {
            manifest.push_str("use = \"validate\"\n");
        }
        runs.push(WrittenRun {
            name: name.clone(),
            setup: setup.clone(),
            file,
            t,
            positions,
            clean_um,
            written_um,
            context,
        });
    }

    let mut stream_rows = 0;
    if let Some(mut s) = stream {
        s.out.flush()?;
        stream_rows = s.rows;
        std::fs::write(
            dir.join("stream/cycle.nc"),
            program_text(machine, plan, &prepared.blocks, realism),
        )?;
        std::fs::write(dir.join("stream/log.csv"), log_text(&log_times, &log))?;
    }
    std::fs::write(dir.join("session.toml"), manifest)?;
    std::fs::write(dir.join("truth/params.toml"), truth.params_toml(machine))?;
    std::fs::write(dir.join("truth/errors.toml"), truth.model_config(machine))?;
    std::fs::write(
        dir.join("truth/setups.toml"),
        sidecar_setups(&offsets, realism),
    )?;
    if !effects.is_empty() {
        std::fs::write(
            dir.join("truth/effects.toml"),
            effects_toml(machine, effects),
        )?;
    }
    std::fs::write(dir.join("truth/deformation.csv"), deformation_text(&visits))?;
    std::fs::write(dir.join("truth/field.csv"), field_text(&field))?;
    std::fs::write(
        dir.join("truth/volumetric.toml"),
        volumetric_toml(machine, plan, &schedule, &prepared),
    )?;
    Ok(VolumetricWritten {
        session: Written {
            dir: dir.to_path_buf(),
            truth: truth.clone(),
            offsets,
            runs,
        },
        schedule,
        visits,
        field,
        stream_rows,
    })
}

/// A commanded position as the program writes it: the controller's decimals, or every digit.
fn word(v: f64, realism: &Realism) -> String {
    match realism.position_decimals {
        Some(d) if d >= 0 => format!("{v:.*}", d as usize),
        _ => format!("{v}"),
    }
}

/// `stream/cycle.nc`.
fn program_text(
    machine: &Machine,
    plan: &VolumetricPlan,
    blocks: &[Block],
    realism: &Realism,
) -> String {
    let letters: Vec<char> = machine.letters().chars().collect();
    let mut s = String::new();
    writeln!(
        s,
        "(mtcal-indsim: one measuring cycle of a volumetric thermal test, {} ball visits)\n\
         (G1 at F{} mm/min, a dwell of {} s on each ball; positions in mm and degrees)\n\
         G90",
        plan.points.len(),
        plan.feed_mm_per_min,
        plan.dwell_s
    )
    .expect("string");
    let mut cur: Option<&Vec<f64>> = None;
    let mut n = 10;
    for b in blocks {
        match b {
            Block::Move(q) => {
                let mut line = format!("N{n} G1");
                for (i, l) in letters.iter().enumerate() {
                    if cur.is_none_or(|c| c[i] != q[i]) {
                        write!(line, " {l}{}", word(q[i], realism)).expect("string");
                    }
                }
                if cur.is_none() {
                    write!(line, " F{}", plan.feed_mm_per_min).expect("string");
                }
                writeln!(s, "{line}").expect("string");
                cur = Some(q);
            }
            Block::Dwell(p) => {
                let point = &plan.points[*p];
                writeln!(
                    s,
                    "N{n} G4 P{} ({} {})",
                    plan.dwell_s, plan.balls[point.ball].name, point.name
                )
                .expect("string");
            }
        }
        n += 10;
    }
    writeln!(s, "N{n} M30").expect("string");
    s
}

/// `stream/log.csv`.
fn log_text(times: &[f64], log: &[(String, Vec<f64>)]) -> String {
    let mut s = String::from("t");
    for (name, _) in log {
        write!(s, ",{name}").expect("string");
    }
    s.push('\n');
    for (k, t) in times.iter().enumerate() {
        write!(s, "{t}").expect("string");
        for (_, v) in log {
            write!(s, ",{}", v[k]).expect("string");
        }
        s.push('\n');
    }
    s
}

/// `truth/deformation.csv`.
fn deformation_text(visits: &[Visit]) -> String {
    let mut s = String::from("t,point,ball,cycle,dx_um,dy_um,dz_um\n");
    for v in visits {
        let [x, y, z] = v.deformation_um;
        writeln!(s, "{},{},{},{},{x},{y},{z}", v.t, v.point, v.ball, v.cycle).expect("string");
    }
    s
}

/// `truth/field.csv`.
fn field_text(field: &[FieldValue]) -> String {
    let mut s = String::from("t,point,ball,cycle,dx_um,dy_um,dz_um\n");
    for f in field {
        let [x, y, z] = f.deformation_um;
        writeln!(s, "{},{},{},{},{x},{y},{z}", f.t, f.point, f.ball, f.cycle).expect("string");
    }
    s
}

/// `truth/volumetric.toml`.
fn volumetric_toml(
    machine: &Machine,
    plan: &VolumetricPlan,
    schedule: &Schedule,
    prepared: &Prepared,
) -> String {
    let mut root = toml::Table::new();
    let floats = |v: &[f64]| toml::Value::Array(v.iter().map(|&x| x.into()).collect());
    root.insert("cycles".into(), (plan.cycles as i64).into());
    if let Some(k) = plan.validate_cycle {
        root.insert("validate_cycle".into(), (k as i64).into());
    }
    root.insert("cycle_s".into(), schedule.cycle_s.into());
    root.insert("period_s".into(), schedule.period_s.into());
    root.insert("dwell_s".into(), plan.dwell_s.into());
    root.insert("feed_mm_per_min".into(), plan.feed_mm_per_min.into());
    root.insert("log_interval_s".into(), plan.log_interval_s.into());
    root.insert("stream_noise_um".into(), plan.stream_noise_um.into());
    root.insert("cycle_start_s".into(), floats(&schedule.cycle_start_s));
    root.insert(
        "between_s".into(),
        toml::Value::Array(
            schedule
                .between_s
                .iter()
                .map(|&(a, b)| floats(&[a, b]))
                .collect(),
        ),
    );
    root.insert("end_s".into(), schedule.end_s.into());
    root.insert(
        "axes".into(),
        toml::Value::Array(
            machine
                .letters()
                .chars()
                .map(|c| c.to_string().into())
                .collect(),
        ),
    );
    let points = plan
        .points
        .iter()
        .enumerate()
        .map(|(p, point)| {
            let mut t = toml::Table::new();
            t.insert("name".into(), point.name.clone().into());
            t.insert("ball".into(), plan.balls[point.ball].name.clone().into());
            t.insert(
                "commanded".into(),
                floats(&prepared.cycle.q_file[prepared.cycle.dwell_at[p]]),
            );
            toml::Value::Table(t)
        })
        .collect();
    root.insert("point".into(), toml::Value::Array(points));
    format!(
        "# The volumetric thermal test's schedule and points (written by mtcal-indsim; times in \
         s, commanded axes in mm / degrees in the order of `axes`).\n{root}"
    )
}
