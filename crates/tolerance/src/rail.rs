//! Source 001's rail/carriage model (its "Model B", section 4): a rigid carriage plate on four
//! blocks riding on two rails whose mounting surfaces have straightness profiles.
//!
//! # Geometry (source 001, eqs. 14–15 as reconstructed in its note §2.6)
//! The guide frame of an axis is `(a, l, n)`, right-handed: `a` the direction the carriage body
//! moves for a positive axis command, `n` the normal of the rail mounting surfaces pointing from
//! the rails to the carriage ("vertical"), `l = n × a` ("horizontal", lateral). Rail A lies at
//! `−W/2` along `l`, rail B at `+W/2`; `W` is the rail spacing. Blocks 1 (rear) and 2 (front)
//! ride on rail A, 3 (front) and 4 (rear) on rail B; rear and front stations are `∓L/2` along
//! `a` from the carriage centre, `L` the block pitch. So 1–4 and 2–3 share a station and 1–3,
//! 2–4 are the diagonals, the layout that makes the source's printed right-hand sides
//! consistent.
//!
//! Each block is a spring (normal stiffness `k_i`, lateral stiffness `k_iy`) sitting on the rail
//! at deviation `d_i` (rail profile at the block plus the pad deviation); its displacement is
//! `w_i = d_i + F_i / k_i`, `F_i` the block force (negative in compression). Vertical, eq. (14):
//! force balance `ΣF = −F_zz`, moment balances `F1 + F2 = −F_zz/2`, `F2 + F3 = −F_zz/2` (load at
//! the plate centre) and coplanarity of the rigid plate `w1 + w3 = w2 + w4`. Horizontal,
//! eq. (15): `ΣF = F_zy`, `F2 + F3 = F_zy/2`, and the plate does not deform in its plane:
//! `v1 = v4`, `v2 = v3`. Both 4 × 4 systems are solved once per axis (they depend only on the
//! stiffnesses), so a carriage is a fixed affine map from block deviations to plate motion.
//!
//! # Plate motion (the source gives no formulas; these are its note's derivation)
//! From the block displacements at one stroke position: normal straightness `(Σ w_i)/4` (the
//! plate centre, exact for a plane over a rectangle), pitch `((w2 + w3) − (w1 + w4))/(2L)`
//! (front up is positive), roll `((w3 + w4) − (w1 + w2))/(2W)` (rail B up is positive), lateral
//! straightness `(Σ v_i)/4`, yaw `((v2 + v3) − (v1 + v4))/(2L)`. As a rigid twist of the body
//! about the carriage centre: translation `s_n n + s_l l`, rotation `roll·a − pitch·l + yaw·n`
//! (a rotation `ω` lifts the point `x a + y l` by `n·(ω × (x a + y l)) = −x ω·l + y ω·a`).
//! With equal stiffnesses the plate takes the least-squares plane of the four block heights, so
//! the load only sinks it uniformly.
//!
//! # To ISO component errors
//! The carriage centre is taken as the axis' joint origin (source 001 puts each prismatic joint
//! at the geometric centre of its support; the shipped ZFYX URDF does too). mtcal's component
//! errors are *functional* (ARCHITECTURE.md, "Conventions"): the tool's motion relative to the
//! workpiece. An axis in the tool branch moves the tool with its body, so its component errors
//! are the body twist; one in the workpiece branch moves the workpiece, so they are the negated
//! twist (first order of `E⁻¹`).

use nalgebra::{Matrix4, Vector3, Vector4};

