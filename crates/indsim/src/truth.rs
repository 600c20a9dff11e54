//! The ground truth of a simulated machine: its geometric errors, and their files.
//!
//! Every error is stored in SI (m, rad) in machine directions at the zero pose, by ISO 230-1
//! name (FORMATS.md "Error parameter names"). Component errors are functions of their axis'
//! position: Legendre polynomials over the stroke on linear axes, Fourier harmonics 1..2 on
//! rotary ones — exactly the terms mtcal's default full model keeps (positioning P1..P3,
//! straightness P2..P3, angular P0..P3; Fourier C1 S1 C2 S2), so [`Truth::params_toml`]
//! reproduces the truth exactly in that model.

// Index loops over the six parallel direction arrays (values, names, coefficients) read best
// here; the lint is allowed module-wide for them.
#![allow(clippy::needless_range_loop)]

use rand::Rng;
use rand::RngExt;
use rand_distr::{Distribution, Normal};

use crate::machine::{ActualErrors, JointKind, Machine};

/// Direction letters of the ISO names, index 0..6: translations X Y Z, rotations A B C.
pub const DIRECTIONS: [char; 6] = ['X', 'Y', 'Z', 'A', 'B', 'C'];
/// Set-up names of the tool point offset (tool frame, m).
pub const TOOL_NAMES: [&str; 3] = ["TOOL_DX", "TOOL_DY", "TOOL_DZ"];
/// Set-up names of the workpiece frame's pose error (m, rad).
pub const WP_NAMES: [&str; 6] = ["WP_DX", "WP_DY", "WP_DZ", "WP_DA", "WP_DB", "WP_DC"];

/// One axis' errors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AxisTruth {
    /// Coefficients of the component errors `E<d><axis>`, d = X Y Z A B C (m, rad). Linear
    /// axes: Legendre `P0..P3` of the normalised position over the stroke (index = degree);
    /// rotary axes: `[C1, S1, C2, S2]`, the coefficients of `cos q, sin q, cos 2q, sin 2q`.
    pub component: [[f64; 4]; 6],
    /// Location errors `E<d>0<axis>` (m, rad). Rotary axes: where the axis line passes and how
    /// it tilts (the two directions across the axis), and in the axis' own direction the
    /// constants of its own-direction component errors (`EZ0C` axial offset, `EC0C` zero
    /// offset). Linear axes: only rotations, the tilt of the direction of motion (squareness:
    /// `EC0Y`, `EB0Z`, `EA0Z`).
    pub location: [f64; 6],
}

/// Every error of a machine (SI): the machine's axes in its `q` order.
#[derive(Clone, Debug, PartialEq)]
pub struct Truth {
    pub axes: Vec<AxisTruth>,
    /// `TOOL_DX..DZ`: the tool point's offset in the tool frame (a longer tool: negative DZ).
    pub tool: [f64; 3],
    /// `WP_DX..WP_DC`: where the workpiece frame really sits, translation then rotation vector.
    pub workpiece: [f64; 6],
}

/// Why a name could not be set.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TruthError(String);

impl Truth {
    /// No error at all.
    pub fn zero(machine: &Machine) -> Self {
        Truth {
            axes: vec![AxisTruth::default(); machine.n_axes()],
            tool: [0.0; 3],
            workpiece: [0.0; 6],
        }
    }

