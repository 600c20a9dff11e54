//! The plan's effects resolved for simulation: heat nodes, temperatures, scales, screws, lines,
//! rotations, ambient, wear, lateral play, bumps and creep, each with the state it needs.

use super::*;

/// A heat source with its programme resolved to steps.
#[derive(Clone, Debug)]
pub(super) struct Node {
    pub(super) gain: f64,
    pub(super) tau_s: f64,
    pub(super) steps: Vec<(f64, f64)>,
}

impl Node {
    pub(super) fn at(&self, t: f64) -> f64 {
        self.gain * first_order_response(&self.steps, self.tau_s, t)
    }
}

/// A temperature programme, resolved.
#[derive(Clone, Debug)]
pub(super) struct Temperature {
    pub(super) ambient_c: f64,
    pub(super) drift_k_per_s: f64,
    pub(super) nodes: Vec<Node>,
}

impl Temperature {
    /// `T(t) − T(0)`, K.
    pub(super) fn rise(&self, t: f64) -> f64 {
        self.drift_k_per_s * t + self.nodes.iter().map(|n| n.at(t)).sum::<f64>()
    }

    pub(super) fn celsius(&self, t: f64) -> f64 {
        self.ambient_c + self.rise(t)
    }
}

#[derive(Clone, Debug)]
pub(super) struct Scale {
    pub(super) axis: usize,
    pub(super) alpha_per_k: f64,
    pub(super) reference: f64,
    pub(super) temperature: Temperature,
}

#[derive(Clone, Debug)]
pub(super) struct Screw {
    pub(super) axis: usize,
    pub(super) pitch: f64,
    pub(super) harmonics: Vec<(u32, f64, f64)>,
}

impl Screw {
    pub(super) fn error(&self, c: f64) -> f64 {
        let turns = std::f64::consts::TAU * c / self.pitch;
        self.harmonics
            .iter()
            .map(|&(k, a, phase)| a * (f64::from(k) * turns + phase).sin())
            .sum()
    }
}

#[derive(Clone, Debug)]
pub(super) struct Bar {
    pub(super) setup: String,
    /// `α·L_nominal`, m per K.
    pub(super) m_per_k: f64,
    pub(super) temperature: Temperature,
}

/// What a context column shows.
#[derive(Clone, Debug)]
pub(super) enum Shows {
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
pub(super) struct Column {
    pub(super) name: String,
    pub(super) shows: Shows,
    /// Only in the runs of this set-up (`None`: every run).
    pub(super) setup: Option<String>,
}

/// A plan's effects checked against its machine and set-ups, in the form the timeline uses.
#[derive(Clone, Debug, Default)]
pub(crate) struct Resolved {
    pub(super) backlash: Vec<(usize, f64)>,
    pub(super) screws: Vec<Screw>,
    pub(super) scales: Vec<Scale>,
    /// Unit direction and nodes (gains in m) of each thermal growth.
    pub(super) growth: Vec<(Vector3<f64>, Vec<Node>)>,
    /// `(X index, Y index, k)`.
    pub(super) twist: Vec<(usize, usize, f64)>,
    /// `(axis index, machine direction 0..3, k)`.
    pub(super) sag: Vec<(usize, usize, f64)>,
    pub(super) bars: Vec<Bar>,
    pub(super) creeps: Vec<Creep>,
    /// `(axis index, lag s)`.
    pub(super) lags: Vec<(usize, f64)>,
    pub(super) spindle_rpm: Option<Vec<(f64, f64)>>,
    pub(super) columns: Vec<Column>,
    pub(super) worn: Vec<Worn>,
    pub(super) lateral: Vec<Lateral>,
    /// `(axis index, height, recovery s)`.
    pub(super) spikes: Vec<(usize, f64, f64)>,
    /// `(axis index, height, slip travel)`.
    pub(super) sticks: Vec<(usize, f64, f64)>,
    pub(super) bumps: Vec<Bump>,
    /// Nodes (gains in m) of each spindle growth along the tool axis.
    pub(super) spindle_growth: Vec<Vec<Node>>,
    pub(super) rotations: Vec<Rotation>,
    pub(super) ambient: Vec<Ambient>,
    /// The logging sensors' temperatures ([`Effect::TemperatureSensor`]).
    pub(super) sensors: Vec<Temperature>,
    pub(super) lines: Vec<LineDrift>,
}

/// A rotary axis' line moving with a temperature ([`Effect::AxisLineDrift`]).
#[derive(Clone, Debug)]
pub(super) struct LineDrift {
    /// The axis (joint index) and the location error's direction (0..6: δx δy δz εx εy εz).
    pub(super) axis: usize,
    pub(super) direction: usize,
    /// m or rad per K.
    pub(super) per_k: f64,
    pub(super) temperature: Temperature,
}

/// The truth with the axis lines moved: `(axis, direction, change)` added to its location
/// errors.
pub(super) struct MovedLines<'a> {
    pub(super) truth: &'a Truth,
    pub(super) changes: &'a [(usize, usize, f64)],
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
pub(super) struct Rotation {
    /// A point of the line, machine frame, m.
    pub(super) pivot: Vector3<f64>,
    pub(super) rad_per_k: f64,
    pub(super) temperature: Temperature,
}

impl Rotation {
    /// `H(θ(t)) = Trans(c)·Rot_x(θ)·Trans(−c)`.
    pub(super) fn turn(&self, t: f64) -> Matrix4<f64> {
        let theta = self.rad_per_k * self.temperature.rise(t);
        let r = exp_rotation(&Vector3::new(theta, 0.0, 0.0));
        rigid(&r, &(self.pivot - r * self.pivot))
    }
}

/// A step of the room temperature ([`Effect::AmbientStep`]).
#[derive(Clone, Debug)]
pub(super) struct Ambient {
    pub(super) ambient_c: f64,
    pub(super) at_s: f64,
    pub(super) step_k: f64,
    pub(super) tau_s: f64,
    /// m per K, machine directions.
    pub(super) shift_per_k: Vector3<f64>,
}

impl Ambient {
    /// The structure's uniform displacement at `t`, m.
    pub(super) fn shift(&self, t: f64) -> Vector3<f64> {
        let x = first_order_response(&[(self.at_s, 1.0)], self.tau_s, t);
        self.shift_per_k * (self.step_k * x)
    }

