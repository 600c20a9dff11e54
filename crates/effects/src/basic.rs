//! The effect most families are made of: one feature, one target, amplitudes and (for some
//! features) one shape parameter. `Δ = Σ amplitudeₖ · featureₖ` on the target.

use crate::view::{Input, SessionView};
use crate::{Effect, EffectInfo, Features, ParamDef, ParamKind, Target, Term};
use std::f64::consts::TAU;
use std::sync::Arc;

/// What the effect follows. Features are dimensionless unless said otherwise; the amplitude
/// carries the unit.
#[derive(Clone, Debug, PartialEq)]
pub enum Feature {
    /// `1 − exp(−(t − t₀)/τ)`, `t₀` the session's first sample: a first-order thermal drift
    /// from the start of the session. Shape: τ (s).
    Saturating,
    /// `(t − t₀)/3600`: hours since the session started (a steady drift).
    Hours,
    /// Hours since set-up `s` was first used; zero in other set-ups' runs.
    SetupHours(usize),
    /// `1 − exp(−(t − t_s)/τ)`, `t_s` when set-up `s` was first used: the set-up settling after
    /// it was mounted (a magnetic base, a clamp); zero in other set-ups' runs. Shape: τ (s).
    SetupSettling(usize),
    /// The input itself (static coupling): `T − T₀` in K, or `S/1000 rpm`.
    Static(Input),
    /// First-order lag of the input (a thermal node driven by it). Shape: τ (s).
    Lag(Input),
    /// Minus half the direction of the last motion of axis `a` (∓½): a backlash `B` leaves the
    /// axis `B/2` behind its command, on the side it came from. 0 before the axis first moves
    /// in a run (the side it arrived from is unknown: the mean of `±B/2`;
    /// [`crate::view::AxisMotion`]).
    Reversal(usize),
    /// Backlash that changes along an axis' stroke: two terms on the axis, `−½·s` and
    /// `−½·s·û` (`s` the direction as for [`Feature::Reversal`], `û` the position normalised
    /// to `[−1, 1]` over the [`Span`]): the lost motion at the middle of the span and its
    /// change from there to the span's positive end.
    ReversalAlong(Span),
    /// `−½·s` of axis `a` (as [`Feature::Reversal`]) acting on another axis: a straightness
    /// step that flips with `a`'s direction (lateral play of the carriage in its guides).
    LateralPlay(usize),
    /// [`Feature::LateralPlay`] taken up over travel: after a reversal the carriage crosses
    /// its clearance as the axis travels, `−½·s·(1 − 2·e^{−d/λ})` (`d` the travel since the
    /// turning point: from the old flank at `d = 0` towards the new one); before the axis
    /// reverses in a run, on the flank of its direction. Shape: λ (m).
    LateralTakeUp(usize),
    /// `w·s·exp(−Δt/τ)` of axis `a`: direction `s` (±1) and time `Δt` since the axis left its
    /// last turning point; `w = 1` after a reversal — within the run, or on its first motion
    /// against the side it arrived from (as the reversal error takes it) — and 0 before one
    /// or where the side is unknown. Shape: τ (s).
    ReversalSpike(usize),
    /// [`Feature::ReversalSpike`] recovering as a critically damped loop does (a position
    /// loop's integrator rebuilding the friction force): `w·s·(1 + Δt/τ)·exp(−Δt/τ)`, flat at
    /// first, then decaying. Shape: τ (s).
    ReversalSpikeDamped(usize),
    /// A compact bump in axis `a`'s position: the cubic B-spline on the uniform knots
    /// `c − w, c − w/2, c, c + w/2, c + w`, scaled to 1 at its centre (`1 − 6σ² + 6σ³` for
    /// `σ = |q − c|/w ≤ ½`, `2(1 − σ)³` up to 1, 0 beyond; twice continuously
    /// differentiable). Shapes: the centre `c` and the half-width `w` (m), in that order:
    /// give them with [`Basic::with_shapes`].
    LocalBump(usize),
    /// `sin(2π q/p)` and `cos(2π q/p)` of axis `a`'s position: two terms. Shape: the pitch `p`
    /// (m or rad).
    Cyclic(usize),
    /// `−v` of axis `a` (SI per second): the amplitude is a lag time (s).
    Velocity(usize),
    /// `w · s · exp(−d/λ)` of axis `a`: direction `s` (±1) and travel `d` since the last
    /// reversal; `w = 1` after a reversal within the run, `½` on the run's first motion (the
    /// turn may have been where the run starts, or not: the mean of both), 0 before it.
    /// Shape: λ (m or rad).
    StickSlip(usize),
    /// `û_a · û_b / k`, positions normalised to `[−1, 1]` over their strokes, `k` the product
    /// at the [`Corner`] the amplitude is given at (1 at the strokes' corner).
    Bilinear(Corner),
    /// One: the amplitude itself (a constant gain error, on a [`Target::Gain`]).
    Constant,
    /// Thermal expansion of axis `a`'s scale (screw, glass scale) with a temperature:
    /// `ΔT·(q_a − q_mid)` (the amplitude a scale change per kelvin), `ΔT` the input as recorded
    /// (`T − T₀`, K), `q_mid` the middle of the positions the axis stands at over the fitted
    /// samples ([`SessionView::fitted_middle`]). Where the scale is fixed is an offset that
    /// follows the temperature: a `temperature-coupling` of the axis, tested on its own. About
    /// the stroke's middle instead, a scale seen over a few heights far from it would be
    /// mostly that offset, and a joint thermal model of the axis would hold most of it.
    Expansion(Input, usize),
    /// [`Feature::Expansion`] through a first-order lag of the temperature (the scale is not
    /// where the sensor is). Shape: τ (s).
    LaggedExpansion(Input, usize),
}

