//! A rigid transform as rotation matrix + translation: cheaper to compose and to apply than a
//! quaternion isometry on the hot path, and exact enough (rotations are re-orthogonal by
//! construction: products of exact rotations).

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

/// `x ↦ r·x + t`. In names, `a_T_b` maps b coordinates to a coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub r: Matrix3<f64>,
    pub t: Vector3<f64>,
}

impl Default for Rigid {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Rigid {
    pub const IDENTITY: Rigid = Rigid {
        r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        t: Vector3::new(0.0, 0.0, 0.0),
    };

    pub fn new(r: Matrix3<f64>, t: Vector3<f64>) -> Self {
        Self { r, t }
    }

    pub fn translation(t: Vector3<f64>) -> Self {
        Self {
            r: Matrix3::identity(),
            t,
        }
    }

    pub fn rotation(r: Matrix3<f64>) -> Self {
        Self {
            r,
            t: Vector3::zeros(),
        }
    }

    /// `self ∘ other`.
    #[inline]
    pub fn compose(&self, other: &Rigid) -> Rigid {
        Rigid {
            r: mm(&self.r, &other.r),
            t: mv(&self.r, &other.t) + self.t,
        }
    }

    /// `self ∘ Trans(v)`, without the product with the identity rotation.
    #[inline]
    pub fn translated(&self, v: &Vector3<f64>) -> Rigid {
        Rigid {
            r: self.r,
            t: mv(&self.r, v) + self.t,
        }
    }

    #[inline]
    pub fn inverse(&self) -> Rigid {
        let rt = self.r.transpose();
        Rigid {
            r: rt,
            t: -mv(&rt, &self.t),
        }
    }

    #[inline]
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        mv(&self.r, p) + self.t
    }

    pub fn from_isometry(iso: &Isometry3<f64>) -> Self {
        Self {
            r: *iso.rotation.to_rotation_matrix().matrix(),
            t: iso.translation.vector,
        }
    }

    pub fn to_isometry(&self) -> Isometry3<f64> {
        let rot = Rotation3::from_matrix(&self.r);
        Isometry3::from_parts(
            Translation3::from(self.t),
            UnitQuaternion::from_rotation_matrix(&rot),
        )
    }

    /// Maps a twist `(v, ω)` given in this transform's child frame to its parent frame (the
    /// adjoint): a point velocity field `v + ω × x` in child coordinates becomes `v' + ω' × x'`.
    #[inline]
    pub fn adjoint(&self, v: &Vector3<f64>, w: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let w2 = mv(&self.r, w);
        (mv(&self.r, v) + self.t.cross(&w2), w2)
    }
}

/// `exp([ω]×)`, exact (Rodrigues), with a series for tiny angles where error motions live.
#[inline]
pub fn exp_so3(w: &Vector3<f64>) -> Matrix3<f64> {
    let th2 = w.norm_squared();
    let (a, b) = if th2 < 1e-8 {
        // sin θ/θ and (1 - cos θ)/θ², to O(θ⁶): exact to double precision for |θ| < 1e-4.
        // Multiplications by the reciprocals: divisions are slow, and the rounding of the
        // tiny correction terms does not show.
        (
            1.0 - th2 * (1.0 / 6.0) * (1.0 - th2 * (1.0 / 20.0)),
            0.5 - th2 * (1.0 / 24.0) * (1.0 - th2 * (1.0 / 30.0)),
        )
    } else {
        let th = th2.sqrt();
        (th.sin() / th, (1.0 - th.cos()) / th2)
    };
    i_ak_bk2(w, a, b)
}

/// The left Jacobian of SO(3): `exp([ω + dω]×) ≈ exp([J_l(ω) dω]×) exp([ω]×)`.
#[inline]
pub fn left_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    let th2 = w.norm_squared();
    let (a, b) = if th2 < 1e-8 {
        // (1 - cos θ)/θ² and (θ - sin θ)/θ³ (reciprocals as in `exp_so3`).
        (
            0.5 - th2 * (1.0 / 24.0) * (1.0 - th2 * (1.0 / 30.0)),
            1.0 / 6.0 - th2 * (1.0 / 120.0) * (1.0 - th2 * (1.0 / 42.0)),
        )
    } else {
        let th = th2.sqrt();
        ((1.0 - th.cos()) / th2, (th - th.sin()) / (th2 * th))
    };
    i_ak_bk2(w, a, b)
}

/// Inverse of [`left_jacobian`].
#[inline]
pub fn left_jacobian_inverse(w: &Vector3<f64>) -> Matrix3<f64> {
    let th2 = w.norm_squared();
    // 1/θ² - (1 + cos θ)/(2 θ sin θ)
    let c = if th2 < 1e-8 {
        1.0 / 12.0 + th2 * (1.0 / 720.0)
    } else {
        let th = th2.sqrt();
        1.0 / th2 - (1.0 + th.cos()) / (2.0 * th * th.sin())
    };
    i_ak_bk2(w, -0.5, c)
}