    /// The air's temperature at `t`, °C.
    pub(super) fn air_c(&self, t: f64) -> f64 {
        if t >= self.at_s {
            self.ambient_c + self.step_k
        } else {
            self.ambient_c
        }
    }
}

/// A lost motion whose width varies along the stroke ([`Effect::LostMotion`]).
#[derive(Clone, Debug)]
pub(super) struct Worn {
    pub(super) axis: usize,
    pub(super) low: f64,
    pub(super) high: f64,
    /// The stroke the width varies over.
    pub(super) stroke: (f64, f64),
    /// The seed of the per-run approach side (`None`: carried).
    pub(super) random_seed: Option<u64>,
}

impl Worn {
    /// `B(c)`.
    pub(super) fn width(&self, c: f64) -> f64 {
        let (lo, hi) = self.stroke;
        let f = ((c - lo) / (hi - lo)).clamp(0.0, 1.0);
        self.low + (self.high - self.low) * f
    }
}

/// A carriage rocking across its guideway clearance ([`Effect::LateralPlay`]).
#[derive(Clone, Debug)]
pub(super) struct Lateral {
    pub(super) axis: usize,
    pub(super) across: Vector3<f64>,
    pub(super) play: f64,
    pub(super) take_up: f64,
}

impl Lateral {
    /// Where the carriage sits across its clearance (m along `across`), having been at `from`
    /// at the last reversal, moving in `sense` for `travel` since.
    pub(super) fn offset(&self, from: f64, sense: f64, travel: f64) -> f64 {
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
pub(super) struct Bump {
    pub(super) axis: usize,
    pub(super) direction: Vector3<f64>,
    pub(super) centre: f64,
    pub(super) width: f64,
    pub(super) height: f64,
}

impl Bump {
    /// The raised cosine at the actual position `q`.
    pub(super) fn rise(&self, q: f64) -> f64 {
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
pub(super) struct Creep {
    pub(super) setup: String,
    /// Where it ends up, m (workpiece frame).
    pub(super) settle: Vector3<f64>,
    pub(super) tau_s: f64,
}

/// A context column of one run: its name, the true values and whether a sensor reads it (a
/// temperature: noise and quantisation apply) or it is exact (the spindle speed).
#[derive(Clone, Debug)]
pub(crate) struct ContextValues {
    pub name: String,
    pub values: Vec<f64>,
    pub sensed: bool,
}

pub(super) fn plan_error(message: String) -> SimError {
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

    pub(super) fn add(
        &mut self,
        machine: &Machine,
        setups: &[SetupPlan],
        e: &Effect,
    ) -> Result<(), String> {
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
    pub(super) fn log_temperature(&mut self, name: &str, shows: Shows) -> Result<(), String> {
        check_temperature_column(name)?;
        self.columns.push(Column {
            name: name.to_string(),
            shows,
            setup: None,
        });
        Ok(())
    }

    pub(super) fn add_bar(
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

    pub(super) fn add_creep(
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

    pub(super) fn nodes(&self, sources: &[HeatSource]) -> Result<Vec<Node>, String> {
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

    pub(super) fn temperature(&self, p: &TemperatureProgramme) -> Result<Temperature, String> {
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
    pub(super) fn moves_the_machine(&self) -> bool {
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
