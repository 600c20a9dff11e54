//! Inverse kinematics of the nominal machine: tool-tip position and tool-axis direction in the
//! workpiece frame → every set of axis positions within the limits that produces them.
//!
//! # Method (closed form, no iteration)
//! Linear axes do not change orientation, so the tool's orientation in the workpiece frame is
//! `w_R_t = G0·Rot(c1, θ1)·G1·Rot(c2, θ2)·G2`, the G constant rotations of the joint origins and
//! branch ends and the workpiece-branch joints entering inverted (`Rot(a, θ)⁻¹ = Rot(−a, θ)`).
//! Moving the constants to the right gives `w_R_t = Rot(ω1, θ1)·Rot(ω2, θ2)·G` with
//! `ω1 = G0·c1`, `ω2 = G0·G1·c2`, `G = G0·G1·G2`, all constant, and the tool axis
//! `v = Rot(ω1, θ1)·Rot(ω2, θ2)·u` with `u = G·ẑ`. Here "1" is the rotary axis nearest the
//! workpiece along the chain workpiece → machine frame → tool (on a trunnion `wCAFYXZt`: C, then
//! A). The two angles follow from Paden–Kahan subproblem 2 (0, 1 or 2 solutions); with the angles
//! fixed the tool point is affine in the three linear axis positions, and the 3 × 3 linear system
//! built from [`Machine::tool_in_workpiece`] at zero linear positions and unit steps is solved
//! exactly. Each angle then gets its 2π-periodic alternatives within its limits (an unlimited
//! axis: the one nearest the reference position, else the one in (−π, π]) and every candidate is
//! filtered by all limits.
//!
//! Supported machines: exactly three linear axes (any letters, any linearly independent
//! directions) and zero, one or two rotary axes anywhere in either branch. Everything is SI:
//! metres, radians. The tool axis is the tool link's +z, from the tool point into the spindle.
//!
//! # Singular configurations
//! Axis `1` is free when the requested tool axis is within `singular_tol_rad` of its line
//! (`∠(v, ±ω1) ≤ singular_tol_rad`, e.g. the tool along the C axis of a trunnion at A = 0);
//! axis `2` is free when `u` is within that angle of `±ω2` (the second axis cannot tilt the
//! tool at all). Both are reported as [`IkError::Singular`], which carries the solutions with the
//! free axis held at its reference position (or 0): they reproduce the tip exactly and the tool
//! axis to within the tolerance.

use crate::machine::{AxisKind, Machine, Side};
use crate::rigid::axis_rotation;
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::{PI, TAU};
use std::fmt;

/// Tolerances and the reference position of [`inverse_kinematics`].
#[derive(Clone, Debug, PartialEq)]
pub struct IkOptions {
    /// The current axis positions (canonical order, one per axis). An unlimited rotary axis
    /// returns the angle nearest its reference; solutions are sorted by their distance from it;
    /// in a singular configuration the free axis is held at its reference.
    pub reference: Option<Vec<f64>>,
    /// How far (m or rad) a solution may lie outside an axis' limits and still be returned.
    pub limit_tol: f64,
    /// Angle (rad) within which the tool axis counts as parallel to a rotary axis' line, which
    /// leaves that axis' angle free (see the module doc).
    pub singular_tol_rad: f64,
    /// Orientation tolerance (rad, approximately): a tool axis this close to the set the rotary
    /// axes can reach counts as reachable (for a 3-axis machine: this close to the fixed one).
    pub orientation_tol_rad: f64,
}

impl Default for IkOptions {
    fn default() -> Self {
        Self {
            reference: None,
            limit_tol: 1e-9,
            singular_tol_rad: 1e-6,
            orientation_tol_rad: 1e-9,
        }
    }
}

/// One set of axis positions reaching the requested tool pose.
#[derive(Clone, Debug, PartialEq)]
pub struct IkSolution {
    /// Axis positions in canonical order ([`Machine::axes`]): m and rad.
    pub q: Vec<f64>,
}

/// Lower or upper limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bound {
    Lower,
    Upper,
}

/// An axis position outside its limits.
#[derive(Clone, Debug, PartialEq)]
pub struct LimitViolation {
    pub axis: char,
    pub kind: AxisKind,
    pub position: f64,
    pub bound: Bound,
    /// The violated limit (m or rad).
    pub limit: f64,
}

impl LimitViolation {
    /// How far outside the limit (m or rad, positive).
    pub fn excess(&self) -> f64 {
        (self.position - self.limit).abs()
    }
}

impl fmt::Display for LimitViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = match self.bound {
            Bound::Lower => "below its lower",
            Bound::Upper => "above its upper",
        };
        // In the units programs and files use (SI inside, mm and degrees for people).
        let v = |x: f64| match self.kind {
            AxisKind::Linear => format!("{} mm", round_to(x * 1e3, 4)),
            AxisKind::Rotary => format!("{}°", round_to(x.to_degrees(), 4)),
        };
        write!(
            f,
            "axis {} = {} is {} limit {} by {}",
            self.axis,
            v(self.position),
            side,
            v(self.limit),
            v(self.excess())
        )
    }
}

/// `x` with at most `decimals` decimals, without trailing zeros (and never `-0`).
fn round_to(x: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    let r = (x * scale).round() / scale;
    if r == 0.0 { 0.0 } else { r }
}