/// `log(R)` as a rotation vector; exact for angles below π.
pub fn log_so3(r: &Matrix3<f64>) -> Vector3<f64> {
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    let cos = ((r.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
    let sin = 0.5 * v.norm();
    if sin < 1e-6 && cos > 0.0 {
        // θ/sin θ ≈ 1 + θ²/6 with θ ≈ sin θ.
        return v * (0.5 * (1.0 + sin * sin / 6.0));
    }
    if cos > -0.99 {
        let th = sin.atan2(cos);
        return v * (0.5 * th / sin);
    }
    // Near π: fall back on nalgebra's robust scaled axis.
    Rotation3::from_matrix_unchecked(*r).scaled_axis()
}

/// Rotation by angle `q` about the unit vector `a`.
#[inline]
pub fn axis_rotation(a: &Vector3<f64>, q: f64) -> Matrix3<f64> {
    let (s, c) = q.sin_cos();
    i_ak_bk2(a, s, 1.0 - c)
}

/// `I + a·[w]× + b·[w]×²`, written out (`[w]×² = w·wᵀ − |w|²·I`): the shape of every
/// Rodrigues-type formula here. Hand-unrolled 3 × 3 arithmetic: nalgebra's generic small-matrix
/// products are several times slower on the kinematic hot paths.
#[inline(always)]
fn i_ak_bk2(w: &Vector3<f64>, a: f64, b: f64) -> Matrix3<f64> {
    let (x, y, z) = (w.x, w.y, w.z);
    let d = 1.0 - b * (x * x + y * y + z * z);
    let (bxy, bxz, byz) = (b * x * y, b * x * z, b * y * z);
    Matrix3::new(
        d + b * x * x,
        bxy - a * z,
        bxz + a * y,
        bxy + a * z,
        d + b * y * y,
        byz - a * x,
        bxz - a * y,
        byz + a * x,
        d + b * z * z,
    )
}

/// `m · v`, unrolled (see [`i_ak_bk2`]).
#[inline(always)]
pub fn mv(m: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    let c = &m.data.0;
    Vector3::new(
        c[0][0] * v.x + c[1][0] * v.y + c[2][0] * v.z,
        c[0][1] * v.x + c[1][1] * v.y + c[2][1] * v.z,
        c[0][2] * v.x + c[1][2] * v.y + c[2][2] * v.z,
    )
}

/// `a · b`, unrolled (see [`i_ak_bk2`]).
#[inline(always)]
pub fn mm(a: &Matrix3<f64>, b: &Matrix3<f64>) -> Matrix3<f64> {
    let bc = &b.data.0;
    let col = |j: usize| mv(a, &Vector3::new(bc[j][0], bc[j][1], bc[j][2]));
    let (c0, c1, c2) = (col(0), col(1), col(2));
    Matrix3::from_columns(&[c0, c1, c2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec3() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(a, b, c)| Vector3::new(a, b, c))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        #[test]
        fn exp_log_round_trip(w in vec3(), scale in prop::sample::select(vec![1e-7, 1e-5, 1e-3, 1.0])) {
            let w = w * scale;
            let r = exp_so3(&w);
            prop_assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-14);
            prop_assert!((log_so3(&r) - w).norm() < 1e-13 * (1.0 + w.norm()));
            let reference = Rotation3::from_scaled_axis(w);
            prop_assert!((reference.matrix() - r).norm() < 1e-14);
        }

        #[test]
        fn left_jacobian_matches_finite_difference(w in vec3(), scale in prop::sample::select(vec![1e-5, 0.3, 1.0]), dir in vec3()) {
            let w = w * scale;
            let h = 1e-6;
            let jl = left_jacobian(&w);
            let lhs = exp_so3(&(w + dir * h)) * exp_so3(&(w - dir * h)).transpose();
            let got = log_so3(&lhs) / (2.0 * h);
            prop_assert!((got - jl * dir).norm() < 1e-7);
            prop_assert!((left_jacobian_inverse(&w) * jl - Matrix3::identity()).norm() < 1e-12);
        }

        #[test]
        fn compose_and_inverse(w in vec3(), t in vec3(), p in vec3()) {
            let a = Rigid::new(exp_so3(&w), t);
            let id = a.compose(&a.inverse());
            prop_assert!((id.r - Matrix3::identity()).norm() < 1e-14 && id.t.norm() < 1e-14);
            let iso = a.to_isometry();
            prop_assert!((iso * nalgebra::Point3::from(p) - nalgebra::Point3::from(a.apply(&p))).norm() < 1e-14);
        }
    }
}