    /// A random machine of realistic quality (`scale = 1`): rotary axis lines 5–30 µm off and
    /// 10–50 µrad tilted, squareness 5–30 µrad (random signs), component errors of a few µm or
    /// µrad over the stroke. No set-up error and no own-direction location constant: the
    /// truth lies in mtcal's default full model (add them with [`Truth::set`] or
    /// [`Truth::randomise_extras`]).
    pub fn random<R: Rng>(machine: &Machine, rng: &mut R, scale: f64) -> Self {
        let mut truth = Truth::zero(machine);
        let um = 1e-6 * scale;
        let signed = |rng: &mut R, lo: f64, hi: f64| {
            let v = rng.random_range(lo..hi);
            if rng.random_bool(0.5) { v } else { -v }
        };
        for (i, j) in machine.joints.iter().enumerate() {
            let own = j.own_direction();
            let a = &mut truth.axes[i];
            match j.kind {
                JointKind::Linear => {
                    for d in 0..6 {
                        // Higher degrees smaller: errors of real guideways are smooth.
                        let (first, size) = if d == own {
                            (1, 3.0)
                        } else if d < 3 {
                            (2, 2.0)
                        } else {
                            (0, 3.0)
                        };
                        let n = Normal::new(0.0, size * um).expect("finite sigma");
                        for (k, c) in a.component[d].iter_mut().enumerate().skip(first) {
                            *c = n.sample(rng) / (1.0 + k as f64 * 0.5);
                        }
                    }
                }
                JointKind::Rotary => {
                    for d in 0..6 {
                        let size = if d < 3 { 1.5 } else { 4.0 };
                        let n = Normal::new(0.0, size * um).expect("finite sigma");
                        for (k, c) in a.component[d].iter_mut().enumerate() {
                            *c = n.sample(rng) / if k < 2 { 1.0 } else { 2.0 };
                        }
                    }
                    for d in (0..3).filter(|&d| d != own) {
                        a.location[d] = signed(rng, 5.0, 30.0) * um;
                        a.location[d + 3] = signed(rng, 10.0, 50.0) * um;
                    }
                }
            }
        }
        let has = |c: char| machine.index(c);
        for (letter, dir, needs) in [('Y', 5, 'X'), ('Z', 4, 'X'), ('Z', 3, 'Y')] {
            if let (Some(i), Some(_)) = (has(letter), has(needs)) {
                truth.axes[i].location[dir] = signed(rng, 5.0, 30.0) * um;
            }
        }
        truth
    }

    /// Adds what mtcal's default model leaves out: every set-up error (tool offset a few µm,
    /// workpiece pose a few µm / µrad) and the own-direction location constants of the rotary
    /// axes. Such a truth needs the model [`Truth::model_config`] writes.
    pub fn randomise_extras<R: Rng>(&mut self, machine: &Machine, rng: &mut R, scale: f64) {
        let n = Normal::new(0.0, 5e-6 * scale).expect("finite sigma");
        for v in self.tool.iter_mut().chain(self.workpiece.iter_mut()) {
            *v = n.sample(rng);
        }
        for (i, j) in machine.joints.iter().enumerate() {
            if j.kind == JointKind::Rotary {
                let own = j.own_direction();
                self.axes[i].location[own] = n.sample(rng);
                self.axes[i].location[own + 3] = n.sample(rng);
            }
        }
    }

    /// Sets one single-valued parameter by name, SI value: `EX0C`, `EC0Y`, `TOOL_DZ`, `WP_DA`.
    pub fn set(&mut self, machine: &Machine, name: &str, value: f64) -> Result<(), TruthError> {
        if let Some(k) = TOOL_NAMES.iter().position(|n| *n == name) {
            self.tool[k] = value;
            return Ok(());
        }
        if let Some(k) = WP_NAMES.iter().position(|n| *n == name) {
            self.workpiece[k] = value;
            return Ok(());
        }
        let c: Vec<char> = name.chars().collect();
        if c.len() == 4 && c[0] == 'E' && (c[2] == '0' || c[2] == 'O') {
            let d = DIRECTIONS.iter().position(|&x| x == c[1]);
            if let (Some(d), Some(i)) = (d, machine.index(c[3])) {
                if machine.joints[i].kind == JointKind::Linear && d < 3 {
                    return Err(TruthError(format!("{name}: a linear axis has no location")));
                }
                self.axes[i].location[d] = value;
                return Ok(());
            }
        }
        Err(TruthError(format!(
            "{name}: not a location or set-up error of this machine"
        )))
    }