/// Why a guide cannot be modelled.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RailError {
    #[error("{what} must be a positive finite number, got {value}")]
    NotPositive { what: &'static str, value: f64 },
    #[error("{what} must be finite, got {value}")]
    NotFinite { what: &'static str, value: f64 },
    #[error("the normal {normal:?} is not perpendicular to the axis' direction of motion {axis:?}")]
    NotPerpendicular { normal: [f64; 3], axis: [f64; 3] },
    #[error("the {which} equations of the carriage are singular (check the stiffnesses)")]
    Singular { which: &'static str },
}

/// The guide of one linear axis: geometry, stiffness, load. SI units (m, N/m, N).
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    /// `a`: the body's direction of motion for a positive command, machine directions (unit).
    pub axis: Vector3<f64>,
    /// `n`: mounting-surface normal from the rails to the carriage, machine directions (unit).
    pub normal: Vector3<f64>,
    /// `W`, m.
    pub rail_spacing: f64,
    /// `L`, m.
    pub block_pitch: f64,
    /// `k_1 … k_4` along `n`, N/m.
    pub stiffness: [f64; 4],
    /// `k_1y … k_4y` along `l`, N/m.
    pub lateral_stiffness: [f64; 4],
    /// `F_zz`: load pressing the carriage onto the rails (against `n`), N.
    pub load: f64,
    /// `F_zy`: load along `+l`, N.
    pub lateral_load: f64,
}

/// The plate's motion at one stroke position, in the guide frame (m, rad).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlateMotion {
    /// Along `n` (vertical straightness).
    pub normal: f64,
    /// Along `l` (horizontal straightness).
    pub lateral: f64,
    /// Front up (about `−l`).
    pub pitch: f64,
    /// Rail B up (about `a`).
    pub roll: f64,
    /// Front towards `+l` (about `n`).
    pub yaw: f64,
}

/// A solved carriage: affine maps from block deviations to block displacements.
#[derive(Clone, Debug)]
pub struct Carriage {
    guide: Guide,
    lateral_dir: Vector3<f64>,
    /// `F = vert_inv · (load_rhs + coupling(d))`.
    vert_inv: Matrix4<f64>,
    horiz_inv: Matrix4<f64>,
    /// `w = vert_map · d + vert_load`.
    vert_map: Matrix4<f64>,
    vert_load: Vector4<f64>,
    horiz_map: Matrix4<f64>,
    horiz_load: Vector4<f64>,
}