/// Why no solution is returned.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IkError {
    #[error("the {what} is not finite")]
    NotFinite { what: &'static str },
    #[error(
        "the tool-axis vector is zero; give the direction from the tool point into the spindle"
    )]
    ZeroToolAxis,
    #[error("the reference has {got} positions but the machine has {expected} axes")]
    ReferenceLength { got: usize, expected: usize },
    #[error("inverse kinematics needs {needs}; machine `{name}` has axes {letters}")]
    UnsupportedMachine {
        name: String,
        letters: String,
        needs: &'static str,
    },
    #[error(
        "rotary axes {first} and {second} are parallel: together they only turn the tool about \
         one direction, so the tool axis does not determine their angles"
    )]
    ParallelRotaryAxes { first: char, second: char },
    #[error(
        "the linear axes {letters} are not linearly independent at this orientation; the tool \
         point cannot be solved for"
    )]
    DependentLinearAxes { letters: String },
    #[error(
        "singular configuration: the tool axis is within {angle_rad:.3e} rad of the line of \
         rotary axis {free_axis}, so {free_axis} is free ({n} solutions with {free_axis} held at \
         {held_at} rad are attached)",
        n = held.len()
    )]
    Singular {
        /// The axis whose angle the tool axis does not determine.
        free_axis: char,
        /// Angle between the tool axis (or, for the second axis, the tool axis it turns) and the
        /// free axis' line, rad.
        angle_rad: f64,
        /// Where the free axis was held for `held`: the reference position, else 0 (clamped to
        /// its limits).
        held_at: f64,
        /// Solutions within the limits with the free axis held at `held_at`: exact tool point,
        /// tool axis within `singular_tol_rad`.
        held: Vec<IkSolution>,
    },
    #[error(
        "the tool axis ({:.9}, {:.9}, {:.9}) cannot be reached: {why}",
        tool_axis[0], tool_axis[1], tool_axis[2]
    )]
    Unreachable { tool_axis: [f64; 3], why: String },
    #[error(
        "no solution within the axis limits; the nearest, {}, has {violation}",
        fmt_q(&nearest.q)
    )]
    OutsideLimits {
        /// The candidate with the smallest largest limit violation (relative to the axis' range).
        nearest: IkSolution,
        /// Its largest violation.
        violation: LimitViolation,
    },
}

fn fmt_q(q: &[f64]) -> String {
    let parts: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
    format!("q = [{}]", parts.join(", "))
}

/// Nominal tool point and unit tool axis in the workpiece frame at axis positions `q`.
pub fn forward_kinematics(machine: &Machine, q: &[f64]) -> (Vector3<f64>, Vector3<f64>) {
    let t = machine.tool_in_workpiece(q);
    (t.t, t.r.column(2).into_owned())
}

/// The constant structure of the orientation: `w_R_t = Rot(ω1, θ1)·Rot(ω2, θ2)·G`.
#[derive(Debug)]
struct Orientation {
    /// Machine indices of the rotary axes in chain order (workpiece → frame → tool).
    idx: Vec<usize>,
    /// Their rotation axes in the workpiece frame (sign included: workpiece-branch axes negated).
    omega: Vec<Vector3<f64>>,
    /// Tool axis with every rotary axis at zero: `G·ẑ`.
    u: Vector3<f64>,
}

fn orientation_structure(machine: &Machine) -> Orientation {
    let axes = machine.axes();
    let wb = machine.branch(Side::Workpiece);
    let tb = machine.branch(Side::Tool);
    let mut idx = Vec::with_capacity(2);
    let mut omega = Vec::with_capacity(2);
    // w_R_t = E_wᵀ · Π_{reversed} (Rot(a_j, θ_j)ᵀ · O_jᵀ) · Π (O_j · Rot(a_j, θ_j)) · E_t
    let mut g = wb.end().r.transpose();
    for &i in wb.joints().iter().rev() {
        let ax = &axes[i];
        if ax.kind() == AxisKind::Rotary {
            idx.push(i);
            omega.push(g * -ax.direction());
        }
        g *= ax.origin().r.transpose();
    }
    for &i in tb.joints() {
        let ax = &axes[i];
        g *= ax.origin().r;
        if ax.kind() == AxisKind::Rotary {
            idx.push(i);
            omega.push(g * ax.direction());
        }
    }
    g *= tb.end().r;
    Orientation {
        idx,
        omega,
        u: g.column(2).into_owned(),
    }
}

/// Paden–Kahan subproblem 1: the angle θ with `Rot(ω, θ)·p` closest to `q` (exact when
/// reachable). `ω` unit.
fn subproblem1(omega: &Vector3<f64>, p: &Vector3<f64>, q: &Vector3<f64>) -> f64 {
    let pp = p - omega * omega.dot(p);
    let qp = q - omega * omega.dot(q);
    omega.dot(&pp.cross(&qp)).atan2(pp.dot(&qp))
}

/// Angle between `v` and the line of unit `w` (0..π/2).
fn angle_to_line(v: &Vector3<f64>, w: &Vector3<f64>) -> f64 {
    v.cross(w).norm().atan2(v.dot(w).abs())
}

/// `θ` wrapped to (−π, π].
fn wrap_pi(theta: f64) -> f64 {
    let w = theta.rem_euclid(TAU);
    if w > PI { w - TAU } else { w }
}

/// Sets the linear axes of `q` so that the nominal tool point sits at `tip` (workpiece frame, m)
/// with the rotary axes as they are in `q`: the "linear axes follow the ball" move of R-test
/// and five-axis ball-bar paths. Exact (the tool point is affine in the linear positions when
/// the rotary axes are fixed). Needs exactly three linear axes; fails if they are dependent.
/// Limits are not checked: use [`Machine::within_limits`].
pub fn follow_point(machine: &Machine, q: &mut [f64], tip: &Vector3<f64>) -> Result<(), IkError> {
    let linear: Vec<usize> = (0..machine.n_axes())
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
        .collect();
    if linear.len() != 3 || q.len() != machine.n_axes() {
        return Err(IkError::UnsupportedMachine {
            name: machine.name().to_string(),
            letters: machine.letters(),
            needs: "exactly 3 linear axes (and one position per axis)",
        });
    }
    if !tip.iter().chain(q.iter()).all(|x| x.is_finite()) {
        return Err(IkError::NotFinite {
            what: "tool point or axis position",
        });
    }
    let opts = IkOptions::default();
    let solver = Solver {
        machine,
        tip,
        opts: &opts,
        linear: [linear[0], linear[1], linear[2]],
        rot: &[],
    };
    let x = solver
        .solve_linear(q)
        .ok_or_else(|| IkError::UnsupportedMachine {
            name: machine.name().to_string(),
            letters: machine.letters(),
            needs: "linearly independent linear axes at this orientation",
        })?;
    for (c, &i) in solver.linear.iter().enumerate() {
        q[i] = x[c];
    }
    Ok(())
}