impl Feature {
    /// Whether the feature has a course over the session ([`crate::Effect::follows_the_session`]):
    /// time since the session or a set-up started, or an input recorded over it.
    pub fn follows_the_session(&self) -> bool {
        match self {
            Feature::Saturating
            | Feature::Hours
            | Feature::SetupHours(_)
            | Feature::SetupSettling(_)
            | Feature::Static(_)
            | Feature::Lag(_)
            | Feature::Expansion(..)
            | Feature::LaggedExpansion(..) => true,
            Feature::Reversal(_)
            | Feature::ReversalAlong(_)
            | Feature::LateralPlay(_)
            | Feature::LateralTakeUp(_)
            | Feature::ReversalSpike(_)
            | Feature::ReversalSpikeDamped(_)
            | Feature::LocalBump(_)
            | Feature::Cyclic(_)
            | Feature::Velocity(_)
            | Feature::StickSlip(_)
            | Feature::Bilinear(..)
            | Feature::Constant => false,
        }
    }
}

/// A span of one axis' positions a feature normalises the position over (`û` from −1 at
/// `lo` to 1 at `hi`), and so the span its amplitudes are given over. A candidate's is what
/// the fitted runs cover ([`Span::fitted`]): a backlash "at the stroke's end" fitted from runs
/// over a thirtieth of the stroke would be an extrapolation thirty times the data, its number
/// and interval the line's, not the machine's. A plant's is the stroke ([`Span::stroke`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    pub axis: usize,
    /// The axis' letter and kind, for words.
    pub letter: char,
    pub rotary: bool,
    /// Lowest and highest position (SI).
    pub lo: f64,
    pub hi: f64,
    /// Whether it is the span the fitted runs cover (not the stroke).
    pub fitted: bool,
}

impl Span {
    /// Axis `a`'s stroke.
    pub fn stroke(view: &SessionView, a: usize) -> Self {
        let ax = &view.axes[a];
        Span {
            axis: a,
            letter: ax.letter,
            rotary: ax.rotary,
            lo: ax.stroke.0,
            hi: ax.stroke.1,
            fitted: false,
        }
    }

    /// The positions axis `a` stands at over the fitted samples ([`SessionView::fitted_range`]);
    /// the stroke where the fitted runs hold it in one place.
    pub fn fitted(view: &SessionView, a: usize) -> Self {
        let (lo, hi) = view.fitted_range(a);
        if hi - lo <= 0.0 {
            return Self::stroke(view, a);
        }
        Span {
            lo,
            hi,
            fitted: true,
            ..Self::stroke(view, a)
        }
    }

    /// The position `q` (SI) normalised: −1 at `lo`, 1 at `hi`.
    pub fn normalised(&self, q: f64) -> f64 {
        (2.0 * q - self.lo - self.hi) / (self.hi - self.lo)
    }

    /// The file unit of the axis' positions and its factor from SI (mm; degrees for a rotary
    /// axis).
    pub fn unit(&self) -> (&'static str, f64) {
        if self.rotary {
            ("deg", 180.0 / std::f64::consts::PI)
        } else {
            ("mm", 1e3)
        }
    }

    /// A position (SI) in the axis' file unit, for sentences: `12.5 mm`.
    fn words(&self, q: f64) -> String {
        let (unit, per_si) = self.unit();
        let text = format!("{:.3}", q * per_si);
        let text = text.trim_end_matches('0').trim_end_matches('.');
        let text = if text == "-0" { "0" } else { text };
        format!("{text} {unit}")
    }
}

/// Where a cross-coupling's amplitude is given ([`Feature::Bilinear`]): at the corner of two
/// spans farthest from the strokes' middles (the largest product there). A candidate's spans
/// are what the fitted runs cover ([`Span::fitted`]): its number is the coupling where the data
/// reach furthest, not at the strokes' corners the runs may never have come near (the same
/// fit, rescaled). A plant's are the strokes: its amplitude is the value at their corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    pub over: [Span; 2],
    /// The corner's positions (SI).
    pub at: [f64; 2],
    /// `û_a · û_b` there (over the strokes; never 0).
    pub product: f64,
}

impl Corner {
    /// The corner of `over` with the largest `|û_a · û_b|` over the strokes of `view`'s axes
    /// (of corners within rounding of each other, the first of the high corner, the low one
    /// and the two mixed ones: a plant's is the strokes' high corner, its product exactly 1);
    /// the strokes' corner where every corner of `over` has a product of 0.
    pub fn of(view: &SessionView, over: [Span; 2]) -> Self {
        let stroke = |s: &Span| Span::stroke(view, s.axis);
        let (sa, sb) = (stroke(&over[0]), stroke(&over[1]));
        let strokes = Corner {
            over: [sa, sb],
            at: [sa.hi, sb.hi],
            product: 1.0,
        };
        if over == strokes.over {
            return strokes;
        }
        let [a, b] = over;
        let corners = [[a.hi, b.hi], [a.lo, b.lo], [a.hi, b.lo], [a.lo, b.hi]];
        let mut best: Option<([f64; 2], f64)> = None;
        for at in corners {
            let p = sa.normalised(at[0]) * sb.normalised(at[1]);
            if best.is_none_or(|(_, q)| p.abs() > q.abs() * (1.0 + 1e-9)) {
                best = Some((at, p));
            }
        }
        match best {
            Some((at, product)) if product.abs() > 1e-9 => Corner { over, at, product },
            _ => strokes,
        }
    }
}