impl Carriage {
    pub fn new(guide: Guide) -> Result<Self, RailError> {
        let positive = |what, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(RailError::NotPositive { what, value })
            }
        };
        positive("the rail spacing", guide.rail_spacing)?;
        positive("the block pitch", guide.block_pitch)?;
        for &k in &guide.stiffness {
            positive("a block's normal stiffness", k)?;
        }
        for &k in &guide.lateral_stiffness {
            positive("a block's lateral stiffness", k)?;
        }
        for (what, value) in [
            ("the load", guide.load),
            ("the lateral load", guide.lateral_load),
        ] {
            if !value.is_finite() {
                return Err(RailError::NotFinite { what, value });
            }
        }
        let (a, n) = (guide.axis.normalize(), guide.normal.normalize());
        if !(a.iter().chain(n.iter()).all(|v| v.is_finite()) && a.dot(&n).abs() < 1e-9) {
            return Err(RailError::NotPerpendicular {
                normal: guide.normal.into(),
                axis: guide.axis.into(),
            });
        }
        let k = guide.stiffness;
        let ky = guide.lateral_stiffness;
        #[rustfmt::skip]
        let vert = Matrix4::new(
            1.0, 1.0, 1.0, 1.0,
            1.0, 1.0, 0.0, 0.0,
            0.0, 1.0, 1.0, 0.0,
            -1.0 / k[0], 1.0 / k[1], -1.0 / k[2], 1.0 / k[3],
        );
        #[rustfmt::skip]
        let horiz = Matrix4::new(
            1.0, 1.0, 1.0, 1.0,
            0.0, 1.0, 1.0, 0.0,
            -1.0 / ky[0], 0.0, 0.0, 1.0 / ky[3],
            0.0, -1.0 / ky[1], 1.0 / ky[2], 0.0,
        );
        let vert_inv = vert
            .try_inverse()
            .ok_or(RailError::Singular { which: "vertical" })?;
        let horiz_inv = horiz.try_inverse().ok_or(RailError::Singular {
            which: "horizontal",
        })?;
        // Right-hand sides: the load part and the part linear in d.
        let f = guide.load;
        let vert_rhs0 = Vector4::new(-f, -f / 2.0, -f / 2.0, 0.0);
        #[rustfmt::skip]
        let vert_coupling = Matrix4::new(
            0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
            1.0, -1.0, 1.0, -1.0,
        );
        let fy = guide.lateral_load;
        let horiz_rhs0 = Vector4::new(fy, fy / 2.0, 0.0, 0.0);
        #[rustfmt::skip]
        let horiz_coupling = Matrix4::new(
            0.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
            1.0, 0.0, 0.0, -1.0,
            0.0, 1.0, -1.0, 0.0,
        );
        let compliance = Matrix4::from_diagonal(&Vector4::from(k.map(|k| 1.0 / k)));
        let compliance_y = Matrix4::from_diagonal(&Vector4::from(ky.map(|k| 1.0 / k)));
        let vert_map = Matrix4::identity() + compliance * vert_inv * vert_coupling;
        let horiz_map = Matrix4::identity() + compliance_y * horiz_inv * horiz_coupling;
        Ok(Carriage {
            lateral_dir: n.cross(&a),
            vert_load: compliance * vert_inv * vert_rhs0,
            horiz_load: compliance_y * horiz_inv * horiz_rhs0,
            vert_inv,
            horiz_inv,
            vert_map,
            horiz_map,
            guide: Guide {
                axis: a,
                normal: n,
                ..guide
            },
        })
    }

    pub fn guide(&self) -> &Guide {
        &self.guide
    }

    /// `l = n × a`.
    pub fn lateral_dir(&self) -> Vector3<f64> {
        self.lateral_dir
    }

    /// Block forces of eq. (14) for normal block deviations `d` (m): N, negative in compression.
    pub fn vertical_forces(&self, d: &[f64; 4]) -> [f64; 4] {
        let f = self.guide.load;
        let rhs = Vector4::new(-f, -f / 2.0, -f / 2.0, d[0] + d[2] - d[1] - d[3]);
        (self.vert_inv * rhs).into()
    }

    /// Block forces of eq. (15) for lateral block deviations `d` (m), N.
    pub fn horizontal_forces(&self, d: &[f64; 4]) -> [f64; 4] {
        let f = self.guide.lateral_load;
        let rhs = Vector4::new(f, f / 2.0, d[0] - d[3], d[1] - d[2]);
        (self.horiz_inv * rhs).into()
    }

    /// Block displacements `w_i = d_i + F_i/k_i` along `n`, with (`with_load`) or without the
    /// load's share (the motion is affine in `d`; the Monte Carlo adds the load once).
    #[inline]
    pub fn vertical_displacements(&self, d: &[f64; 4], with_load: bool) -> [f64; 4] {
        let mut w = self.vert_map * Vector4::from(*d);
        if with_load {
            w += self.vert_load;
        }
        w.into()
    }

    /// Block displacements `v_i` along `l`.
    #[inline]
    pub fn horizontal_displacements(&self, d: &[f64; 4], with_load: bool) -> [f64; 4] {
        let mut v = self.horiz_map * Vector4::from(*d);
        if with_load {
            v += self.horiz_load;
        }
        v.into()
    }

    /// The plate motion for normal deviations `dn` and lateral deviations `dl` of the blocks.
    #[inline]
    pub fn motion(&self, dn: &[f64; 4], dl: &[f64; 4], with_load: bool) -> PlateMotion {
        let w = self.vertical_displacements(dn, with_load);
        let v = self.horizontal_displacements(dl, with_load);
        let (l, wd) = (self.guide.block_pitch, self.guide.rail_spacing);
        PlateMotion {
            normal: 0.25 * (w[0] + w[1] + w[2] + w[3]),
            lateral: 0.25 * (v[0] + v[1] + v[2] + v[3]),
            pitch: ((w[1] + w[2]) - (w[0] + w[3])) / (2.0 * l),
            roll: ((w[2] + w[3]) - (w[0] + w[1])) / (2.0 * wd),
            yaw: ((v[1] + v[2]) - (v[0] + v[3])) / (2.0 * l),
        }
    }

    /// The body twist `[δ; ω]` (machine directions; about the carriage centre) of a plate motion.
    #[inline]
    pub fn body_twist(&self, m: &PlateMotion) -> [f64; 6] {
        let (a, n, l) = (self.guide.axis, self.guide.normal, self.lateral_dir);
        let t = n * m.normal + l * m.lateral;
        let w = a * m.roll - l * m.pitch + n * m.yaw;
        [t.x, t.y, t.z, w.x, w.y, w.z]
    }

    /// Position of block `i` (0-based: blocks 1–4) relative to the carriage centre, machine
    /// directions.
    pub fn block_position(&self, i: usize) -> Vector3<f64> {
        let (a, l) = (self.guide.axis, self.lateral_dir);
        let (half_l, half_w) = (0.5 * self.guide.block_pitch, 0.5 * self.guide.rail_spacing);
        let (along, across) = match i {
            0 => (-half_l, -half_w),
            1 => (half_l, -half_w),
            2 => (half_l, half_w),
            _ => (-half_l, half_w),
        };
        a * along + l * across
    }
}