    /// Component and location errors of axis `i` at position `q` (SI), machine directions:
    /// `(component, location)`. A rotary axis' own-direction location errors are moved into
    /// its component values (they are their constants), leaving the location factor with the
    /// cross-axis terms only.
    pub fn axis_errors(&self, machine: &Machine, i: usize, q: f64) -> ([f64; 6], [f64; 6]) {
        let j = &machine.joints[i];
        let a = &self.axes[i];
        let mut comp = [0.0; 6];
        let mut loc = a.location;
        match j.kind {
            JointKind::Linear => {
                let p = legendre(j.stroke(), q);
                for d in 0..6 {
                    comp[d] = (0..4).map(|k| a.component[d][k] * p[k]).sum();
                }
                // A linear axis has no axis line: only the tilt of its motion.
                loc[0] = 0.0;
                loc[1] = 0.0;
                loc[2] = 0.0;
            }
            JointKind::Rotary => {
                let f = [q.cos(), q.sin(), (2.0 * q).cos(), (2.0 * q).sin()];
                for d in 0..6 {
                    comp[d] = (0..4).map(|k| a.component[d][k] * f[k]).sum();
                }
                let own = j.own_direction();
                for d in [own, own + 3] {
                    comp[d] += loc[d];
                    loc[d] = 0.0;
                }
            }
        }
        (comp, loc)
    }

    /// The error model this truth lives in, as an mtcal error-model configuration
    /// (`mtcal.errors/1`): the default full model (every component error, Legendre degree 3 and
    /// Fourier 2 harmonics), its ISO locations plus any non-zero own-direction constant, and the
    /// non-zero set-up errors.
    pub fn model_config(&self, machine: &Machine) -> String {
        let mut s = String::from(
            "# The model of the truth (written by mtcal-indsim): mtcal's default full model\n\
             # plus whatever the truth has beyond it.\nschema = \"mtcal.errors/1\"\ncomponents = \"all\"\n",
        );
        let extra_loc: Vec<String> = self.own_direction_names(machine);
        if extra_loc.is_empty() {
            s.push_str("locations = \"iso\"\n");
        } else {
            let mut all = iso_location_names(machine);
            all.extend(extra_loc);
            s.push_str(&format!("locations = [{}]\n", quoted(&all)));
        }
        let setup = self.setup_names();
        if !setup.is_empty() {
            s.push_str(&format!("setup = [{}]\n", quoted(&setup)));
        }
        s
    }

    /// The truth as an mtcal parameter file (`mtcal.params/1`, µm / µrad): single values in
    /// `[values]`, component errors as `coefficients` in the default model's basis order, every
    /// digit kept (the file reproduces the truth to the last bit of the decimal conversion).
    pub fn params_toml(&self, machine: &Machine) -> String {
        let mut s = String::from(
            "# Ground truth written by mtcal-indsim (um, urad). Model: the errors.toml beside it.\n\
             schema = \"mtcal.params/1\"\n\n[values]\n",
        );
        let mut names = iso_location_names(machine);
        names.extend(self.own_direction_names(machine));
        for name in &names {
            s.push_str(&format!(
                "{name} = {:?}\n",
                self.single(machine, name) * 1e6
            ));
        }
        for name in self.setup_names() {
            s.push_str(&format!(
                "{name} = {:?}\n",
                self.single(machine, &name) * 1e6
            ));
        }
        for (i, j) in machine.joints.iter().enumerate() {
            let own = j.own_direction();
            for d in 0..6 {
                let c = &self.axes[i].component[d];
                let kept: &[f64] = match j.kind {
                    JointKind::Rotary => c,
                    JointKind::Linear if d == own => &c[1..],
                    JointKind::Linear if d < 3 => &c[2..],
                    JointKind::Linear => c,
                };
                let vals: Vec<String> = kept.iter().map(|v| format!("{:?}", v * 1e6)).collect();
                s.push_str(&format!(
                    "\n[component.E{}{}]\ncoefficients = [{}]\n",
                    DIRECTIONS[d],
                    j.letter,
                    vals.join(", ")
                ));
            }
        }
        s
    }