/// An effect of one [`Feature`] on one target.
#[derive(Clone, Debug)]
pub struct Basic {
    info: EffectInfo,
    params: Vec<ParamDef>,
    terms: Vec<Term>,
    feature: Feature,
    /// How the target is named in words (`Z`, `channel d_ch1`, `ball-low's ball_x`).
    target_words: String,
    /// Whether every term carries the same feature (one amplitude acting on several
    /// targets: [`Basic::shared`]).
    shared: bool,
    /// The axis and the runs whose start state is fitted ([`Basic::with_start_states`]): one
    /// nuisance shape each, after the feature's own shapes.
    start_states: Option<(usize, Vec<usize>)>,
    /// The simpler effect this one is when a shape reaches an edge of its box
    /// ([`Basic::becoming_at_edge`]).
    edge_form: Option<EdgeForm>,
    /// The simpler effect this one is without one of its amplitudes
    /// ([`Basic::becoming_without`]): the amplitude's index and the effect.
    lesser_form: Option<(usize, Arc<dyn Effect>)>,
}

/// [`Basic::becoming_at_edge`]: shape parameter `param` at its lower (`low`) or upper edge
/// makes the effect `effect`.
#[derive(Clone, Debug)]
struct EdgeForm {
    param: usize,
    low: bool,
    effect: Arc<dyn Effect>,
}

/// The unit of an amplitude on a target, and its factor from SI.
#[derive(Clone, Debug, PartialEq)]
pub struct AmplitudeUnit {
    pub unit: String,
    pub per_si: f64,
}

impl AmplitudeUnit {
    pub fn um() -> Self {
        Self {
            unit: "um".into(),
            per_si: 1e6,
        }
    }
    pub fn urad() -> Self {
        Self {
            unit: "urad".into(),
            per_si: 1e6,
        }
    }
}

impl Basic {
    /// An effect of `feature` on `target`. `unit` is the target's unit (µm for a linear axis
    /// or a µm channel, µrad for a rotary axis); `shape` the starting value of the shape
    /// parameter if the feature has one.
    pub fn new(
        info: EffectInfo,
        feature: Feature,
        target: Target,
        target_words: String,
        unit: AmplitudeUnit,
        shape: Option<f64>,
    ) -> Self {
        // Plausible sizes: a millimetre (or milliradian) of error, a 10 % gain (an instrument
        // channel's: 5 %), a second of lag.
        let amp = |name: &str, unit: String, per_si: f64| ParamDef {
            name: name.to_string(),
            scale: match unit.as_str() {
                "ppm" => 0.1,
                "ms" => 1.0,
                _ => 1e-3,
            },
            unit,
            per_si,
            kind: ParamKind::Amplitude,
            initial: 0.0,
            bounds: None,
            prior: None,
            nuisance: false,
        };
        let shape_def = |name: &str, unit: &str, per_si: f64, lo: f64, hi: f64| ParamDef {
            name: name.to_string(),
            unit: unit.to_string(),
            per_si,
            kind: ParamKind::Shape,
            initial: shape.unwrap_or(0.0),
            bounds: Some((lo, hi)),
            scale: shape.unwrap_or(1.0).abs().max(lo),
            prior: None,
            nuisance: false,
        };
        let u = &unit.unit;
        let k = unit.per_si;
        let rotary_shape = unit.unit == "urad";
        let tau = || shape_def("tau_s", "s", 1.0, 1.0, 1e8);
        let params = match &feature {
            Feature::Saturating | Feature::SetupSettling(_) => {
                vec![amp(&format!("amplitude_{u}"), u.clone(), k), tau()]
            }
            Feature::Hours | Feature::SetupHours(_) => {
                vec![amp(&format!("rate_{u}_per_h"), format!("{u}/h"), k)]
            }
            Feature::Static(input) | Feature::Lag(input) => {
                let (name, unit_name) = match input {
                    Input::Speed => (format!("gain_{u}_per_krpm"), format!("{u}/krpm")),
                    Input::SpeedSquared => (format!("gain_{u}_per_krpm2"), format!("{u}/krpm²")),
                    Input::Context(_) => (format!("gain_{u}_per_K"), format!("{u}/K")),
                };
                let mut p = vec![amp(&name, unit_name, k)];
                if matches!(feature, Feature::Lag(_)) {
                    p.push(tau());
                }
                p
            }
            Feature::Reversal(_) => vec![amp(&format!("backlash_{u}"), u.clone(), k)],
            Feature::ReversalAlong(_) => vec![
                amp(&format!("backlash_{u}"), u.clone(), k),
                amp(&format!("backlash_change_{u}"), u.clone(), k),
            ],
            Feature::LateralPlay(_) => vec![amp(&format!("play_{u}"), u.clone(), k)],
            Feature::LateralTakeUp(_) => vec![
                amp(&format!("play_{u}"), u.clone(), k),
                // Beyond a few centimetres the carriage never settles on a flank: not play.
                shape_def("take_up_mm", "mm", 1e3, 1e-6, 0.02),
            ],
            Feature::ReversalSpike(_) | Feature::ReversalSpikeDamped(_) => {
                // Beyond half a minute a decay in time is a reversal error held over the next
                // stretch of the path, the simpler explanation.
                vec![
                    amp(&format!("height_{u}"), u.clone(), k),
                    shape_def("tau_s", "s", 1.0, 1e-3, 30.0),
                ]
            }
            Feature::LocalBump(_) => vec![
                amp(&format!("amplitude_{u}"), u.clone(), k),
                // Placeholders until `with_shapes` gives the session's ranges.
                shape_def("centre_mm", "mm", 1e3, -10.0, 10.0),
                shape_def("half_width_mm", "mm", 1e3, 1e-6, 10.0),
            ],
            Feature::Cyclic(_) => {
                let pitch = if rotary_shape {
                    shape_def("period_deg", "deg", 180.0 / std::f64::consts::PI, 1e-3, 7.0)
                } else {
                    shape_def("pitch_mm", "mm", 1e3, 1e-5, 10.0)
                };
                vec![
                    amp(&format!("sin_{u}"), u.clone(), k),
                    amp(&format!("cos_{u}"), u.clone(), k),
                    pitch,
                ]
            }
            Feature::Velocity(_) => vec![amp("lag_ms", "ms".into(), 1e3)],
            Feature::StickSlip(_) => {
                // Beyond a few centimetres (or degrees) of travel the catching up never ends:
                // that is a reversal error, the simpler explanation, not stick-slip.
                let decay = if rotary_shape {
                    shape_def("decay_deg", "deg", 180.0 / std::f64::consts::PI, 1e-6, 0.35)
                } else {
                    shape_def("decay_mm", "mm", 1e3, 1e-7, 0.02)
                };
                vec![amp(&format!("height_{u}"), u.clone(), k), decay]
            }
            Feature::Bilinear(..) => vec![amp(&format!("corner_{u}"), u.clone(), k)],
            // An instrument channel's gain: a sensor's sensitivity entered wrong or a
            // ball-bar's calibration lost by a few per cent is plausible; readings off by more
            // than 5 % would be visibly wrong at the machine.
            Feature::Constant => vec![ParamDef {
                scale: 0.05,
                ..amp("gain_ppm", "ppm".into(), 1e6)
            }],
            Feature::Expansion(..) | Feature::LaggedExpansion(..) => {
                // A scale follows its temperature by some 10 ppm/K (steel 11.5, glass 8):
                // 100 ppm/K is beyond any machine.
                let mut p = vec![ParamDef {
                    scale: 1e-4,
                    ..amp("scale_ppm_per_K", "ppm/K".into(), 1e6)
                }];
                if matches!(feature, Feature::LaggedExpansion(..)) {
                    p.push(tau());
                }
                p
            }
        };
        let terms = match &feature {
            Feature::Cyclic(_) | Feature::ReversalAlong(_) => vec![
                Term {
                    amplitude: 0,
                    target: target.clone(),
                },
                Term {
                    amplitude: 1,
                    target,
                },
            ],
            _ => vec![Term {
                amplitude: 0,
                target,
            }],
        };
        Self {
            info,
            params,
            terms,
            feature,
            target_words,
            shared: false,
            start_states: None,
            edge_form: None,
            lesser_form: None,
        }
    }

