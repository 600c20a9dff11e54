//! The effects' state sample by sample: the commanded motion of every axis (which way, how far
//! since it reversed), the dead bands, lateral play and stick-slip, and the actual pose each gives.

use super::*;

/// The effects' state at one sample: what turns a commanded pose into the actual one.
#[derive(Clone, Debug)]
pub(crate) struct SampleState<'a> {
    pub(super) effects: &'a Resolved,
    /// Per backlash effect: actual minus commanded position, as the dead band left it here.
    pub(super) lost: Vec<f64>,
    /// Per servo lag: the command `T` earlier minus the command now.
    pub(super) trail: Vec<f64>,
    /// Per thermal scale: `α·(T(t) − T(0))`.
    pub(super) strain: Vec<f64>,
    /// The spindle head's thermal growth, machine frame, m.
    pub(super) growth: Vector3<f64>,
    /// Per worn lost motion, per reversal spike, per stick-slip: actual minus commanded
    /// position.
    pub(super) worn: Vec<f64>,
    pub(super) spike: Vec<f64>,
    pub(super) stick: Vec<f64>,
    /// The carriages' displacement across their guideways, machine frame, m.
    pub(super) lateral: Vector3<f64>,
    /// The spindle's growth along the tool axis (out of the spindle), m.
    pub(super) spindle: f64,
    /// The structure's uniform displacement after ambient steps, machine frame, m.
    pub(super) air: Vector3<f64>,
    /// The head's turn about its lines, `H = H_1·H_2·…` (`None`: no head rotation).
    pub(super) head: Option<Matrix4<f64>>,
    /// The axis lines' changes: `(axis, direction, m or rad)`.
    pub(super) lines: Vec<(usize, usize, f64)>,
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
pub(super) const STILL: f64 = 1e-9;

/// The commanded motion of one axis along the session: which way it last moved, how far it
/// has travelled since it last reversed, and when that was.
#[derive(Clone, Debug)]
pub(super) struct Travel {
    /// The command where the axis last moved (`None`: before the session's first sample).
    pub(super) last: Option<f64>,
    /// The time of the previous sample, s.
    pub(super) last_t: f64,
    /// +1 or −1: the direction of the last move (+1 before any: approached from below).
    pub(super) sense: f64,
    /// Commanded travel since the last reversal (infinite before the first).
    pub(super) since: f64,
    /// When the last reversal happened, s (the time of the last sample at the turning point).
    pub(super) reversed_at: Option<f64>,
}

impl Travel {
    pub(super) fn new() -> Self {
        Travel {
            last: None,
            last_t: 0.0,
            sense: 1.0,
            since: f64::INFINITY,
            reversed_at: None,
        }
    }

    /// Moves to command `c` at time `t`; whether the axis reversed on the way.
    pub(super) fn to(&mut self, c: f64, t: f64) -> bool {
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
    pub(super) effects: &'a Resolved,
    /// Per backlash effect: the axis' actual position after the last sample (`None`: before
    /// the session's first sample).
    pub(super) actual: Vec<Option<f64>>,
    /// Per worn lost motion: the same, and the random stream of its approach sides.
    pub(super) worn: Vec<(Option<f64>, Option<ChaCha8Rng>)>,
    /// Per lateral play: the axis' travel and where the carriage was across at the last
    /// reversal and at the last sample (m).
    pub(super) lateral: Vec<(Travel, f64, f64)>,
    /// Per reversal spike, per stick-slip: the axis' travel.
    pub(super) spikes: Vec<Travel>,
    pub(super) sticks: Vec<Travel>,
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

    pub(super) fn sample(&mut self, q: &[f64], t: f64, trail: Vec<f64>) -> SampleState<'a> {
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
pub(super) fn command_at(poses: &[Vec<f64>], times: &[f64], k: usize, i: usize, at: f64) -> f64 {
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
pub(super) fn stick_slip(sense: f64, travel: f64, height: f64, slip: f64) -> f64 {
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