/// Random mounting-surface profiles along one rail, within a straightness zone.
///
/// Source 001 does not describe its generator (its note §2.6). mtcal's, stated here as an
/// assumption: a profile over the rail length `[lo − L/2, hi + L/2]` (the stretch the blocks
/// touch) is a sum of `modes` harmonics, `sin(mπξ)` and `cos(mπξ)` for `m = 1 … modes`,
/// `ξ ∈ [0, 1]` along the rail, with independent normal amplitudes of standard deviation
/// `m^(−decay)`, minus its least-squares line (a straightness tolerance fixes neither the
/// height nor the slope of the surface: those are other tolerances). The profile is then
/// scaled so that its zone about that line (max − min over 101 points along the rail and the
/// block positions) is the drawn width. The zone about the least-squares line is at least the
/// minimum-zone straightness, so a profile of width `t` is within a tolerance `t`.
#[derive(Clone, Debug)]
pub struct ProfileBasis {
    modes: usize,
    /// `n_points × 2·modes`, row-major: the detrended harmonics, already weighted by
    /// `m^(−decay)`.
    table: Vec<f64>,
    n_points: usize,
    /// Rows `first_block..first_block + n_knots` are the rear block positions, the next
    /// `n_knots` the front ones.
    first_block: usize,
    n_knots: usize,
}

/// Points along the rail where the profile's zone is measured.
const ZONE_POINTS: usize = 101;

impl ProfileBasis {
    /// For the carriage centre at `knots` (axis positions, m) on a stroke `(lo, hi)` with block
    /// pitch `pitch`.
    pub fn new(knots: &[f64], stroke: (f64, f64), pitch: f64, modes: usize, decay: f64) -> Self {
        let (start, end) = (stroke.0 - 0.5 * pitch, stroke.1 + 0.5 * pitch);
        let len = end - start;
        let xi = |u: f64| (u - start) / len;
        let mut points: Vec<f64> = (0..ZONE_POINTS)
            .map(|i| i as f64 / (ZONE_POINTS - 1) as f64)
            .collect();
        let first_block = points.len();
        points.extend(knots.iter().map(|&q| xi(q - 0.5 * pitch)));
        points.extend(knots.iter().map(|&q| xi(q + 0.5 * pitch)));
        let cols = 2 * modes;
        let raw = |x: f64, c: usize| {
            let m = (c / 2 + 1) as f64;
            let phase = m * std::f64::consts::PI * x;
            let v = if c % 2 == 0 { phase.sin() } else { phase.cos() };
            v * m.powf(-decay)
        };
        let mut table = vec![0.0; points.len() * cols];
        for c in 0..cols {
            // Least-squares line of this harmonic over the uniform points.
            let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
            for &x in &points[..ZONE_POINTS] {
                let y = raw(x, c);
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
            }
            let n = ZONE_POINTS as f64;
            let slope = (n * sxy - sx * sy) / (n * sxx - sx * sx);
            let icpt = (sy - slope * sx) / n;
            for (i, &x) in points.iter().enumerate() {
                table[i * cols + c] = raw(x, c) - (icpt + slope * x);
            }
        }
        ProfileBasis {
            modes,
            table,
            n_points: points.len(),
            first_block,
            n_knots: knots.len(),
        }
    }