    /// An effect of a one-term `feature` acting with one amplitude on every target of
    /// `targets` (the spindle growing: the tool length of every set-up at once). The unit is
    /// the targets' (they share it).
    pub fn shared(
        info: EffectInfo,
        feature: Feature,
        targets: Vec<Target>,
        target_words: String,
        unit: AmplitudeUnit,
        shape: Option<f64>,
    ) -> Self {
        assert!(
            !matches!(
                feature,
                Feature::Cyclic(_) | Feature::ReversalAlong(_) | Feature::LocalBump(_)
            ),
            "a shared effect's feature has one term and at most one shape"
        );
        let first = targets
            .first()
            .cloned()
            .expect("a shared effect has targets");
        let mut e = Self::new(info, feature, first, target_words, unit, shape);
        e.terms = targets
            .into_iter()
            .map(|target| Term {
                amplitude: 0,
                target,
            })
            .collect();
        e.shared = true;
        e
    }

    /// The effect with its shape parameters (in their order) starting at `initial`, boxed in
    /// `bounds` (SI), with `scale` their plausible sizes (what moving them by that much means
    /// to the solver).
    pub fn with_shapes(mut self, shapes: &[ShapeStart]) -> Self {
        let mut given = shapes.iter();
        for p in self
            .params
            .iter_mut()
            .filter(|p| p.kind == ParamKind::Shape)
        {
            let Some(g) = given.next() else { break };
            p.initial = g.initial;
            p.bounds = Some(g.bounds);
            p.scale = g.scale;
        }
        self
    }

    pub fn feature(&self) -> &Feature {
        &self.feature
    }

    /// The effect with its shape parameter named `param` making it `simpler` at the lower
    /// (`low`) or upper edge of its box ([`Effect::at_edge`]). Panics if it has no such
    /// parameter (a family's construction error).
    pub fn becoming_at_edge(mut self, param: &str, low: bool, simpler: Basic) -> Self {
        let param = self
            .params
            .iter()
            .position(|p| p.name == param && p.kind == ParamKind::Shape)
            .unwrap_or_else(|| panic!("{} has no shape {param}", self.info.label));
        self.edge_form = Some(EdgeForm {
            param,
            low,
            effect: Arc::new(simpler),
        });
        self
    }

    /// The effect with its amplitude named `param` making it `simpler` when that amplitude is
    /// zero ([`Effect::without`]). Panics if it has no such amplitude (a family's construction
    /// error).
    pub fn becoming_without(mut self, param: &str, simpler: Basic) -> Self {
        let amplitude = self
            .params
            .iter()
            .position(|p| p.name == param && p.kind == ParamKind::Amplitude)
            .unwrap_or_else(|| panic!("{} has no amplitude {param}", self.info.label));
        self.lesser_form = Some((amplitude, Arc::new(simpler)));
        self
    }

    /// A direction-driven effect ([`Feature::Reversal`], [`Feature::ReversalAlong`],
    /// [`Feature::LateralPlay`], [`Feature::LateralTakeUp`]) of axis `a` with the axis' state
    /// before its first motion fitted in every run it moves in, and in those it stands in
    /// arrived at from an unknown side where that decides at least [`START_STATE_SAMPLES`]
    /// fitted samples ([`SessionView::start_states`]): the approach move is not in the file.
    /// One nuisance shape `u` per run, `start_<run>` between −1 and 1, starting from the side
    /// the previous run suggests (0, the mean of the two sides, where none does): the feature
    /// reads `−½·u` there (the direction's `−½·s` for a side `u` of the play). Without it a session whose first run is recorded with the axis standing
    /// carries `±B/2` there as a drift or a set-up error.
    pub fn with_start_states(mut self, view: &SessionView, a: usize) -> Self {
        assert!(
            !self.shared
                && matches!(
                    self.feature,
                    Feature::Reversal(_)
                        | Feature::ReversalAlong(_)
                        | Feature::LateralPlay(_)
                        | Feature::LateralTakeUp(_)
                        | Feature::ReversalSpike(_)
                        | Feature::ReversalSpikeDamped(_)
                ),
            "start states belong to a direction-driven effect"
        );
        let states = match self.feature {
            // A transient follows the first motion: every run whose first turn is unknown.
            Feature::ReversalSpike(_) | Feature::ReversalSpikeDamped(_) => {
                view.unknown_first_turns(a)
            }
            _ => view.start_states(a, START_STATE_SAMPLES),
        };
        if states.is_empty() {
            return self;
        }
        for st in &states {
            self.params.push(ParamDef {
                name: format!("start_{}", st.name),
                unit: "side".into(),
                per_si: 1.0,
                kind: ParamKind::Shape,
                initial: f64::from(st.guess),
                bounds: Some((-1.0, 1.0)),
                scale: 1.0,
                prior: None,
                nuisance: true,
            });
        }
        self.start_states = Some((a, states.iter().map(|st| st.run).collect()));
        self
    }
}