/// Inverse kinematics of the nominal machine: every set of axis positions (canonical order)
/// within the limits that puts the tool point at `tip` with its axis along `tool_axis`, both in
/// the workpiece frame (m; the axis need not be unit).
///
/// Solutions are sorted by the rotary axes' total travel from `opts.reference` (then the linear
/// axes' travel), or without a reference by the rotary positions in canonical order.
///
/// Errors: non-finite input, zero axis, unsupported machine ([`IkError::UnsupportedMachine`]:
/// needs 3 linear and at most 2 rotary axes), a singular configuration
/// ([`IkError::Singular`], see the module doc), an orientation the rotary axes cannot produce
/// ([`IkError::Unreachable`]), and solutions that all violate a limit
/// ([`IkError::OutsideLimits`], naming the nearest candidate's worst axis and limit).
pub fn inverse_kinematics(
    machine: &Machine,
    tip: &Vector3<f64>,
    tool_axis: &Vector3<f64>,
    opts: &IkOptions,
) -> Result<Vec<IkSolution>, IkError> {
    if !tip.iter().all(|v| v.is_finite()) {
        return Err(IkError::NotFinite { what: "tool tip" });
    }
    if !tool_axis.iter().all(|v| v.is_finite()) {
        return Err(IkError::NotFinite { what: "tool axis" });
    }
    let norm = tool_axis.norm();
    if norm == 0.0 || !norm.is_finite() {
        return Err(IkError::ZeroToolAxis);
    }
    let v = tool_axis / norm;
    let n = machine.n_axes();
    if let Some(r) = &opts.reference {
        if r.len() != n {
            return Err(IkError::ReferenceLength {
                got: r.len(),
                expected: n,
            });
        }
        if !r.iter().all(|x| x.is_finite()) {
            return Err(IkError::NotFinite { what: "reference" });
        }
    }
    let linear: Vec<usize> = (0..n)
        .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
        .collect();
    let ori = orientation_structure(machine);
    if linear.len() != 3 || ori.idx.len() > 2 {
        return Err(IkError::UnsupportedMachine {
            name: machine.name().to_string(),
            letters: machine.letters(),
            needs: "exactly 3 linear axes and 0, 1 or 2 rotary axes",
        });
    }
    let linear = [linear[0], linear[1], linear[2]];
    let solver = Solver {
        machine,
        tip,
        opts,
        linear,
        rot: &ori.idx,
    };
    let letter = |k: usize| machine.axes()[ori.idx[k]].letter().as_char();
    let unreachable = |why: String| IkError::Unreachable {
        tool_axis: [v.x, v.y, v.z],
        why,
    };
    let (u, otol, stol) = (ori.u, opts.orientation_tol_rad, opts.singular_tol_rad);
    let roots: Vec<[f64; 2]> = match ori.idx.len() {
        0 => {
            let angle = v.cross(&u).norm().atan2(v.dot(&u));
            if angle > otol {
                return Err(unreachable(format!(
                    "the machine has no rotary axis and its tool axis is fixed at \
                     ({:.9}, {:.9}, {:.9}), {angle:.3e} rad away",
                    u.x, u.y, u.z
                )));
            }
            vec![[0.0; 2]]
        }
        1 => {
            let w = ori.omega[0];
            let free = angle_to_line(&u, &w);
            if free <= stol {
                let miss = v.cross(&u).norm().atan2(v.dot(&u));
                if miss > stol + otol {
                    return Err(unreachable(format!(
                        "rotary axis {} turns about the tool axis itself, which stays at \
                         ({:.9}, {:.9}, {:.9})",
                        letter(0),
                        u.x,
                        u.y,
                        u.z
                    )));
                }
                let held_at = solver.hold_value(ori.idx[0]);
                let held = solver.expand(&[[held_at, 0.0]], Some(0))?;
                return Err(IkError::Singular {
                    free_axis: letter(0),
                    angle_rad: free,
                    held_at,
                    held,
                });
            }
            if (w.dot(&u) - w.dot(&v)).abs() > otol {
                return Err(unreachable(format!(
                    "rotary axis {} keeps the tool axis at {:.6} rad from its own line; the \
                     requested axis is at {:.6} rad",
                    letter(0),
                    w.dot(&u).clamp(-1.0, 1.0).acos(),
                    w.dot(&v).clamp(-1.0, 1.0).acos()
                )));
            }
            vec![[subproblem1(&w, &u, &v), 0.0]]
        }
        _ => {
            let (w1, w2) = (ori.omega[0], ori.omega[1]);
            let c = w1.dot(&w2);
            let d = w1.cross(&w2).norm_squared();
            if d < 1e-18 {
                return Err(IkError::ParallelRotaryAxes {
                    first: letter(0),
                    second: letter(1),
                });
            }
            // First axis free: the tool axis lies on its line.
            let free1 = angle_to_line(&v, &w1);
            if free1 <= stol {
                let held_at = solver.hold_value(ori.idx[0]);
                let z = axis_rotation(&w1, -held_at) * v;
                if (w2.dot(&u) - w2.dot(&z)).abs() > stol + otol {
                    return Err(unreachable(format!(
                        "the tool axis lies on the line of rotary axis {}, which rotary axis {} \
                         cannot tilt the tool to",
                        letter(0),
                        letter(1)
                    )));
                }
                let t2 = subproblem1(&w2, &u, &z);
                let held = solver.expand(&[[held_at, t2]], Some(0))?;
                return Err(IkError::Singular {
                    free_axis: letter(0),
                    angle_rad: free1,
                    held_at,
                    held,
                });
            }
            // Second axis free: it turns the tool about the tool's own axis.
            let free2 = angle_to_line(&u, &w2);
            if free2 <= stol {
                let held_at = solver.hold_value(ori.idx[1]);
                if (w1.dot(&u) - w1.dot(&v)).abs() > stol + otol {
                    return Err(unreachable(format!(
                        "rotary axis {} turns about the tool axis itself and rotary axis {} \
                         cannot tilt the tool to the requested direction",
                        letter(1),
                        letter(0)
                    )));
                }
                let t1 = subproblem1(&w1, &u, &v);
                let held = solver.expand(&[[t1, held_at]], Some(1))?;
                return Err(IkError::Singular {
                    free_axis: letter(1),
                    angle_rad: free2,
                    held_at,
                    held,
                });
            }
            // Subproblem 2: z = Rot(ω2, θ2)·u = Rot(ω1, −θ1)·v, z = α ω1 + β ω2 + γ ω1×ω2.
            let (a1, a2) = (w1.dot(&v), w2.dot(&u));
            let alpha = (a1 - c * a2) / d;
            let beta = (a2 - c * a1) / d;
            let num = 1.0 - alpha * alpha - beta * beta - 2.0 * alpha * beta * c;
            // Near tangency num changes to first order with the tool axis: accept a small miss.
            let gammas: Vec<f64> = if num < -4.0 * otol {
                return Err(unreachable(format!(
                    "rotary axes {} and {} cannot turn the tool to this direction",
                    letter(0),
                    letter(1)
                )));
            } else if num <= 0.0 {
                vec![0.0]
            } else {
                let g = (num / d).sqrt();
                if g * d.sqrt() < 1e-15 {
                    vec![0.0]
                } else {
                    vec![g, -g]
                }
            };
            let cross = w1.cross(&w2);
            gammas
                .iter()
                .map(|&g| {
                    let z = w1 * alpha + w2 * beta + cross * g;
                    [subproblem1(&w1, &z, &v), subproblem1(&w2, &u, &z)]
                })
                .collect()
        }
    };
    let sols = solver.expand(&roots, None)?;
    Ok(sols)
}

