//! The plan a `MachineModel` evaluates from: per axis its error terms packed for the hot
//! loop, where each coefficient sits, and the per-joint state of the last chain evaluation.

use super::*;

/// The error model flattened per axis for the hot paths: coefficient offsets instead of
/// parameter lookups, one shared Legendre evaluation per axis, and flags that let the nominal
/// chain skip work (a pure-translation joint origin needs no rotation product).
#[derive(Clone, Debug)]
pub(super) struct Plan {
    pub(super) axes: Vec<AxisPlan>,
    pub(super) tool: [Option<usize>; 3],
    pub(super) workpiece: [Option<usize>; 6],
    /// Longest shared Legendre recurrence of any axis (scratch size).
    pub(super) max_legendre: usize,
    /// The branch ends carry no rotation (the first-order walk skips the product).
    pub(super) tool_end_is_translation: bool,
    pub(super) wp_end_is_translation: bool,
}

#[derive(Clone, Debug)]
pub(super) struct AxisPlan {
    pub(super) linear: bool,
    /// Some component error or own-direction location error is configured: the axis has
    /// component-twist Jacobian columns (a reduced model, e.g. location errors only, has none).
    pub(super) has_component_columns: bool,
    pub(super) tool_side: bool,
    pub(super) r0t: Matrix3<f64>,
    /// The joint frame is aligned with the machine frame at the zero pose (`r0t = I`).
    pub(super) r0t_is_identity: bool,
    pub(super) origin_is_translation: bool,
    /// The axis direction is exactly `±e_k`, as `(k, ±1)`: rotations mix two coordinates.
    pub(super) along_basis: Option<(usize, f64)>,
    /// `(lo, hi)` of the stroke the axis' shared Legendre components use.
    pub(super) legendre_stroke: (f64, f64),
    /// Highest Legendre degree evaluated for the axis (`None`: no shared Legendre component).
    pub(super) legendre_max: Option<usize>,
    /// Shared Fourier functions `1, cos q, sin q, cos 2q, …` the axis' Fourier components use
    /// (0: none).
    pub(super) fourier_terms: usize,
    pub(super) comp: [Slot; 6],
    /// Coefficient offsets of the location errors that go into the location factor.
    pub(super) loc: [Option<usize>; 6],
    /// Coefficient offsets of a rotary axis' own-direction location errors (added to the
    /// component values: they are their constants).
    pub(super) own_loc: [Option<usize>; 6],
}

/// Highest Legendre degree + 1 the packed fast path handles; axes beyond it use the general one.
pub(super) const PACKED_TERMS: usize = 8;

/// Shared Fourier functions the packed fast path handles (harmonics up to 16); axes beyond it
/// use the general one.
pub(super) const FOURIER_TERMS: usize = 33;

/// An axis' error values in local coordinates (`r0t` applied) as dense polynomials in the
/// shared Legendre basis: `[δ; ε](q) = Σ_k comp[k]·P_k(u)`, location `[lt; lw] = loc`.
#[derive(Clone, Copy, Debug)]
pub(super) struct PackedAxis {
    /// Monomial coefficients in the normalised position `u ∈ [−1, 1]` (converted from the
    /// Legendre ones when packing): Horner's rule then evaluates all six directions with a
    /// short dependency chain, where the Legendre recurrence is a long serial one.
    pub(super) mono: [[f64; 6]; PACKED_TERMS],
    pub(super) terms: usize,
    pub(super) loc: [f64; 6],
    /// The location factor `L = (exp([lw]×), lt)` and its inverse, and a linear axis' actual
    /// direction of motion `R_L·a`: constant for one set of coefficients, so the chain walk
    /// does not recompute them at every pose.
    pub(super) l_factor: Rigid,
    pub(super) l_inverse: Rigid,
    pub(super) motion_dir: Vector3<f64>,
    /// Some component is neither a shared-stroke Legendre polynomial nor a Fourier series:
    /// use the general path.
    pub(super) general: bool,
    pub(super) fourier_terms: usize,
    /// Coefficients of the shared Fourier functions (`1, cos q, sin q, cos 2q, …`), local
    /// directions: one sine and cosine per sample serve all six directions. Last: most axes
    /// never read it, and the fields above stay on a few cache lines.
    pub(super) fourier: [[f64; 6]; FOURIER_TERMS],
}

impl Default for PackedAxis {
    fn default() -> Self {
        Self {
            mono: [[0.0; 6]; PACKED_TERMS],
            terms: 0,
            fourier: [[0.0; 6]; FOURIER_TERMS],
            fourier_terms: 0,
            loc: [0.0; 6],
            l_factor: Rigid::IDENTITY,
            l_inverse: Rigid::IDENTITY,
            motion_dir: Vector3::zeros(),
            general: false,
        }
    }
}

/// A component error slot of an axis.
#[derive(Clone, Copy, Debug)]
pub(super) enum Slot {
    Empty,
    /// Legendre over the axis' shared stroke: coefficients `offset..offset+len` multiply
    /// `P_min .. P_(min+len-1)`.
    Legendre {
        offset: usize,
        len: usize,
        min: usize,
    },
    /// Fourier series: coefficients `offset..offset+len` multiply the axis' shared Fourier
    /// functions `first..first+len` (`param` for the general path).
    Fourier {
        offset: usize,
        len: usize,
        first: usize,
        param: usize,
    },
    /// Any other basis, evaluated through [`crate::Basis`] (index into the parameters).
    General {
        offset: usize,
        len: usize,
        param: usize,
    },
}