/// The fewest fitted samples before an axis' first motion for the run's start state to be
/// fitted ([`Basic::with_start_states`]): a run's first sample alone says too little.
pub const START_STATE_SAMPLES: usize = 5;

/// A shape parameter's start, box (SI) and plausible size ([`Basic::with_shapes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeStart {
    pub initial: f64,
    pub bounds: (f64, f64),
    pub scale: f64,
}

impl Effect for Basic {
    fn info(&self) -> &EffectInfo {
        &self.info
    }

    fn params(&self) -> &[ParamDef] {
        &self.params
    }

    fn terms(&self) -> &[Term] {
        &self.terms
    }

    fn spans(&self) -> Vec<Span> {
        match &self.feature {
            Feature::ReversalAlong(span) => vec![*span],
            Feature::Bilinear(corner) => corner.over.to_vec(),
            _ => Vec::new(),
        }
    }

    fn prepare(&self, view: &Arc<SessionView>, shape: &[f64]) -> Box<dyn Features> {
        let shape_value = shape.first().copied().unwrap_or(0.0);
        let second = shape.get(1).copied().unwrap_or(0.0);
        let lag = match &self.feature {
            Feature::Lag(input) | Feature::LaggedExpansion(input, _) => {
                Some(view.lag(input, shape_value))
            }
            _ => None,
        };
        let input = match &self.feature {
            Feature::Static(input) | Feature::Expansion(input, _) => Some(view.input(input)),
            _ => None,
        };
        let setup_start = match self.feature {
            Feature::SetupHours(s) | Feature::SetupSettling(s) => view
                .runs_in_time_order()
                .iter()
                .find(|&&r| view.runs[r].setup == s)
                .and_then(|&r| view.runs[r].first_time())
                .unwrap_or(0.0),
            _ => 0.0,
        };
        Box::new(BasicFeatures {
            view: Arc::clone(view),
            feature: self.feature.clone(),
            shape: shape_value,
            second,
            copies: if self.shared { self.terms.len() } else { 1 },
            n_shapes: shape.len(),
            lag,
            input,
            setup_start,
            start_states: self.start_states.clone().map(|(a, runs)| {
                let first = shape.len() - runs.len();
                (a, first, runs)
            }),
            shape_values: shape.to_vec(),
        })
    }

    fn follows_the_session(&self) -> bool {
        self.feature.follows_the_session()
    }

    fn without(&self, param: usize) -> Option<Arc<dyn Effect>> {
        let (amplitude, effect) = self.lesser_form.as_ref()?;
        (*amplitude == param).then(|| Arc::clone(effect))
    }

    fn at_edge(&self, param: usize, low: bool) -> Option<Arc<dyn Effect>> {
        let form = self.edge_form.as_ref()?;
        (form.param == param && form.low == low).then(|| Arc::clone(&form.effect))
    }

    fn shape_scan(&self, view: &SessionView) -> Vec<Vec<f64>> {
        if let Feature::LocalBump(_) = self.feature {
            return self.centre_scan();
        }
        let Feature::Cyclic(a) = self.feature else {
            return Vec::new();
        };
        let Some(p0) = self.params.iter().find(|p| p.kind == ParamKind::Shape) else {
            return Vec::new();
        };
        // The longest stretch of the axis a fitted run covers: a pitch off by δ turns the
        // phase at its far end by 2π·L·δ/p², so steps of p²/(8L) keep every phase within an
        // eighth of a turn of the best.
        let reach = (0..view.runs.len())
            .filter(|&r| view.runs[r].fit)
            .map(|r| {
                let (lo, hi) = view.motion(r, a).range;
                (hi - lo).max(lo.abs().max(hi.abs()))
            })
            .fold(0.0, f64::max);
        if reach <= 0.0 {
            return Vec::new();
        }
        let (lo, hi) = (0.8 * p0.initial, 1.25 * p0.initial);
        let (min, max) = p0.bounds.unwrap_or((0.0, f64::INFINITY));
        let mut out = Vec::new();
        let mut p = lo.max(min);
        while p <= hi.min(max) && out.len() < SCAN_MAX {
            out.push(vec![p]);
            p += p * p / (8.0 * reach);
        }
        out
    }

    fn with_shape(&self, shape: &[f64]) -> Option<Arc<dyn Effect>> {
        let mut e = self.clone();
        let mut values = shape.iter();
        // A bump's centre and width keep the sizes the session gave them (a centre near 0 is
        // no smaller a parameter).
        let keep_scale = matches!(self.feature, Feature::LocalBump(_));
        for p in e.params.iter_mut().filter(|p| p.kind == ParamKind::Shape) {
            p.initial = *values.next()?;
            if !keep_scale && !p.nuisance {
                p.scale = p.initial.abs().max(p.bounds.map_or(0.0, |b| b.0));
            }
        }
        Some(Arc::new(e))
    }