struct Solver<'a> {
    machine: &'a Machine,
    tip: &'a Vector3<f64>,
    opts: &'a IkOptions,
    linear: [usize; 3],
    /// Rotary axis indices in chain order (the order of the root angles).
    rot: &'a [usize],
}

impl Solver<'_> {
    /// Where to hold a free rotary axis: its reference, else 0 clamped into its limits.
    fn hold_value(&self, axis: usize) -> f64 {
        if let Some(r) = &self.opts.reference {
            return r[axis];
        }
        match self.machine.axes()[axis].limits() {
            Some((lo, hi)) => 0.0f64.clamp(lo, hi),
            None => 0.0,
        }
    }

    /// Values of rotary axis `axis` equal to `theta` modulo 2π: all within its limits, or the
    /// single nearest outside if none; an unlimited axis gets the one nearest its reference,
    /// else the one in (−π, π]. A `fixed` (held) axis keeps `theta`.
    fn alternatives(&self, axis: usize, theta: f64, fixed: bool) -> Vec<f64> {
        if fixed {
            return vec![theta];
        }
        let tol = self.opts.limit_tol;
        match self.machine.axes()[axis].limits() {
            None => match &self.opts.reference {
                Some(r) => vec![theta + TAU * ((r[axis] - theta) / TAU).round()],
                None => vec![wrap_pi(theta)],
            },
            Some((lo, hi)) => {
                let k_min = ((lo - tol - theta) / TAU).ceil() as i64;
                let k_max = ((hi + tol - theta) / TAU).floor() as i64;
                if k_min <= k_max {
                    (k_min..=k_max).map(|k| theta + TAU * k as f64).collect()
                } else {
                    // theta + 2π(k_min − 1) < lo and theta + 2π·k_min > hi.
                    let below = theta + TAU * (k_min - 1) as f64;
                    let above = theta + TAU * k_min as f64;
                    vec![if lo - below <= above - hi {
                        below
                    } else {
                        above
                    }]
                }
            }
        }
    }

    /// Linear positions putting the tool point at the tip with the rotary axes as in `q`.
    fn solve_linear(&self, q: &mut [f64]) -> Option<Vector3<f64>> {
        for &i in &self.linear {
            q[i] = 0.0;
        }
        let p0 = self.machine.tool_in_workpiece(q).t;
        let mut a = Matrix3::zeros();
        for (c, &i) in self.linear.iter().enumerate() {
            q[i] = 1.0;
            a.set_column(c, &(self.machine.tool_in_workpiece(q).t - p0));
            q[i] = 0.0;
        }
        let scale: f64 = (0..3).map(|c| a.column(c).norm()).product();
        let det = a.determinant().abs();
        if det.is_nan() || det <= 1e-9 * scale {
            return None;
        }
        a.lu().solve(&(self.tip - p0))
    }

    /// Expands root angle pairs (chain order) into solutions: linear positions, 2π alternatives,
    /// limit filter, sorting. `fixed`: the root index of an axis held in place (singular case).
    fn expand(&self, roots: &[[f64; 2]], fixed: Option<usize>) -> Result<Vec<IkSolution>, IkError> {
        let n = self.machine.n_axes();
        let mut q = vec![0.0; n];
        let mut sols: Vec<IkSolution> = Vec::new();
        let mut nearest: Option<(f64, IkSolution, LimitViolation)> = None;
        let mut any_linear = false;
        for root in roots {
            for (k, &i) in self.rot.iter().enumerate() {
                q[i] = root[k];
            }
            let Some(x) = self.solve_linear(&mut q) else {
                continue;
            };
            any_linear = true;
            for (c, &i) in self.linear.iter().enumerate() {
                q[i] = x[c];
            }
            let alts: Vec<Vec<f64>> = self
                .rot
                .iter()
                .enumerate()
                .map(|(k, &i)| self.alternatives(i, root[k], fixed == Some(k)))
                .collect();
            let counts: Vec<usize> = alts.iter().map(Vec::len).collect();
            let total: usize = counts.iter().product();
            for mut combo in 0..total {
                for (k, &i) in self.rot.iter().enumerate() {
                    q[i] = alts[k][combo % counts[k]];
                    combo /= counts[k];
                }
                match self.worst_violation(&q) {
                    None => sols.push(IkSolution { q: q.clone() }),
                    Some((rel, viol)) => {
                        if nearest.as_ref().is_none_or(|(best, _, _)| rel < *best) {
                            nearest = Some((rel, IkSolution { q: q.clone() }, viol));
                        }
                    }
                }
            }
        }
        if !any_linear {
            return Err(IkError::DependentLinearAxes {
                letters: self
                    .linear
                    .iter()
                    .map(|&i| self.machine.axes()[i].letter().as_char())
                    .collect(),
            });
        }
        if sols.is_empty() && fixed.is_none() {
            let (_, nearest, violation) = nearest.expect("a candidate outside the limits");
            return Err(IkError::OutsideLimits { nearest, violation });
        }
        self.sort(&mut sols);
        Ok(sols)
    }

    /// The largest violation of `q` relative to its axis' range, and that violation.
    fn worst_violation(&self, q: &[f64]) -> Option<(f64, LimitViolation)> {
        worst_violation(self.machine, q, self.opts.limit_tol)
    }

    fn sort(&self, sols: &mut [IkSolution]) {
        let mut rot_sorted = self.rot.to_vec();
        rot_sorted.sort_unstable();
        match &self.opts.reference {
            Some(r) => {
                let key = |s: &IkSolution| {
                    let rot: f64 = rot_sorted.iter().map(|&i| (s.q[i] - r[i]).abs()).sum();
                    let lin: f64 = self.linear.iter().map(|&i| (s.q[i] - r[i]).powi(2)).sum();
                    (rot, lin)
                };
                sols.sort_by(|a, b| {
                    let (ka, kb) = (key(a), key(b));
                    ka.0.total_cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
                });
            }
            None => sols.sort_by(|a, b| {
                rot_sorted
                    .iter()
                    .map(|&i| a.q[i].total_cmp(&b.q[i]))
                    .find(|o| o.is_ne())
                    .unwrap_or(std::cmp::Ordering::Equal)
            }),
        }
    }
}