    /// The terms mtcal's default model cannot hold (dropped by its bases): must be zero for
    /// [`Truth::params_toml`] to be exact.
    pub fn outside_default_bases(&self, machine: &Machine) -> Vec<String> {
        let mut out = Vec::new();
        for (i, j) in machine.joints.iter().enumerate() {
            if j.kind != JointKind::Linear {
                continue;
            }
            let own = j.own_direction();
            for d in 0..3 {
                let dropped = if d == own { 1 } else { 2 };
                for k in 0..dropped {
                    if self.axes[i].component[d][k] != 0.0 {
                        out.push(format!("E{}{} P{k}", DIRECTIONS[d], j.letter));
                    }
                }
            }
        }
        out
    }

    fn single(&self, machine: &Machine, name: &str) -> f64 {
        if let Some(k) = TOOL_NAMES.iter().position(|n| *n == name) {
            return self.tool[k];
        }
        if let Some(k) = WP_NAMES.iter().position(|n| *n == name) {
            return self.workpiece[k];
        }
        let c: Vec<char> = name.chars().collect();
        let d = DIRECTIONS
            .iter()
            .position(|&x| x == c[1])
            .expect("ISO name");
        self.axes[machine.index(c[3]).expect("axis of the machine")].location[d]
    }

    fn own_direction_names(&self, machine: &Machine) -> Vec<String> {
        let mut out = Vec::new();
        for (i, j) in machine.joints.iter().enumerate() {
            if j.kind == JointKind::Rotary {
                let own = j.own_direction();
                for d in [own, own + 3] {
                    if self.axes[i].location[d] != 0.0 {
                        out.push(format!("E{}0{}", DIRECTIONS[d], j.letter));
                    }
                }
            }
        }
        out
    }

    fn setup_names(&self) -> Vec<String> {
        let tool = TOOL_NAMES.iter().zip(self.tool.iter());
        let wp = WP_NAMES.iter().zip(self.workpiece.iter());
        tool.chain(wp)
            .filter(|(_, v)| **v != 0.0)
            .map(|(n, _)| n.to_string())
            .collect()
    }
}

/// The ISO location errors of mtcal's default model: squareness `EC0Y` (needs X and Y), `EB0Z`
/// (X and Z), `EA0Z` (Y and Z), then per rotary axis the positions and tilts across it.
pub fn iso_location_names(machine: &Machine) -> Vec<String> {
    let mut out = Vec::new();
    let has = |c: char| machine.index(c).is_some();
    for (name, a, b) in [("EC0Y", 'Y', 'X'), ("EB0Z", 'Z', 'X'), ("EA0Z", 'Z', 'Y')] {
        if has(a) && has(b) {
            out.push(name.to_string());
        }
    }
    for j in machine
        .joints
        .iter()
        .filter(|j| j.kind == JointKind::Rotary)
    {
        let own = j.own_direction();
        for base in [0, 3] {
            for d in (0..3).filter(|&d| d != own) {
                out.push(format!("E{}0{}", DIRECTIONS[base + d], j.letter));
            }
        }
    }
    out
}

/// Legendre `P0..P3` at the position `q` normalised to `[-1, 1]` over `stroke`.
pub fn legendre((lo, hi): (f64, f64), q: f64) -> [f64; 4] {
    let u = 2.0 * (q - lo) / (hi - lo) - 1.0;
    [
        1.0,
        u,
        0.5 * (3.0 * u * u - 1.0),
        0.5 * (5.0 * u * u * u - 3.0 * u),
    ]
}

fn quoted(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

impl ActualErrors for Truth {
    fn axis_errors(&self, machine: &Machine, i: usize, q: f64) -> ([f64; 6], [f64; 6]) {
        Truth::axis_errors(self, machine, i, q)
    }
    fn workpiece(&self) -> [f64; 6] {
        self.workpiece
    }
    fn tool(&self) -> [f64; 3] {
        self.tool
    }
}