    fn cached_series(&self) -> Vec<String> {
        match &self.feature {
            Feature::Lag(input) | Feature::LaggedExpansion(input, _) => vec![format!(
                "{input:?}/{}",
                self.params
                    .iter()
                    .find(|p| p.kind == ParamKind::Shape)
                    .map_or(0.0, |p| p.initial)
            )],
            _ => Vec::new(),
        }
    }

    fn describe(&self, v: &[f64], u: &[Option<f64>]) -> String {
        let p = |i: usize| Quantity {
            value: v[i] * self.params[i].per_si,
            u95: u[i].map(|x| x * self.params[i].per_si),
            unit: self.params[i].unit.clone(),
        };
        let tau = |i: usize| duration(v[i], u[i]);
        let target = &self.target_words;
        match &self.feature {
            Feature::Saturating => format!(
                "a first-order thermal drift of {target} from the start of the session with τ = {} and {} amplitude",
                tau(1),
                p(0)
            ),
            Feature::Hours => format!("a steady drift of {target} of {}", p(0)),
            Feature::SetupHours(_) => format!("a drift of {target} of {}", p(0)),
            Feature::SetupSettling(_) => format!(
                "a settling of {target} from the set-up's first use with τ = {} and {} amplitude",
                tau(1),
                p(0)
            ),
            Feature::Static(Input::Context(name)) => {
                format!(
                    "a coupling of {target} to the temperature {name} of {}",
                    p(0)
                )
            }
            Feature::Static(_) => format!("a coupling of {target} to spindle speed of {}", p(0)),
            Feature::Lag(input) => {
                let to = match input {
                    Input::Speed => "spindle speed".to_string(),
                    Input::SpeedSquared => "the square of spindle speed".to_string(),
                    Input::Context(name) => format!("the temperature {name}"),
                };
                format!(
                    "a first-order thermal response of {target} to {to} with τ = {} and a gain of {}",
                    tau(1),
                    p(0)
                )
            }
            Feature::Reversal(_) => format!("a reversal error (backlash) of {target} of {}", p(0)),
            Feature::ReversalAlong(span) => {
                let over = if span.fitted {
                    "the positions the fitted runs cover"
                } else {
                    "its stroke"
                };
                format!(
                    "a reversal error (backlash) of {target} of {} at {} {}, the middle of {over} ({} … {}), changing by {} from there to {}",
                    p(0),
                    span.letter,
                    span.words(0.5 * (span.lo + span.hi)),
                    span.words(span.lo),
                    span.words(span.hi),
                    p(1),
                    span.words(span.hi)
                )
            }
            Feature::LateralPlay(_) => format!(
                "a lateral play: {target}, a step of {} that flips with the direction of motion",
                p(0)
            ),
            Feature::LateralTakeUp(_) => format!(
                "a lateral play: {target}, a step of {} that flips with the direction of motion, taken up over {} of travel",
                p(0),
                p(1)
            ),
            Feature::ReversalSpike(_) => format!(
                "a reversal spike of {target}: {} after each reversal, decaying in time with τ = {}",
                p(0),
                tau(1)
            ),
            Feature::ReversalSpikeDamped(_) => format!(
                "a reversal spike of {target}: {} after each reversal, recovering as a critically damped loop with τ = {}",
                p(0),
                tau(1)
            ),
            Feature::LocalBump(_) => format!(
                "a local error of {target}: a bump of {} centred at {} with a half-width of {}",
                p(0),
                p(1),
                p(2)
            ),
            Feature::Cyclic(_) => {
                let amplitude = v[0].hypot(v[1]) * self.params[0].per_si;
                format!(
                    "a cyclic error of {target} with a period of {} and {:.3} {} amplitude (sine {}, cosine {})",
                    p(2),
                    amplitude,
                    self.params[0].unit,
                    p(0),
                    p(1)
                )
            }
            Feature::Velocity(_) => format!(
                "a servo lag of {target} of {} (the error grows with the axis' velocity and flips with its direction)",
                p(0)
            ),
            Feature::StickSlip(_) => format!(
                "stick-slip of {target} after reversals: {} decaying over {} of travel",
                p(0),
                p(1)
            ),
            Feature::Bilinear(corner) => {
                let [a, b] = corner.over;
                let over = if a.fitted || b.fitted {
                    "the positions the fitted runs cover"
                } else {
                    "the strokes"
                };
                format!(
                    "a cross-coupling: {target}, {} at {} {}, {} {}, the corner of {over} ({} … {}, {} … {}) farthest from the strokes' middles",
                    p(0),
                    a.letter,
                    a.words(corner.at[0]),
                    b.letter,
                    b.words(corner.at[1]),
                    a.words(a.lo),
                    a.words(a.hi),
                    b.words(b.lo),
                    b.words(b.hi)
                )
            }
            Feature::Constant => format!("a scale error of {target} of {}", p(0)),
            Feature::Expansion(input, _) => format!(
                "a thermal expansion of {target}'s scale with the temperature {}: {}",
                input.column(),
                p(0)
            ),
            Feature::LaggedExpansion(input, _) => format!(
                "a thermal expansion of {target}'s scale following the temperature {} with τ = {}: {}",
                input.column(),
                tau(1),
                p(0)
            ),
        }
    }
}

/// A value with its 95 % half-width, for sentences.
struct Quantity {
    value: f64,
    u95: Option<f64>,
    unit: String,
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let digits = significant_decimals(self.u95.unwrap_or(self.value.abs() * 1e-3));
        match self.u95 {
            Some(u) => write!(
                f,
                "{:.*} ± {:.*} {}",
                digits, self.value, digits, u, self.unit
            ),
            None => write!(
                f,
                "{:.*} {} (not separable from the fitted parameters)",
                digits, self.value, self.unit
            ),
        }
    }
}