impl Plan {
    pub(super) fn new(machine: &Machine, errors: &ErrorModel) -> Plan {
        let axes: Vec<AxisPlan> = machine
            .axes()
            .iter()
            .enumerate()
            .map(|(i, ax)| AxisPlan::new(i, ax, errors))
            .collect();
        let max_legendre = axes
            .iter()
            .filter_map(|a| a.legendre_max)
            .map(|m| m + 1)
            .max()
            .unwrap_or(0);
        Plan {
            axes,
            tool: std::array::from_fn(|d| errors.tool_offset(d).map(|p| p.offset)),
            workpiece: std::array::from_fn(|d| errors.workpiece_offset(d).map(|p| p.offset)),
            max_legendre,
            tool_end_is_translation: machine.branch(Side::Tool).end().r == Matrix3::identity(),
            wp_end_is_translation: machine.branch(Side::Workpiece).end().r == Matrix3::identity(),
        }
    }
}

impl AxisPlan {
    pub(super) fn new(i: usize, ax: &crate::machine::Axis, errors: &ErrorModel) -> AxisPlan {
        let linear = ax.kind() == AxisKind::Linear;
        // The first Legendre component fixes the shared stroke; others on another stroke fall
        // back to the general path.
        let mut stroke = None;
        let mut legendre_max = None;
        let mut fourier_terms = 0;
        let mut comp = [Slot::Empty; 6];
        for (d, slot) in comp.iter_mut().enumerate() {
            let Some(p) = errors.component(i, d) else {
                continue;
            };
            let param = errors
                .params()
                .iter()
                .position(|q| std::ptr::eq(q, p))
                .expect("parameter of this model");
            *slot = Slot::General {
                offset: p.offset,
                len: p.len,
                param,
            };
            if let Role::Component {
                basis:
                    crate::Basis::Legendre {
                        lo,
                        hi,
                        min_degree,
                        max_degree,
                    },
                ..
            } = &p.role
            {
                let s = *stroke.get_or_insert((*lo, *hi));
                if s == (*lo, *hi) {
                    *slot = Slot::Legendre {
                        offset: p.offset,
                        len: p.len,
                        min: *min_degree,
                    };
                    legendre_max = Some(legendre_max.unwrap_or(0).max(*max_degree));
                }
            }
            if let Role::Component {
                basis:
                    crate::Basis::Fourier {
                        min_harmonic,
                        max_harmonic,
                    },
                ..
            } = &p.role
            {
                // Function order 1, cos q, sin q, cos 2q, …: harmonic k ≥ 1 starts at 2k − 1.
                let first = if *min_harmonic == 0 {
                    0
                } else {
                    2 * min_harmonic - 1
                };
                *slot = Slot::Fourier {
                    offset: p.offset,
                    len: p.len,
                    first,
                    param,
                };
                fourier_terms = fourier_terms.max(2 * max_harmonic + 1);
            }
        }
        let own = ax.own_cartesian();
        let mut loc = [None; 6];
        let mut own_loc = [None; 6];
        for d in 0..6 {
            if let Some(p) = errors.location(i, d) {
                if !linear && d % 3 == own {
                    own_loc[d] = Some(p.offset);
                } else {
                    loc[d] = Some(p.offset);
                }
            }
        }
        AxisPlan {
            linear,
            has_component_columns: comp.iter().any(|s| !matches!(s, Slot::Empty))
                || own_loc.iter().any(Option::is_some),
            tool_side: ax.side() == Side::Tool,
            r0t: ax.zero_rotation().transpose(),
            r0t_is_identity: *ax.zero_rotation() == Matrix3::identity(),
            origin_is_translation: ax.origin().r == Matrix3::identity(),
            along_basis: (0..3).find_map(|k| {
                let d = ax.direction();
                if *d == unit(k) {
                    Some((k, 1.0))
                } else if *d == -unit(k) {
                    Some((k, -1.0))
                } else {
                    None
                }
            }),
            legendre_stroke: stroke.unwrap_or((0.0, 1.0)),
            legendre_max,
            fourier_terms,
            comp,
            loc,
            own_loc,
        }
    }

    /// `m · r0t` (machine directions to local ones, then `m`), without the product when the
    /// joint frame is aligned with the machine's.
    #[inline(always)]
    pub(super) fn times_r0t(&self, m: &Matrix3<f64>) -> Matrix3<f64> {
        if self.r0t_is_identity {
            *m
        } else {
            mm(m, &self.r0t)
        }
    }
}

/// Per-joint quantities of the last chain evaluation, in the joint's local frame.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct JointState {
    /// Frame before the first error factor of the joint (`f_T_·`).
    pub(super) before_a: Rigid,
    /// Linear: frame before `E` (after the motion). Rotary: frame before `L` (after `E`).
    pub(super) before_b: Rigid,
    /// Rotary: frame before `Rot(q)` (after `L`).
    pub(super) before_r: Rigid,
    /// The body frame after the joint (`before_b · L·Rot(q)·L⁻¹` for a rotary axis).
    pub(super) after: Rigid,
    /// The body's error factor (`E` or `E⁻¹`).
    pub(super) e_body: Rigid,
    pub(super) e_trans: Vector3<f64>,
    pub(super) e_rot: Vector3<f64>,
    pub(super) l_trans: Vector3<f64>,
    pub(super) l_rot: Vector3<f64>,
    /// Linear: actual direction of motion `R_L·a`.
    pub(super) motion_dir: Vector3<f64>,
    pub(super) q: f64,
}