    /// Amplitudes a sample draws (`2·modes` standard normals).
    pub fn n_amplitudes(&self) -> usize {
        2 * self.modes
    }

    /// Scratch length [`Self::profile`] needs.
    pub fn n_points(&self) -> usize {
        self.n_points
    }

    /// The profile for standard-normal `amplitudes`, scaled to zone width `width`, into
    /// `scratch` (`n_points` long); writes the rear and front block values (one per knot).
    pub fn profile(
        &self,
        amplitudes: &[f64],
        width: f64,
        scratch: &mut [f64],
        rear: &mut [f64],
        front: &mut [f64],
    ) {
        let cols = 2 * self.modes;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (i, s) in scratch[..self.n_points].iter_mut().enumerate() {
            let row = &self.table[i * cols..(i + 1) * cols];
            let v: f64 = row.iter().zip(amplitudes).map(|(a, b)| a * b).sum();
            *s = v;
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let zone = hi - lo;
        let scale = if zone > 0.0 { width / zone } else { 0.0 };
        let n = self.n_knots;
        let b = self.first_block;
        for k in 0..n {
            rear[k] = scratch[b + k] * scale;
            front[k] = scratch[b + n + k] * scale;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guide(k: [f64; 4], load: f64) -> Guide {
        Guide {
            axis: Vector3::x(),
            normal: Vector3::z(),
            rail_spacing: 0.4,
            block_pitch: 0.3,
            stiffness: k,
            lateral_stiffness: k,
            load,
            lateral_load: 0.0,
        }
    }

    const K: f64 = 5e8; // 500 N/µm

    #[test]
    fn flat_rails_share_the_load_equally() {
        // The source note's check: F_i = −F_zz/4 (and F_zy/4) for flat rails, equal stiffness.
        let c = Carriage::new(Guide {
            lateral_load: 800.0,
            ..guide([K; 4], 2000.0)
        })
        .unwrap();
        for f in c.vertical_forces(&[0.0; 4]) {
            assert!((f + 500.0).abs() < 1e-9, "{f}");
        }
        for f in c.horizontal_forces(&[0.0; 4]) {
            assert!((f - 200.0).abs() < 1e-9, "{f}");
        }
        let m = c.motion(&[0.0; 4], &[0.0; 4], true);
        assert!(
            (m.normal + 500.0 / K).abs() < 1e-18 && m.pitch.abs() < 1e-18 && m.roll.abs() < 1e-18
        );
        assert!((m.lateral - 200.0 / K).abs() < 1e-18 && m.yaw.abs() < 1e-18);
    }

    #[test]
    fn equations_hold_for_unequal_stiffness_and_load() {
        let c = Carriage::new(Guide {
            lateral_stiffness: [3e8, 4e8, 5e8, 6e8],
            lateral_load: -300.0,
            ..guide([2e8, 5e8, 3e8, 7e8], 1500.0)
        })
        .unwrap();
        let d = [3e-6, -2e-6, 5e-6, 1e-6];
        let f = c.vertical_forces(&d);
        let w = c.vertical_displacements(&d, true);
        let k = c.guide().stiffness;
        assert!((f.iter().sum::<f64>() + 1500.0).abs() < 1e-9);
        assert!((f[0] + f[1] + 750.0).abs() < 1e-9 && (f[1] + f[2] + 750.0).abs() < 1e-9);
        for i in 0..4 {
            assert!((w[i] - (d[i] + f[i] / k[i])).abs() < 1e-15);
        }
        assert!((w[0] + w[2] - w[1] - w[3]).abs() < 1e-15, "coplanar");
        let fy = c.horizontal_forces(&d);
        let v = c.horizontal_displacements(&d, true);
        assert!((fy.iter().sum::<f64>() + 300.0).abs() < 1e-9);
        assert!((fy[1] + fy[2] + 150.0).abs() < 1e-9);
        assert!(
            (v[0] - v[3]).abs() < 1e-15 && (v[1] - v[2]).abs() < 1e-15,
            "rigid in plane"
        );
    }

    #[test]
    fn one_rail_raised_is_pure_roll_and_a_ramp_is_pitch() {
        let c = Carriage::new(guide([K; 4], 0.0)).unwrap();
        let (wd, l) = (0.4, 0.3);
        // Rail B (blocks 3, 4) 10 µm higher: roll 10 µm / W, centre up 5 µm, no pitch.
        let m = c.motion(&[0.0, 0.0, 10e-6, 10e-6], &[0.0; 4], false);
        assert!((m.roll - 10e-6 / wd).abs() < 1e-15 && m.pitch.abs() < 1e-18);
        assert!((m.normal - 5e-6).abs() < 1e-15);
        // Both rails on a ramp of slope g at centre position q: pitch g, centre g·q.
        let (g, q) = (20e-6, 0.1);
        let h = |u: f64| g * u;
        let d = [
            h(q - l / 2.0),
            h(q + l / 2.0),
            h(q + l / 2.0),
            h(q - l / 2.0),
        ];
        let m = c.motion(&d, &[0.0; 4], false);
        assert!((m.pitch - g).abs() < 1e-15 && m.roll.abs() < 1e-18);
        assert!((m.normal - g * q).abs() < 1e-15);
        // One rail (A) on the ramp: half the pitch, roll −g·q/W.
        let d = [h(q - l / 2.0), h(q + l / 2.0), 0.0, 0.0];
        let m = c.motion(&d, &[0.0; 4], false);
        assert!((m.pitch - g / 2.0).abs() < 1e-15);
        assert!((m.roll + g * q / wd).abs() < 1e-15);
        // Lateral: both rails bent the same way → yaw.
        let m = c.motion(&[0.0; 4], &d.map(|x| -x), false);
        assert!((m.yaw + g / 2.0).abs() < 1e-15 && (m.lateral + g * q / 2.0).abs() < 1e-15);
    }

    #[test]
    fn a_parabolic_profile_gives_its_slope_as_pitch_and_an_averaged_height() {
        // h(u) = c·u² on both rails: pitch = h'(q) = 2cq exactly, height c(q² + L²/4).
        let c = Carriage::new(guide([K; 4], 0.0)).unwrap();
        let (cc, l) = (1e-4, 0.3);
        for q in [-0.3, -0.05, 0.0, 0.2] {
            let h = |u: f64| cc * u * u;
            let d = [
                h(q - l / 2.0),
                h(q + l / 2.0),
                h(q + l / 2.0),
                h(q - l / 2.0),
            ];
            let m = c.motion(&d, &[0.0; 4], false);
            assert!((m.pitch - 2.0 * cc * q).abs() < 1e-15, "{q}: {}", m.pitch);
            assert!((m.normal - cc * (q * q + l * l / 4.0)).abs() < 1e-15);
            assert!(m.roll.abs() < 1e-18);
        }
    }

    #[test]
    fn the_twist_reproduces_every_block_displacement() {
        // Rigid plate: the body twist moves each block's point by its w_i along n and v_i along
        // l, for any guide orientation (here a Z axis on a column face, normal −y).
        let c = Carriage::new(Guide {
            axis: Vector3::z(),
            normal: -Vector3::y(),
            ..guide([K; 4], 0.0)
        })
        .unwrap();
        let dn = [3e-6, -1e-6, 4e-6, 2e-6];
        let dl = [-2e-6, 5e-6, 1e-6, 0.5e-6];
        let m = c.motion(&dn, &dl, false);
        let t = c.body_twist(&m);
        let (dt, om) = (
            Vector3::new(t[0], t[1], t[2]),
            Vector3::new(t[3], t[4], t[5]),
        );
        let w = c.vertical_displacements(&dn, false);
        let v = c.horizontal_displacements(&dl, false);
        let (n, l) = (c.guide().normal, c.lateral_dir());
        for i in 0..4 {
            let disp = dt + om.cross(&c.block_position(i));
            assert!((disp.dot(&n) - w[i]).abs() < 1e-15, "block {i} normal");
            assert!((disp.dot(&l) - v[i]).abs() < 1e-15, "block {i} lateral");
        }
    }

    #[test]
    fn bad_guides_are_errors() {
        assert!(matches!(
            Carriage::new(guide([K, 0.0, K, K], 0.0)),
            Err(RailError::NotPositive { .. })
        ));
        assert!(matches!(
            Carriage::new(Guide {
                normal: Vector3::x(),
                ..guide([K; 4], 0.0)
            }),
            Err(RailError::NotPerpendicular { .. })
        ));
        assert!(matches!(
            Carriage::new(Guide {
                rail_spacing: f64::NAN,
                ..guide([K; 4], 0.0)
            }),
            Err(RailError::NotPositive { .. })
        ));
    }

    #[test]
    fn profiles_fill_their_zone_and_have_no_line() {
        let knots: Vec<f64> = (0..11).map(|i| -0.375 + 0.075 * i as f64).collect();
        let b = ProfileBasis::new(&knots, (-0.375, 0.375), 0.3, 8, 1.0);
        let mut s = vec![0.0; b.n_points()];
        let (mut rear, mut front) = (vec![0.0; 11], vec![0.0; 11]);
        let amps: Vec<f64> = (0..16)
            .map(|i| ((i * 37 % 11) as f64 - 5.0) / 3.0)
            .collect();
        b.profile(&amps, 30e-6, &mut s, &mut rear, &mut front);
        let scale = 30e-6
            / (s.iter().cloned().fold(f64::MIN, f64::max)
                - s.iter().cloned().fold(f64::MAX, f64::min));
        let zoned: Vec<f64> = s.iter().map(|v| v * scale).collect();
        let range = zoned.iter().cloned().fold(f64::MIN, f64::max)
            - zoned.iter().cloned().fold(f64::MAX, f64::min);
        assert!((range - 30e-6).abs() < 1e-15);
        // The block values lie in the zone, and the uniform points have no LS slope.
        let (lo, hi) = (
            zoned.iter().cloned().fold(f64::MAX, f64::min),
            zoned.iter().cloned().fold(f64::MIN, f64::max),
        );
        assert!(rear.iter().chain(&front).all(|v| (lo..=hi).contains(v)));
        let n = ZONE_POINTS as f64;
        let xs: Vec<f64> = (0..ZONE_POINTS).map(|i| i as f64 / (n - 1.0)).collect();
        let mx = xs.iter().sum::<f64>() / n;
        let slope: f64 = xs
            .iter()
            .zip(&zoned)
            .map(|(x, y)| (x - mx) * y)
            .sum::<f64>();
        let mean: f64 = zoned[..ZONE_POINTS].iter().sum::<f64>() / n;
        assert!(slope.abs() < 1e-18 && mean.abs() < 1e-18, "{slope} {mean}");
        // Block positions: the front block at knot k sits where the rear one at k + 4 does.
        assert!((front[0] - rear[4]).abs() < 1e-18);
    }
}
