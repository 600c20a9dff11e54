//! Small frame algebra of the chain: turns about coordinate axes, twists at the tool
//! point, location continuations, vector helpers.

use super::*;

/// A rotary axis' rotation by `q`: about a coordinate axis only two coordinates mix (four
/// products instead of a 3 × 3 product, and no matrix to build).
#[derive(Clone, Copy, Debug)]
pub(super) enum Turn {
    /// About `e_k`, with `(sin q, cos q)` (an axis along `−e_k` turns by `−q`).
    About(usize, f64, f64),
    General(Matrix3<f64>),
}

impl Turn {
    #[inline(always)]
    pub(super) fn new(along_basis: Option<(usize, f64)>, direction: &Vector3<f64>, q: f64) -> Turn {
        match along_basis {
            Some((k, sign)) => {
                let (s, c) = q.sin_cos();
                Turn::About(k, sign * s, c)
            }
            None => Turn::General(axis_rotation(direction, q)),
        }
    }

    #[inline(always)]
    pub(super) fn apply(&self, v: &Vector3<f64>) -> Vector3<f64> {
        match *self {
            Turn::About(k, s, c) => planar(k, s, c, v),
            Turn::General(r) => mv(&r, v),
        }
    }

    #[inline(always)]
    pub(super) fn apply_inverse(&self, v: &Vector3<f64>) -> Vector3<f64> {
        match *self {
            Turn::About(k, s, c) => planar(k, -s, c, v),
            Turn::General(r) => mv(&r.transpose(), v),
        }
    }

    /// `m · Rot`: about `e_k` only two columns mix.
    #[inline(always)]
    pub(super) fn right_of(&self, m: &Matrix3<f64>) -> Matrix3<f64> {
        match *self {
            Turn::About(k, s, c) => {
                // Columns i = k+1, j = k+2 (cyclic) become c·m_i + s·m_j and c·m_j − s·m_i.
                let (m0, m1, m2) = (column(m, 0), column(m, 1), column(m, 2));
                let cols = match k {
                    0 => [m0, m1 * c + m2 * s, m2 * c - m1 * s],
                    1 => [m0 * c - m2 * s, m1, m2 * c + m0 * s],
                    _ => [m0 * c + m1 * s, m1 * c - m0 * s, m2],
                };
                Matrix3::from_columns(&cols)
            }
            Turn::General(r) => mm(m, &r),
        }
    }
}

/// `v` rotated about `e_k` by the angle with sine `s` and cosine `c`.
#[inline(always)]
pub(super) fn planar(k: usize, s: f64, c: f64, v: &Vector3<f64>) -> Vector3<f64> {
    // Written out per axis: no run-time indexing into the vector.
    let (x, y, z) = (v.x, v.y, v.z);
    match k {
        0 => Vector3::new(x, c * y - s * z, s * y + c * z),
        1 => Vector3::new(s * z + c * x, y, c * z - s * x),
        _ => Vector3::new(c * x - s * y, s * x + c * y, z),
    }
}

/// The first-order error carried along the chain: the tool point `p`, the displacement of the
/// tool point `v` (µm) and the rotation `w` (µrad), all in the current frame's coordinates.
#[derive(Clone, Copy, Default)]
pub(super) struct AtToolPoint {
    pub(super) p: Vector3<f64>,
    pub(super) v: Vector3<f64>,
    pub(super) w: Vector3<f64>,
}

impl AtToolPoint {
    /// Adds a twist `(tv, tw)` given at the current frame's origin.
    #[inline(always)]
    pub(super) fn add(&mut self, tv: Vector3<f64>, tw: Vector3<f64>) {
        self.v += tv + tw.cross(&self.p);
        self.w += tw;
    }

    /// Re-expresses in the frame before the rotation `r` (current = before · r).
    #[inline(always)]
    pub(super) fn rotate(&mut self, r: &Matrix3<f64>) {
        self.p = mv(r, &self.p);
        self.v = mv(r, &self.v);
        self.w = mv(r, &self.w);
    }

    /// Re-expresses in the frame after the rotation `r` (current · r = next).
    #[inline(always)]
    pub(super) fn rotate_back(&mut self, r: &Matrix3<f64>) {
        let rt = r.transpose();
        self.rotate(&rt);
    }

    /// From a child frame to its parent, `parent_T_child = t`.
    #[inline(always)]
    pub(super) fn move_to_parent(&mut self, t: &Rigid, translation_only: bool) {
        if !translation_only {
            self.rotate(&t.r);
        }
        self.p += t.t;
    }

    /// From a parent frame to its child, `parent_T_child = t`.
    #[inline(always)]
    pub(super) fn move_to_child(&mut self, t: &Rigid, translation_only: bool) {
        self.p -= t.t;
        if !translation_only {
            self.rotate_back(&t.r);
        }
    }
}

/// Adds location error `d` of an axis: a rotary axis' own-direction location errors are the
/// constants of its component errors, the others go to the location factor.
#[inline]
pub(super) fn continue_location(
    c: &mut [f64; 6],
    l: &mut [f64; 6],
    ax: &crate::machine::Axis,
    d: usize,
    param: Option<&crate::model::Param>,
    coeffs: &[f64],
) {
    if let Some(p) = param {
        let v = coeffs[p.offset];
        if ax.kind() == AxisKind::Rotary && d % 3 == ax.own_cartesian() {
            c[d] += v;
        } else {
            l[d] = v;
        }
    }
}

pub(super) fn sign(side: Side) -> f64 {
    match side {
        Side::Tool => 1.0,
        Side::Workpiece => -1.0,
    }
}

/// `[r0t·a[0..3]; r0t·a[3..6]]`: machine directions to a joint's local ones.
#[inline]
pub(super) fn to_local(r0t: &Matrix3<f64>, a: &[f64; 6]) -> [f64; 6] {
    let (t, r) = (mv(r0t, &v3(a, 0)), mv(r0t, &v3(a, 3)));
    [t.x, t.y, t.z, r.x, r.y, r.z]
}

/// Column `j` of `m`.
#[inline(always)]
pub(super) fn column(m: &Matrix3<f64>, j: usize) -> Vector3<f64> {
    let c = &m.data.0[j];
    Vector3::new(c[0], c[1], c[2])
}

pub(super) fn unit(i: usize) -> Vector3<f64> {
    let mut v = Vector3::zeros();
    v[i] = 1.0;
    v
}

pub(super) fn v3(a: &[f64; 6], start: usize) -> Vector3<f64> {
    Vector3::new(a[start], a[start + 1], a[start + 2])
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(super) fn opt(offset: Option<usize>, coeffs: &[f64]) -> f64 {
    offset.map_or(0.0, |o| coeffs[o])
}

/// Workpiece set-up translation (`start` 0) or rotation (`start` 3) from the coefficients.
pub(super) fn ws_wp(plan: &Plan, coeffs: &[f64], start: usize) -> Vector3<f64> {
    let wp = &plan.workpiece;
    Vector3::new(
        opt(wp[start], coeffs),
        opt(wp[start + 1], coeffs),
        opt(wp[start + 2], coeffs),
    )
}

pub(super) fn value_of(p: Option<&crate::model::Param>, coeffs: &[f64]) -> f64 {
    match p {
        Some(p) => coeffs[p.offset],
        None => 0.0,
    }
}