/// The largest violation of `q`'s axis limits (beyond `tol`, m or rad), relative to the axis'
/// range, and that violation; `None` when every axis is within its limits.
pub fn worst_violation(machine: &Machine, q: &[f64], tol: f64) -> Option<(f64, LimitViolation)> {
    let mut worst: Option<(f64, LimitViolation)> = None;
    for (ax, &v) in machine.axes().iter().zip(q) {
        let Some((lo, hi)) = ax.limits() else {
            continue;
        };
        let (bound, limit) = if v < lo - tol {
            (Bound::Lower, lo)
        } else if v > hi + tol {
            (Bound::Upper, hi)
        } else {
            continue;
        };
        let rel = (v - limit).abs() / (hi - lo);
        if worst.as_ref().is_none_or(|(w, _)| rel > *w) {
            worst = Some((
                rel,
                LimitViolation {
                    axis: ax.letter().as_char(),
                    kind: ax.kind(),
                    position: v,
                    bound,
                    limit,
                },
            ));
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::machine::{BranchSpec, JointSpec, MachineSpec};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use proptest::prelude::*;

    #[test]
    fn a_limit_violation_reads_in_mm_and_degrees() {
        let linear = LimitViolation {
            axis: 'X',
            kind: AxisKind::Linear,
            position: 0.9,
            bound: Bound::Upper,
            limit: 0.375,
        };
        assert_eq!(
            linear.to_string(),
            "axis X = 900 mm is above its upper limit 375 mm by 525 mm"
        );
        let rotary = LimitViolation {
            axis: 'A',
            kind: AxisKind::Rotary,
            position: (-120.0f64).to_radians(),
            bound: Bound::Lower,
            limit: (-30.0f64).to_radians(),
        };
        assert_eq!(
            rotary.to_string(),
            "axis A = -120° is below its lower limit -30° by 90°"
        );
    }

    /// Hand-built test machines: random pivot offsets and small rotations in every joint origin
    /// and branch end, drawn from a list of numbers in [-1, 1].
    struct Builder<'a> {
        rnd: std::slice::Iter<'a, f64>,
        offset: f64,
        tilt: f64,
    }

    impl Builder<'_> {
        fn next(&mut self) -> f64 {
            *self.rnd.next().unwrap_or(&0.0)
        }
        fn origin(&mut self, base: [f64; 3]) -> Isometry3<f64> {
            let t = Vector3::from(base)
                + Vector3::new(self.next(), self.next(), self.next()) * self.offset;
            let r = Vector3::new(self.next(), self.next(), self.next()) * self.tilt;
            Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_scaled_axis(r))
        }
        fn joint(
            &mut self,
            letter: char,
            axis: [f64; 3],
            base: [f64; 3],
            limits: Option<(f64, f64)>,
        ) -> JointSpec {
            let kind = if "ABC".contains(letter) {
                AxisKind::Rotary
            } else {
                AxisKind::Linear
            };
            JointSpec {
                letter,
                kind,
                origin: self.origin(base),
                axis: Vector3::from(axis),
                limits,
            }
        }
    }

    const LIN: Option<(f64, f64)> = Some((-0.5, 0.5));

    #[derive(Clone, Copy, Debug)]
    enum Layout {
        /// wCAFYXZt: trunnion A carrying C on the table, Y X Z in the tool branch.
        Cafyxz,
        /// wCAXFYZt: trunnion on an X table.
        Caxfyz,
        /// wCBFXYZt: table-table B/C (source 002 §7.3).
        TableBc,
        /// wYXFZCAt: head-head, C then A in the tool branch.
        HeadCa,
        /// wCYFXZBt: C table, B head.
        Mixed,
    }

    const LAYOUTS: [Layout; 5] = [
        Layout::Cafyxz,
        Layout::Caxfyz,
        Layout::TableBc,
        Layout::HeadCa,
        Layout::Mixed,
    ];

    fn build(layout: Layout, rnd: &[f64], offset: f64, tilt: f64) -> Machine {
        let mut b = Builder {
            rnd: rnd.iter(),
            offset,
            tilt,
        };
        let b = &mut b;
        let (x, y, z) = ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.]);
        let (nx, ny, nz) = ([-1., 0., 0.], [0., -1., 0.], [0., 0., -1.]);
        let o = [0.0; 3];
        let a_lim = Some((-2.0, 2.0));
        let (wp, tool) = match layout {
            Layout::Cafyxz => (
                vec![
                    b.joint('A', nx, [0., 0., 0.2], a_lim),
                    b.joint('C', nz, [0., 0., -0.05], Some((-4.0, 4.0))),
                ],
                vec![
                    b.joint('Y', y, o, LIN),
                    b.joint('X', x, o, LIN),
                    b.joint('Z', z, [0., 0., 0.4], LIN),
                ],
            ),
            Layout::Caxfyz => (
                vec![
                    b.joint('X', nx, o, LIN),
                    b.joint('A', nx, [0., 0., 0.15], a_lim),
                    b.joint('C', nz, [0., 0., 0.03], None),
                ],
                vec![b.joint('Y', y, o, LIN), b.joint('Z', z, [0., 0., 0.3], LIN)],
            ),
            Layout::TableBc => (
                vec![
                    b.joint(
                        'B',
                        ny,
                        [0., 0., 0.1],
                        Some((-105f64.to_radians(), 15f64.to_radians())),
                    ),
                    b.joint('C', nz, [0., 0., 0.02], None),
                ],
                vec![
                    b.joint('X', x, o, LIN),
                    b.joint('Y', y, o, LIN),
                    b.joint('Z', z, [0., 0., 0.35], LIN),
                ],
            ),
            Layout::HeadCa => (
                vec![b.joint('X', nx, o, LIN), b.joint('Y', ny, o, LIN)],
                vec![
                    b.joint('Z', z, [0., 0., 0.5], LIN),
                    b.joint('C', z, [0., 0., -0.1], None),
                    b.joint('A', x, [0., 0., -0.15], a_lim),
                ],
            ),
            Layout::Mixed => (
                vec![
                    b.joint('Y', ny, o, LIN),
                    b.joint('C', nz, [0., 0., 0.05], None),
                ],
                vec![
                    b.joint('X', x, o, LIN),
                    b.joint('Z', z, [0., 0., 0.45], LIN),
                    b.joint('B', y, [0., 0., -0.12], Some((-1.9, 1.9))),
                ],
            ),
        };
        let wp_end = b.origin([0., 0., 0.01]);
        let tool_end = b.origin([0., 0., -0.1]);
        Machine::try_new(&MachineSpec {
            name: format!("{layout:?}"),
            workpiece: BranchSpec {
                joints: wp,
                end: wp_end,
            },
            tool: BranchSpec {
                joints: tool,
                end: tool_end,
            },
        })
        .unwrap()
    }

    fn same_angle(a: f64, b: f64, tol: f64) -> bool {
        wrap_pi(a - b).abs() < tol
    }

    fn same_q(m: &Machine, a: &[f64], b: &[f64], tol: f64) -> bool {
        m.axes().iter().enumerate().all(|(i, ax)| match ax.kind() {
            AxisKind::Linear => (a[i] - b[i]).abs() < tol,
            AxisKind::Rotary => same_angle(a[i], b[i], tol),
        })
    }

    /// The tilting (second in the chain) axis away from its singular zero.
    fn tilt_axis(layout: Layout) -> char {
        match layout {
            Layout::Cafyxz | Layout::Caxfyz | Layout::HeadCa => 'A',
            Layout::TableBc | Layout::Mixed => 'B',
        }
    }

    /// Axis positions within the limits from numbers in [0, 1], the tilt axis at least
    /// `margin` away from zero; None if that is impossible for these numbers.
    fn draw_q(m: &Machine, layout: Layout, unit: &[f64], margin: f64) -> Option<Vec<f64>> {
        let q: Vec<f64> = m
            .axes()
            .iter()
            .zip(unit)
            .map(|(ax, &s)| {
                let (lo, hi) = ax.limits().unwrap_or((-PI, PI));
                lo + (hi - lo) * s
            })
            .collect();
        let t = m.axis_index(tilt_axis(layout)).unwrap();
        (q[t].abs() >= margin).then_some(q)
    }

    #[test]
    fn orientation_structure_matches_forward_kinematics() {
        let rnd: Vec<f64> = (0..80)
            .map(|k| ((k * 37 % 23) as f64 / 11.5) - 1.0)
            .collect();
        for layout in LAYOUTS {
            let m = build(layout, &rnd, 0.1, 0.02);
            let ori = orientation_structure(&m);
            let q: Vec<f64> = (0..m.n_axes()).map(|i| 0.3 - 0.17 * i as f64).collect();
            let r = axis_rotation(&ori.omega[0], q[ori.idx[0]])
                * axis_rotation(&ori.omega[1], q[ori.idx[1]]);
            let fk = m.tool_in_workpiece(&q);
            assert!((r * ori.u - fk.r.column(2)).norm() < 1e-14, "{layout:?}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        #[test]
        fn forward_of_inverse_is_identity(
            layout in prop::sample::select(LAYOUTS.to_vec()),
            rnd in prop::collection::vec(-1.0..1.0f64, 60),
            unit in prop::collection::vec(0.0..1.0f64, 5),
            with_reference in any::<bool>(),
        ) {
            let m = build(layout, &rnd, 0.1, 0.01);
            let q = draw_q(&m, layout, &unit, 0.15);
            prop_assume!(q.is_some());
            let q = q.unwrap();
            let (tip, axis) = forward_kinematics(&m, &q);
            let opts = IkOptions {
                reference: with_reference.then(|| q.clone()),
                ..IkOptions::default()
            };
            let sols = inverse_kinematics(&m, &tip, &axis, &opts)
                .map_err(|e| TestCaseError::fail(format!("{layout:?} {q:?}: {e}")))?;
            prop_assert!(!sols.is_empty());
            for s in &sols {
                prop_assert!(m.within_limits(&s.q, 1e-9));
                let (t2, a2) = forward_kinematics(&m, &s.q);
                prop_assert!((t2 - tip).norm() < 1e-9, "{layout:?} tip {:e}", (t2 - tip).norm());
                prop_assert!((a2 - axis).norm() < 1e-9, "{layout:?} axis {:e}", (a2 - axis).norm());
            }
            prop_assert!(
                sols.iter().any(|s| same_q(&m, &s.q, &q, 1e-8)),
                "{layout:?}: {q:?} not among {sols:?}"
            );
            if with_reference {
                prop_assert!(sols[0].q.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-8));
            }
        }
    }

    fn trunnion(a_limits: (f64, f64)) -> Machine {
        let mut spec = build(Layout::Cafyxz, &[], 0.0, 0.0).to_spec();
        spec.workpiece.joints[0].limits = Some(a_limits);
        Machine::try_new(&spec).unwrap()
    }

    #[test]
    fn two_branches_and_two_pi_alternatives() {
        // A in [-2, 2], C in [-4, 4]: (A, C) and (-A, C + π), each C with its 2π twin if in range.
        let m = trunnion((-2.0, 2.0));
        let q = [0.1, -0.2, 0.05, 0.7, 0.5];
        let (tip, axis) = forward_kinematics(&m, &q);
        let sols = inverse_kinematics(&m, &tip, &axis, &IkOptions::default()).unwrap();
        let a: Vec<f64> = sols.iter().map(|s| s.q[3]).collect();
        let c: Vec<f64> = sols.iter().map(|s| s.q[4]).collect();
        // C = 0.5 (twin 0.5 - 2π out of range) and C = 0.5 - π, 0.5 + π (both within ±4).
        assert_eq!(sols.len(), 3, "{sols:?}");
        assert!(a.iter().filter(|&&x| (x - 0.7).abs() < 1e-12).count() == 1);
        assert!(a.iter().filter(|&&x| (x + 0.7).abs() < 1e-12).count() == 2);
        for s in &sols {
            let (t2, a2) = forward_kinematics(&m, &s.q);
            assert!((t2 - tip).norm() < 1e-12 && (a2 - axis).norm() < 1e-12);
        }
        // Without a reference: sorted by A, then C.
        assert!(
            sols.windows(2)
                .all(|w| (w[0].q[3], w[0].q[4]) <= (w[1].q[3], w[1].q[4]))
        );
        assert!(
            c.iter()
                .all(|&x| same_angle(x, 0.5, 1e-12) || same_angle(x, 0.5 + PI, 1e-12))
        );
    }

    #[test]
    fn singular_when_tool_axis_along_c() {
        let m = trunnion((-2.0, 2.0));
        let q = [0.1, -0.2, 0.05, 0.0, 0.3];
        let (tip, axis) = forward_kinematics(&m, &q);
        let reference = vec![0.0, 0.0, 0.0, 0.0, 1.25];
        let opts = IkOptions {
            reference: Some(reference),
            ..IkOptions::default()
        };
        match inverse_kinematics(&m, &tip, &axis, &opts) {
            Err(IkError::Singular {
                free_axis,
                held_at,
                held,
                ..
            }) => {
                assert_eq!(free_axis, 'C');
                assert_eq!(held_at, 1.25);
                assert!(!held.is_empty());
                for s in &held {
                    assert_eq!(s.q[4], 1.25);
                    let (t2, a2) = forward_kinematics(&m, &s.q);
                    assert!((t2 - tip).norm() < 1e-12 && (a2 - axis).norm() < 1e-12);
                }
            }
            other => panic!("expected Singular, got {other:?}"),
        }
        // Within the tolerance still singular, beyond it solved.
        let tilted = |eps: f64| Vector3::new(eps.sin(), 0.0, eps.cos());
        let err = inverse_kinematics(&m, &tip, &tilted(5e-7), &IkOptions::default()).unwrap_err();
        assert!(
            matches!(err, IkError::Singular { free_axis: 'C', .. }),
            "{err}"
        );
        assert!(err.to_string().contains("singular"));
        for eps in [2e-6, 1e-4] {
            let sols = inverse_kinematics(&m, &tip, &tilted(eps), &IkOptions::default()).unwrap();
            assert!(!sols.is_empty());
            for s in &sols {
                let (t2, a2) = forward_kinematics(&m, &s.q);
                assert!((t2 - tip).norm() < 1e-9 && (a2 - tilted(eps)).norm() < 1e-9);
            }
        }
        // Anti-parallel tool axis (A = ±π) is singular too, and outside A's reach here.
        let err = inverse_kinematics(&m, &tip, &-axis, &IkOptions::default()).unwrap_err();
        assert!(
            matches!(err, IkError::Singular { free_axis: 'C', ref held, .. } if held.is_empty())
        );
    }

    #[test]
    fn limits_filter_and_report() {
        // A in [-2, 0.5]: the branch with A = +1 is cut off, A = -1 remains.
        let m = trunnion((-2.0, 0.5));
        let q = [0.05, 0.1, -0.1, 1.0, 0.2];
        let (tip, axis) = forward_kinematics(&m, &q);
        let sols = inverse_kinematics(&m, &tip, &axis, &IkOptions::default()).unwrap();
        assert!(!sols.is_empty());
        assert!(sols.iter().all(|s| (s.q[3] + 1.0).abs() < 1e-12));
        // |A| = 2.5: A = -2.5 misses the lower limit by 0.5, A = 2.5 the upper by 2: nearest.
        let q = [0.0, 0.0, 0.0, 2.5, 0.2];
        let (tip, axis) = forward_kinematics(&m, &q);
        match inverse_kinematics(&m, &tip, &axis, &IkOptions::default()) {
            Err(IkError::OutsideLimits { nearest, violation }) => {
                assert_eq!(violation.axis, 'A');
                assert_eq!(violation.bound, Bound::Lower);
                assert_eq!(violation.limit, -2.0);
                assert!((nearest.q[3] + 2.5).abs() < 1e-12);
                assert!((violation.excess() - 0.5).abs() < 1e-12);
                let msg = IkError::OutsideLimits { nearest, violation }.to_string();
                assert!(
                    msg.contains("axis A") && msg.contains("lower limit"),
                    "{msg}"
                );
            }
            other => panic!("expected OutsideLimits, got {other:?}"),
        }
        // A linear axis out of range: X = ±0.8 on both branches.
        let m = trunnion((-2.0, 2.0));
        let (tip, axis) = forward_kinematics(&m, &[0.8, 0.0, 0.0, 1.0, 0.2]);
        match inverse_kinematics(&m, &tip, &axis, &IkOptions::default()) {
            Err(IkError::OutsideLimits { violation, .. }) => {
                assert_eq!(violation.axis, 'X');
                let expected = match violation.bound {
                    Bound::Upper => 0.5,
                    Bound::Lower => -0.5,
                };
                assert_eq!(violation.limit, expected);
                assert!(violation.to_string().contains(" m"));
            }
            other => panic!("expected OutsideLimits on X, got {other:?}"),
        }
    }

    fn three_axis() -> Machine {
        let mut b = Builder {
            rnd: [].iter(),
            offset: 0.0,
            tilt: 0.0,
        };
        Machine::try_new(&MachineSpec {
            name: "vmc".into(),
            workpiece: BranchSpec {
                joints: vec![
                    b.joint('Y', [0., -1., 0.], [0.; 3], LIN),
                    b.joint('X', [-1., 0., 0.], [0.; 3], LIN),
                ],
                end: Isometry3::identity(),
            },
            tool: BranchSpec {
                joints: vec![b.joint('Z', [0., 0., 1.], [0., 0., 0.3], LIN)],
                end: Isometry3::translation(0.0, 0.0, -0.1),
            },
        })
        .unwrap()
    }

    #[test]
    fn follow_point_puts_the_nominal_tool_point_on_the_target() {
        let m = trunnion((-0.5, 2.1));
        let tip = Vector3::new(0.12, -0.05, 0.08);
        for (a, c) in [(0.0, 0.0), (0.7, 2.0), (-0.4, -3.0)] {
            let mut q = vec![0.3; m.n_axes()];
            q[m.axis_index('A').unwrap()] = a;
            q[m.axis_index('C').unwrap()] = c;
            follow_point(&m, &mut q, &tip).unwrap();
            assert!((m.tool_in_workpiece(&q).t - tip).norm() < 1e-12);
            assert_eq!(q[m.axis_index('A').unwrap()], a, "rotary axes untouched");
        }
        let mut q = vec![0.0; m.n_axes()];
        assert!(follow_point(&m, &mut q, &Vector3::new(f64::NAN, 0.0, 0.0)).is_err());
    }

    #[test]
    fn three_axis_machine() {
        let m = three_axis();
        let q = [0.2, -0.1, 0.3];
        let (tip, axis) = forward_kinematics(&m, &q);
        let sols = inverse_kinematics(&m, &tip, &(axis * 3.0), &IkOptions::default()).unwrap();
        assert_eq!(sols.len(), 1);
        assert!(same_q(&m, &sols[0].q, &q, 1e-12));
        let err = inverse_kinematics(
            &m,
            &tip,
            &Vector3::new(0.01, 0.0, 1.0),
            &IkOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(err, IkError::Unreachable { .. }), "{err}");
        assert!(err.to_string().contains("no rotary axis"));
    }

    #[test]
    fn rejects_bad_input() {
        let m = three_axis();
        let o = IkOptions::default();
        let z = Vector3::z();
        assert_eq!(
            inverse_kinematics(&m, &Vector3::new(f64::NAN, 0., 0.), &z, &o),
            Err(IkError::NotFinite { what: "tool tip" })
        );
        assert_eq!(
            inverse_kinematics(
                &m,
                &Vector3::zeros(),
                &Vector3::new(0., f64::INFINITY, 0.),
                &o
            ),
            Err(IkError::NotFinite { what: "tool axis" })
        );
        assert_eq!(
            inverse_kinematics(&m, &Vector3::zeros(), &Vector3::zeros(), &o),
            Err(IkError::ZeroToolAxis)
        );
        let bad_ref = IkOptions {
            reference: Some(vec![0.0; 2]),
            ..IkOptions::default()
        };
        assert_eq!(
            inverse_kinematics(&m, &Vector3::zeros(), &z, &bad_ref),
            Err(IkError::ReferenceLength {
                got: 2,
                expected: 3
            })
        );
        // Two linear axes only.
        let mut spec = m.to_spec();
        spec.workpiece.joints.pop();
        let m2 = Machine::try_new(&spec).unwrap();
        assert!(matches!(
            inverse_kinematics(&m2, &Vector3::zeros(), &z, &o),
            Err(IkError::UnsupportedMachine { .. })
        ));
    }

    #[test]
    fn unreachable_orientation_of_a_nutating_head() {
        // Head-head C then A, with A's axis at 45° to the tool (a nutating head): the tool axis
        // can only reach directions within 90° of z.
        let mut spec = build(Layout::HeadCa, &[], 0.0, 0.0).to_spec();
        let a = spec
            .tool
            .joints
            .iter_mut()
            .find(|j| j.letter == 'A')
            .unwrap();
        a.axis = Vector3::new(1.0, 0.0, 1.0);
        a.limits = None;
        let m = Machine::try_new(&spec).unwrap();
        let tip = Vector3::new(0.0, 0.0, 0.0);
        // Reachable: 60° from z.
        let ok = Vector3::new(60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos());
        let sols = inverse_kinematics(&m, &tip, &ok, &IkOptions::default()).unwrap();
        for s in &sols {
            let (t2, a2) = forward_kinematics(&m, &s.q);
            assert!((t2 - tip).norm() < 1e-9 && (a2 - ok).norm() < 1e-9);
        }
        // Unreachable: pointing down.
        let err = inverse_kinematics(
            &m,
            &tip,
            &Vector3::new(0.3, 0.0, -1.0),
            &IkOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(err, IkError::Unreachable { .. }), "{err}");
    }

    #[test]
    fn four_axis_machine() {
        // wAFYXZt: an A trunnion without C.
        let mut spec = build(Layout::Cafyxz, &[], 0.0, 0.0).to_spec();
        spec.workpiece.joints.pop();
        let m = Machine::try_new(&spec).unwrap();
        let q = [0.1, 0.2, -0.3, 0.8];
        let (tip, axis) = forward_kinematics(&m, &q);
        let sols = inverse_kinematics(&m, &tip, &axis, &IkOptions::default()).unwrap();
        assert_eq!(sols.len(), 1);
        assert!(same_q(&m, &sols[0].q, &q, 1e-12));
        let err = inverse_kinematics(
            &m,
            &tip,
            &Vector3::new(0.1, 0.3, 1.0),
            &IkOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(err, IkError::Unreachable { .. }), "{err}");
    }

    #[test]
    fn second_axis_about_the_tool_is_free() {
        // A B head with a C axis turning the spindle about the tool axis: C never tilts the tool.
        let mut b = Builder {
            rnd: [].iter(),
            offset: 0.0,
            tilt: 0.0,
        };
        let m = Machine::try_new(&MachineSpec {
            name: "bc-spindle".into(),
            workpiece: BranchSpec {
                joints: vec![b.joint('X', [-1., 0., 0.], [0.; 3], LIN)],
                end: Isometry3::identity(),
            },
            tool: BranchSpec {
                joints: vec![
                    b.joint('Y', [0., 1., 0.], [0.; 3], LIN),
                    b.joint('Z', [0., 0., 1.], [0.; 3], LIN),
                    b.joint('B', [0., 1., 0.], [0., 0., -0.2], Some((-2.0, 2.0))),
                    b.joint('C', [0., 0., 1.], [0.; 3], None),
                ],
                end: Isometry3::translation(0.0, 0.0, -0.1),
            },
        })
        .unwrap();
        let q = [0.1, 0.0, 0.2, 0.5, 0.0];
        let (tip, axis) = forward_kinematics(&m, &q);
        match inverse_kinematics(&m, &tip, &axis, &IkOptions::default()) {
            Err(IkError::Singular {
                free_axis: 'C',
                held,
                ..
            }) => {
                assert_eq!(held.len(), 1);
                assert!(same_q(&m, &held[0].q, &q, 1e-12));
            }
            other => panic!("expected Singular on C, got {other:?}"),
        }
    }

    #[test]
    fn parallel_rotary_axes_are_rejected() {
        let mut spec = build(Layout::Mixed, &[], 0.0, 0.0).to_spec();
        let bj = spec
            .tool
            .joints
            .iter_mut()
            .find(|j| j.letter == 'B')
            .unwrap();
        bj.axis = Vector3::z();
        let m = Machine::try_new(&spec).unwrap();
        let err = inverse_kinematics(&m, &Vector3::zeros(), &Vector3::z(), &IkOptions::default())
            .unwrap_err();
        assert!(matches!(err, IkError::ParallelRotaryAxes { .. }), "{err}");
    }
}