/// Decimals that show two significant digits of `u`.
fn significant_decimals(u: f64) -> usize {
    if !(u.is_finite()) || u <= 0.0 {
        return 2;
    }
    (1.0 - u.log10().floor()).clamp(0.0, 6.0) as usize
}

/// A time constant in the unit that reads best.
fn duration(value_s: f64, u95_s: Option<f64>) -> String {
    let (scale, unit) = if value_s < 120.0 {
        (1.0, "s")
    } else if value_s < 2.0 * 3600.0 {
        (60.0, "min")
    } else {
        (3600.0, "h")
    };
    Quantity {
        value: value_s / scale,
        u95: u95_s.map(|u| u / scale),
        unit: unit.into(),
    }
    .to_string()
}

/// Shapes a scan tries at most (a pitch between 0.8 and 1.25 of its grid value over a stroke
/// of a metre at 2 mm needs about 120).
const SCAN_MAX: usize = 400;

/// Axis `a`'s position at sample `i` of run `r` from the middle of its fitted positions (SI).
fn from_fitted_middle(view: &SessionView, r: usize, i: usize, a: usize) -> f64 {
    view.q(r, i, a) - view.fitted_middle(a)
}

/// The cubic B-spline bump of [`Feature::LocalBump`] at `σ = |q − c|/w`, and its derivative
/// by `σ`.
fn bump(sigma: f64) -> (f64, f64) {
    if sigma < 0.5 {
        (
            1.0 - 6.0 * sigma * sigma + 6.0 * sigma.powi(3),
            -12.0 * sigma + 18.0 * sigma * sigma,
        )
    } else if sigma < 1.0 {
        let u = 1.0 - sigma;
        (2.0 * u.powi(3), -6.0 * u * u)
    } else {
        (0.0, 0.0)
    }
}

/// A reversal spike's decay `Δt` after the turn at time constant `tau`, and its derivative
/// with respect to `tau`: first-order `e^{−x}`, or critically damped `(1 + x)·e^{−x}`
/// ([`Feature::ReversalSpikeDamped`]), `x = Δt/τ`.
fn spike_law(feature: &Feature, dt: f64, tau: f64) -> (f64, f64) {
    let x = dt / tau;
    let e = (-x).exp();
    match feature {
        Feature::ReversalSpikeDamped(_) => (e * (1.0 + x), e * x * x / tau),
        _ => (e, e * x / tau),
    }
}

/// How much of a transient after a reversal the feature holds at sample `i` of run `r`: the
/// direction after a reversal, 0 before one. A run's first motion against the side the axis
/// arrived from is a reversal, as the reversal error counts it (the previous run left the axis
/// moving the other way: the controller turns it where this run starts, and the transient
/// decays into the run's first samples); where the side is unknown, none is counted.
fn after_reversal(view: &SessionView, r: usize, a: usize, i: usize) -> f64 {
    if view.reversed(r, a, i) {
        f64::from(view.direction(r, a, i))
    } else {
        0.0
    }
}

impl Basic {
    /// Centres a bump's refit may start from: over its box, a quarter of its half-width
    /// apart (its width kept).
    fn centre_scan(&self) -> Vec<Vec<f64>> {
        let shapes: Vec<&ParamDef> = self
            .params
            .iter()
            .filter(|p| p.kind == ParamKind::Shape)
            .collect();
        let [c, w] = shapes[..] else {
            return Vec::new();
        };
        let Some((lo, hi)) = c.bounds else {
            return Vec::new();
        };
        let step = 0.25 * w.initial;
        let usable = step > 0.0 && hi > lo && (hi - lo).is_finite();
        if !usable {
            return Vec::new();
        }
        let n = (((hi - lo) / step).floor() as usize + 1).min(SCAN_MAX);
        (0..n)
            .map(|k| vec![lo + k as f64 * step, w.initial])
            .collect()
    }
}

struct BasicFeatures {
    view: Arc<SessionView>,
    feature: Feature,
    shape: f64,
    /// The second shape parameter ([`Feature::LocalBump`]'s half-width).
    second: f64,
    /// Terms that carry the feature (several for a shared effect).
    copies: usize,
    n_shapes: usize,
    lag: Option<Arc<crate::lag::LagSeries>>,
    input: Option<Arc<Vec<f64>>>,
    setup_start: f64,
    /// The axis, the index of the first start state among the shapes, and the runs.
    start_states: Option<(usize, usize, Vec<usize>)>,
    /// Every shape value (the start states among them).
    shape_values: Vec<f64>,
}

impl BasicFeatures {
    /// [`Basic::with_start_states`]: before axis `a`'s first motion in a run whose start
    /// state is fitted (shape `first + k` for the `k`-th of `runs`), the side `u` replaces the
    /// guessed direction; every start state's derivative is set on every sample.
    #[allow(clippy::too_many_arguments)]
    fn start_state(
        &self,
        r: usize,
        i: usize,
        a: usize,
        first: usize,
        runs: &[usize],
        f: &mut [f64],
        df: &mut [f64],
    ) {
        let ns = self.n_shapes;
        let n_terms = if matches!(self.feature, Feature::ReversalAlong(_)) {
            2
        } else {
            1
        };
        for k in 0..n_terms {
            df[k * ns + first..k * ns + first + runs.len()].fill(0.0);
        }
        let view = &*self.view;
        let Some(k) = runs.iter().position(|&run| run == r) else {
            return;
        };
        if let Feature::ReversalSpike(_) | Feature::ReversalSpikeDamped(_) = self.feature {
            // From the first motion to the first reversal within the run, the spike of a
            // turn at the run's start in the share `½(1 − u·s)` of the side `u` against the
            // first direction `s`: in full if it arrived from the other side, none if from
            // its own.
            if view.before_first_motion(r, a, i) || view.reversed_in_run(r, a, i) {
                return;
            }
            let s = f64::from(view.direction(r, a, i));
            let (g, dg) = spike_law(&self.feature, view.since_turn(r, a, i), self.shape);
            let w = 0.5 * (s - self.shape_values[first + k]);
            f[0] = w * g;
            df[0] = w * dg;
            df[first + k] = -0.5 * g;
            return;
        }
        if !view.before_first_motion(r, a, i) {
            return;
        }
        let side = self.shape_values[first + k];
        f[0] = -0.5 * side;
        df[first + k] = -0.5;
        if first > 0 {
            // The feature's own shape (a take-up) does nothing before the first motion.
            df[..first].fill(0.0);
        }
        if let Feature::ReversalAlong(span) = &self.feature {
            let u = span.normalised(view.q(r, i, a));
            f[1] = f[0] * u;
            df[ns + first + k] = -0.5 * u;
        }
    }
}

impl Features for BasicFeatures {
    fn eval(&self, r: usize, i: usize, f: &mut [f64], df: &mut [f64]) {
        let view = &*self.view;
        let run = &view.runs[r];
        match &self.feature {
            Feature::Saturating => {
                let t = run.t.get(i) - view.t0();
                let tau = self.shape;
                let e = (-t / tau).exp();
                f[0] = 1.0 - e;
                df[0] = -e * t / (tau * tau);
            }
            Feature::Hours => f[0] = (run.t.get(i) - view.t0()) / 3600.0,
            Feature::SetupHours(s) => {
                f[0] = if run.setup == *s {
                    (run.t.get(i) - self.setup_start) / 3600.0
                } else {
                    0.0
                }
            }
            Feature::SetupSettling(s) => {
                if run.setup == *s {
                    let t = (run.t.get(i) - self.setup_start).max(0.0);
                    let tau = self.shape;
                    let e = (-t / tau).exp();
                    f[0] = 1.0 - e;
                    df[0] = -e * t / (tau * tau);
                } else {
                    f[0] = 0.0;
                    df[0] = 0.0;
                }
            }
            Feature::Static(_) => {
                let u = self
                    .input
                    .as_ref()
                    .expect("static features have their input");
                f[0] = u[view.timeline_index(r, i)];
            }
            Feature::Lag(_) => {
                let lag = self.lag.as_ref().expect("lag features have their series");
                let k = view.timeline_index(r, i);
                f[0] = lag.y[k];
                df[0] = lag.dy_dtau[k];
            }
            Feature::Reversal(a) | Feature::LateralPlay(a) => {
                f[0] = -0.5 * f64::from(view.direction(r, *a, i));
            }
            Feature::LateralTakeUp(a) => {
                let s = -0.5 * f64::from(view.direction(r, *a, i));
                if view.reversed(r, *a, i) {
                    let d = view.travel(r, *a, i);
                    let lambda = self.shape;
                    let e = (-d / lambda).exp();
                    f[0] = s * (1.0 - 2.0 * e);
                    df[0] = -2.0 * s * e * d / (lambda * lambda);
                } else {
                    f[0] = s;
                    df[0] = 0.0;
                }
            }
            Feature::ReversalAlong(span) => {
                let u = span.normalised(view.q(r, i, span.axis));
                f[0] = -0.5 * f64::from(view.direction(r, span.axis, i));
                f[1] = f[0] * u;
            }
            Feature::ReversalSpike(a) | Feature::ReversalSpikeDamped(a) => {
                let w = after_reversal(view, r, *a, i);
                let (g, dg) = spike_law(&self.feature, view.since_turn(r, *a, i), self.shape);
                f[0] = w * g;
                df[0] = w * dg;
            }
            Feature::LocalBump(a) => {
                let (c, w) = (self.shape, self.second);
                let d = view.q(r, i, *a) - c;
                let sigma = d.abs() / w;
                let (g, dg) = bump(sigma);
                f[0] = g;
                df[0] = -dg * d.signum() / w;
                df[1] = -dg * sigma / w;
            }
            Feature::Cyclic(a) => {
                let q = view.q(r, i, *a);
                let p = self.shape;
                let (s, c) = (TAU * q / p).sin_cos();
                let dphase = -TAU * q / (p * p);
                f[0] = s;
                f[1] = c;
                df[0] = c * dphase;
                df[1] = -s * dphase;
            }
            Feature::Velocity(a) => f[0] = -view.velocity(r, *a, i),
            Feature::StickSlip(a) => {
                let travel = view.travel(r, *a, i);
                let lambda = self.shape;
                let e = f64::from(view.direction(r, *a, i)) * (-travel / lambda).exp();
                f[0] = e;
                df[0] = e * travel / (lambda * lambda);
            }
            Feature::Bilinear(corner) => {
                let u = |k: usize| {
                    let (lo, hi) = view.axes[k].stroke;
                    (2.0 * view.q(r, i, k) - lo - hi) / (hi - lo)
                };
                f[0] = u(corner.over[0].axis) * u(corner.over[1].axis) / corner.product;
            }
            Feature::Constant => f[0] = 1.0,
            Feature::Expansion(_, a) => {
                let u = self
                    .input
                    .as_ref()
                    .expect("static features have their input");
                f[0] = u[view.timeline_index(r, i)] * from_fitted_middle(view, r, i, *a);
            }
            Feature::LaggedExpansion(_, a) => {
                let lag = self.lag.as_ref().expect("lag features have their series");
                let k = view.timeline_index(r, i);
                let q = from_fitted_middle(view, r, i, *a);
                f[0] = lag.y[k] * q;
                df[0] = lag.dy_dtau[k] * q;
            }
        }
        if let Some((a, first, runs)) = &self.start_states {
            self.start_state(r, i, *a, *first, runs, f, df);
        }
        // A shared effect: every term carries the first term's feature.
        let ns = self.n_shapes;
        for k in 1..self.copies {
            f[k] = f[0];
            for s in 0..ns {
                df[k * ns + s] = df[s];
            }
        }
    }
}
