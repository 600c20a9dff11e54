//! The machine model a tolerance analysis evaluates, and its allocation-free grid maximum.
//!
//! # The analysis model
//! The machine's own error model (its `.errors.toml`, e.g. quadratic Legendre polynomials)
//! would smooth the rail-derived error curves. The analysis therefore builds its own
//! [`MachineModel`] of the machine: the 18 component errors of X, Y and Z as piecewise-linear
//! tables whose knots are the grid's positions of that axis (so a sampled curve is represented
//! exactly at every grid point) and the three squareness errors `EC0Y`, `EB0Z`, `EA0Z`. The
//! tables follow mtcal's rules for what a component error leaves out
//! ([`mtcal_kinematics::BasisChoice::build`]): positioning is pinned to zero at the stroke's
//! start (its constant is a set-up offset), straightness at both ends (its constant is a set-up
//! offset, its end-point slope a squareness or a turn of the whole workpiece), angular errors
//! keep everything. [`Layout::to_coefficients`] applies those rules to raw curves: it is what
//! identifying the sampled machine in mtcal's conventions would give, so the maps agree with
//! `cargo xtask map` of such a parameter set.
//!
//! # Straightness slopes
//! With `s_kj` the end-point slope of the functional straightness of axis `j` along `k`, the
//! tool moves by `Σ_j q_j s_kj e_k`. Split into a turn `ω` of the workpiece frame (set-up, not a
//! machine error) and mtcal's squareness (X the reference, Y in the XY plane; ARCHITECTURE.md,
//! "Conventions"): `EC0Y = −(s_xy + s_yx)`, `EB0Z = s_xz + s_zx`, `EA0Z = −(s_yz + s_zy)`, and
//! `ω = (s_zy, −s_zx, s_yx)` is dropped. The tests check that the raw and the converted models'
//! maps differ by a rigid motion only.
//!
//! # Grid maximum
//! The first-order pose error is linear in the coefficients, and with the rotary axes held the
//! error due to linear axis `l`'s parameters is `a_l(q_l) + Σ_{j≠l} m_lj(q_l)·(q_j − q_j0)`
//! (the separable structure of [`mtcal_kinematics::volmap::volumetric_map`]). [`GridMax`]
//! tabulates, once, each coefficient's contribution to `a_l` and `m_lj` at every grid value of
//! its axis; per sample it forms the tables (a few thousand flops) and sums them at every grid
//! point. Nothing is allocated per sample.

use mtcal_kinematics::model::default_stroke;
use mtcal_kinematics::volmap::{Grid, GridError};
use mtcal_kinematics::{
    AxisKind, Basis, BasisChoice, Direction, MachineModel, ModelError, ParamConfig, ParamName,
};

/// Why the analysis model cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EvalError {
    #[error(
        "tolerance analysis needs a machine whose linear axes are exactly X, Y and Z along \
         machine x, y and z; this one has {letters}"
    )]
    NotXyz { letters: String },
    #[error(
        "the grid needs at least 3 points on every linear axis (straightness tables), got {counts:?}"
    )]
    GridTooSmall { counts: Vec<usize> },
    #[error(transparent)]
    Grid(#[from] GridError),
    /// The cause is in the message, so it is not also the source.
    #[error("the analysis model: {0}")]
    Model(ModelError),
    #[error(
        "internal check failed: the separable grid evaluation differs from the model by \
         {diff_um:.3e} µm at grid point {point}"
    )]
    Check { point: usize, diff_um: f64 },
}

impl From<ModelError> for EvalError {
    fn from(e: ModelError) -> Self {
        EvalError::Model(e)
    }
}

/// Linear axes of the analysis, X Y Z.
pub const N_LINEAR: usize = 3;

/// The analysis model and where each knot value lives in its coefficient vector.
#[derive(Clone, Debug)]
pub struct Layout {
    model: MachineModel,
    grid: Grid,
    /// Machine axis index of X, Y, Z.
    axes: [usize; N_LINEAR],
    /// Grid positions of each linear axis (m).
    knots: [Vec<f64>; N_LINEAR],
    /// `[axis][direction][knot]` → coefficient index (None: pinned).
    index: [[Vec<Option<usize>>; 6]; N_LINEAR],
    /// Coefficient indices of EC0Y, EB0Z, EA0Z.
    squareness: [usize; 3],
}

impl Layout {
    /// The analysis model of `model`'s machine on a grid of `counts` points per linear axis over
    /// the axis limits (rotary axes held at 0).
    pub fn new(machine: &mtcal_kinematics::Machine, counts: &[usize]) -> Result<Self, EvalError> {
        let linear: Vec<usize> = (0..machine.n_axes())
            .filter(|&i| machine.axes()[i].kind() == AxisKind::Linear)
            .collect();
        let letters: String = linear
            .iter()
            .map(|&i| machine.axes()[i].letter().as_char())
            .collect();
        let ok = letters == "XYZ"
            && linear
                .iter()
                .enumerate()
                .all(|(c, &i)| machine.axes()[i].own_cartesian() == c);
        if !ok {
            return Err(EvalError::NotXyz { letters });
        }
        let axes = [linear[0], linear[1], linear[2]];
        let grid = Grid::with_counts(machine, counts)?;
        if counts.iter().any(|&n| n < 3) {
            return Err(EvalError::GridTooSmall {
                counts: counts.to_vec(),
            });
        }
        let knots: [Vec<f64>; N_LINEAR] = std::array::from_fn(|l| {
            (0..grid.linear()[l].n)
                .map(|k| grid.linear()[l].value(k))
                .collect()
        });
        let mut config = Vec::new();
        for (l, &i) in axes.iter().enumerate() {
            let ax = &machine.axes()[i];
            let choice = BasisChoice::TableAt {
                knots: knots[l].clone(),
            };
            for d in Direction::ALL {
                let basis = choice
                    .build(ax.kind(), ax.own_cartesian(), d, default_stroke(machine, i))
                    .map_err(|source| ModelError::Basis {
                        name: ParamName::component(d, ax.letter()).to_string(),
                        cause: source,
                    })?;
                config.push(ParamConfig {
                    name: ParamName::component(d, ax.letter()),
                    basis: Some(basis),
                });
            }
        }
        for name in ["EC0Y", "EB0Z", "EA0Z"] {
            config.push(ParamConfig {
                name: name.parse().expect("ISO squareness name"),
                basis: None,
            });
        }
        let model = MachineModel::new(machine.clone(), &config)?;
        let mut index: [[Vec<Option<usize>>; 6]; N_LINEAR] = Default::default();
        for (l, &i) in axes.iter().enumerate() {
            let letter = machine.axes()[i].letter();
            for d in Direction::ALL {
                let p = model
                    .errors()
                    .find(&ParamName::component(d, letter))
                    .expect("configured above");
                let Some(mtcal_kinematics::model::Role::Component {
                    basis:
                        Basis::Table {
                            pin_first,
                            pin_last,
                            ..
                        },
                    ..
                }) = Some(&p.role)
                else {
                    unreachable!("tables configured above")
                };
                let n = knots[l].len();
                index[l][d.index()] = (0..n)
                    .map(|k| {
                        let pinned = (*pin_first && k == 0) || (*pin_last && k + 1 == n);
                        (!pinned).then(|| p.offset + k - usize::from(*pin_first))
                    })
                    .collect();
            }
        }
        let squareness = ["EC0Y", "EB0Z", "EA0Z"].map(|n| {
            model
                .errors()
                .find(&n.parse().expect("ISO name"))
                .expect("configured above")
                .offset
        });
        Ok(Layout {
            model,
            grid,
            axes,
            knots,
            index,
            squareness,
        })
    }

    pub fn model(&self) -> &MachineModel {
        &self.model
    }

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    pub fn n_coeffs(&self) -> usize {
        self.model.n_coeffs()
    }

    /// Machine axis index of linear axis `l` (0 = X, 1 = Y, 2 = Z).
    pub fn axis(&self, l: usize) -> usize {
        self.axes[l]
    }

    /// Grid positions of linear axis `l` (m).
    pub fn knots(&self, l: usize) -> &[f64] {
        &self.knots[l]
    }

    /// Coefficient index of squareness `s` (0 = EC0Y, 1 = EB0Z, 2 = EA0Z).
    pub fn squareness(&self, s: usize) -> usize {
        self.squareness[s]
    }

    /// Adds raw functional component-error curves to `out` in the model's conventions (module
    /// docs): `raw.curve(l, d)[k]` is the error of axis `l` in direction `d` at its knot `k`
    /// (m, rad), nothing left out.
    // Index loops over parallel fixed-size arrays (axes, directions) read best here.
    #[allow(clippy::needless_range_loop)]
    pub fn to_coefficients(&self, raw: &RawCurves, out: &mut [f64]) {
        let mut s = [[0.0; N_LINEAR]; 3]; // s[k][j]: slope of E_k(axis j)
        for l in 0..N_LINEAR {
            let q = &self.knots[l];
            let n = q.len();
            for d in 0..6 {
                let e = raw.curve(l, d);
                let idx = &self.index[l][d];
                if d == l {
                    for k in 1..n {
                        add(out, idx[k], e[k] - e[0]);
                    }
                } else if d < 3 {
                    let slope = (e[n - 1] - e[0]) / (q[n - 1] - q[0]);
                    s[d][l] += slope;
                    for k in 1..n - 1 {
                        add(out, idx[k], e[k] - e[0] - slope * (q[k] - q[0]));
                    }
                } else {
                    for k in 0..n {
                        add(out, idx[k], e[k]);
                    }
                }
            }
        }
        out[self.squareness[0]] += -(s[0][1] + s[1][0]);
        out[self.squareness[1]] += s[0][2] + s[2][0];
        out[self.squareness[2]] += -(s[1][2] + s[2][1]);
    }
}

#[inline]
fn add(out: &mut [f64], idx: Option<usize>, v: f64) {
    if let Some(i) = idx {
        out[i] += v;
    }
}

/// Raw functional component-error curves of X, Y, Z at their grid knots (m, rad).
#[derive(Clone, Debug)]
pub struct RawCurves {
    /// `[axis][direction]` → values at the knots.
    values: [[Vec<f64>; 6]; N_LINEAR],
}

impl RawCurves {
    pub fn new(layout: &Layout) -> Self {
        RawCurves {
            values: std::array::from_fn(|l| {
                std::array::from_fn(|_| vec![0.0; layout.knots(l).len()])
            }),
        }
    }

    pub fn curve(&self, l: usize, d: usize) -> &[f64] {
        &self.values[l][d]
    }

    pub fn curve_mut(&mut self, l: usize, d: usize) -> &mut [f64] {
        &mut self.values[l][d]
    }

    pub fn clear(&mut self) {
        for v in self.values.iter_mut().flatten() {
            v.fill(0.0);
        }
    }
}

/// One coefficient's contribution at one knot: `a` and the slopes `m[j]` (m per m of `q_j`).
#[derive(Clone, Copy, Debug)]
struct Entry {
    coeff: usize,
    a: [f64; 3],
    m: [[f64; 3]; N_LINEAR],
}

/// The maximum translation error over the grid, allocation-free per evaluation.
#[derive(Clone, Debug)]
pub struct GridMax {
    /// `[axis]` → per knot, the entries with a nonzero contribution.
    entries: [Vec<Vec<Entry>>; N_LINEAR],
    /// `q_l − q_l0` at each knot.
    offsets: [Vec<f64>; N_LINEAR],
}

/// Per-evaluation tables of [`GridMax`].
#[derive(Clone, Debug)]
pub struct GridScratch {
    a: [Vec<[f64; 3]>; N_LINEAR],
    m: [Vec<[[f64; 3]; N_LINEAR]>; N_LINEAR],
    /// `a_2[k] + m_20[k]·d0[i]` for the current `i`.
    inner: Vec<[f64; 3]>,
}

impl GridMax {
    pub fn new(layout: &Layout) -> Result<Self, EvalError> {
        let model = layout.model();
        let machine = model.machine();
        let mut ws = model.workspace();
        let n = model.n_coeffs();
        let mut q = vec![0.0; machine.n_axes()];
        let base: [f64; N_LINEAR] = std::array::from_fn(|l| layout.knots(l)[0]);
        let top: [f64; N_LINEAR] = std::array::from_fn(|l| *layout.knots(l).last().unwrap());
        let mut unit = vec![0.0; n];
        let mut entries: [Vec<Vec<Entry>>; N_LINEAR] =
            std::array::from_fn(|l| vec![Vec::new(); layout.knots(l).len()]);
        for p in model.errors().params() {
            let axis = match p.role {
                mtcal_kinematics::model::Role::Component { axis, .. }
                | mtcal_kinematics::model::Role::Location { axis, .. } => axis,
                _ => unreachable!("the analysis model has no set-up parameters"),
            };
            let l = (0..N_LINEAR)
                .find(|&l| layout.axis(l) == axis)
                .expect("linear axis");
            for c in p.offset..p.offset + p.len {
                unit.fill(0.0);
                unit[c] = 1.0;
                for (k, &qk) in layout.knots(l).iter().enumerate() {
                    for j in 0..N_LINEAR {
                        q[layout.axis(j)] = base[j];
                    }
                    q[layout.axis(l)] = qk;
                    let a = model.pose_error_first_order(&q, &unit, &mut ws).translation;
                    let mut m = [[0.0; 3]; N_LINEAR];
                    for j in (0..N_LINEAR).filter(|&j| j != l) {
                        q[layout.axis(j)] = top[j];
                        let e = model.pose_error_first_order(&q, &unit, &mut ws).translation;
                        q[layout.axis(j)] = base[j];
                        let d = (e - a) / (top[j] - base[j]);
                        m[j] = [d.x, d.y, d.z];
                    }
                    let a = [a.x, a.y, a.z];
                    if a.iter().chain(m.iter().flatten()).any(|v| *v != 0.0) {
                        entries[l][k].push(Entry { coeff: c, a, m });
                    }
                }
            }
        }
        let offsets =
            std::array::from_fn(|l| layout.knots(l).iter().map(|q| q - base[l]).collect());
        let g = GridMax { entries, offsets };
        g.check(layout)?;
        Ok(g)
    }

    /// Compares the separable sums with direct evaluation at a few grid points for a
    /// deterministic coefficient set.
    fn check(&self, layout: &Layout) -> Result<(), EvalError> {
        let model = layout.model();
        let coeffs: Vec<f64> = (0..model.n_coeffs())
            .map(|k| 1e-6 * (((k * 7919) % 41) as f64 - 20.0))
            .collect();
        let mut s = self.scratch();
        self.tables(&coeffs, &mut s);
        let mut ws = model.workspace();
        let grid = layout.grid();
        let mut q = vec![0.0; grid.n_axes()];
        let n = grid.len();
        let dims: [usize; N_LINEAR] = std::array::from_fn(|l| self.offsets[l].len());
        for t in 0..8 {
            let k = t * (n - 1) / 7;
            grid.point(k, &mut q);
            let direct = model
                .pose_error_first_order(&q, &coeffs, &mut ws)
                .translation;
            let idx = [
                k / (dims[1] * dims[2]),
                (k / dims[2]) % dims[1],
                k % dims[2],
            ];
            let e = self.point(&s, idx);
            let diff =
                ((e[0] - direct.x).powi(2) + (e[1] - direct.y).powi(2) + (e[2] - direct.z).powi(2))
                    .sqrt();
            if diff > 1e-12 + 1e-9 * direct.norm() {
                return Err(EvalError::Check {
                    point: k,
                    diff_um: diff * 1e6,
                });
            }
        }
        Ok(())
    }

    pub fn scratch(&self) -> GridScratch {
        GridScratch {
            a: std::array::from_fn(|l| vec![[0.0; 3]; self.offsets[l].len()]),
            m: std::array::from_fn(|l| vec![[[0.0; 3]; N_LINEAR]; self.offsets[l].len()]),
            inner: vec![[0.0; 3]; self.offsets[2].len()],
        }
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.offsets.iter().map(Vec::len).product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    // Index loops over parallel fixed-size arrays (axes, directions) read best here.
    #[allow(clippy::needless_range_loop)]
    fn tables(&self, coeffs: &[f64], s: &mut GridScratch) {
        for l in 0..N_LINEAR {
            for (k, list) in self.entries[l].iter().enumerate() {
                let (mut a, mut m) = ([0.0; 3], [[0.0; 3]; N_LINEAR]);
                for e in list {
                    let c = coeffs[e.coeff];
                    if c == 0.0 {
                        continue;
                    }
                    for r in 0..3 {
                        a[r] += e.a[r] * c;
                        for j in 0..N_LINEAR {
                            m[j][r] += e.m[j][r] * c;
                        }
                    }
                }
                s.a[l][k] = a;
                s.m[l][k] = m;
            }
        }
    }

    /// The translation error (m) at grid index `idx` (X, Y, Z knots) from the tables.
    // Index loops over parallel fixed-size arrays (axes, directions) read best here.
    #[allow(clippy::needless_range_loop)]
    fn point(&self, s: &GridScratch, idx: [usize; N_LINEAR]) -> [f64; 3] {
        let d: [f64; N_LINEAR] = std::array::from_fn(|l| self.offsets[l][idx[l]]);
        let mut e = [0.0; 3];
        for l in 0..N_LINEAR {
            for r in 0..3 {
                e[r] += s.a[l][idx[l]][r];
                for j in (0..N_LINEAR).filter(|&j| j != l) {
                    e[r] += s.m[l][idx[l]][j][r] * d[j];
                }
            }
        }
        e
    }

    /// The largest translation error |Δ| over the grid, m, for `coeffs` of the analysis model.
    pub fn max(&self, coeffs: &[f64], s: &mut GridScratch) -> f64 {
        self.tables(coeffs, s);
        let [d0, d1, d2] = &self.offsets;
        let mut best = 0.0f64;
        for (i, &x) in d0.iter().enumerate() {
            let (a0, m0) = (s.a[0][i], s.m[0][i]);
            for (k, inner) in s.inner.iter_mut().enumerate() {
                let (a2, m2) = (&s.a[2][k], &s.m[2][k]);
                *inner = std::array::from_fn(|r| a2[r] + m2[0][r] * x);
            }
            for (j, &y) in d1.iter().enumerate() {
                let (a1, m1) = (s.a[1][j], s.m[1][j]);
                let base: [f64; 3] =
                    std::array::from_fn(|r| a0[r] + a1[r] + m0[1][r] * y + m1[0][r] * x);
                let rz: [f64; 3] = std::array::from_fn(|r| m0[2][r] + m1[2][r]);
                for ((inner, &z), m2) in s.inner.iter().zip(d2).zip(&s.m[2]) {
                    let ex = base[0] + inner[0] + rz[0] * z + m2[1][0] * y;
                    let ey = base[1] + inner[1] + rz[1] * z + m2[1][1] * y;
                    let ez = base[2] + inner[2] + rz[2] * z + m2[1][2] * y;
                    best = best.max(ex * ex + ey * ey + ez * ez);
                }
            }
        }
        best.sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_kinematics::volmap::{MapOptions, volumetric_map};
    use mtcal_machine::topology::Reading;

    fn zfyx() -> mtcal_kinematics::Machine {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/three-axis/machine/zfyx.urdf"
        );
        mtcal_machine::load_machine(path, Reading::FromTool)
            .unwrap()
            .machine
    }

    fn pseudo(n: usize, scale: f64, salt: usize) -> Vec<f64> {
        (0..n)
            .map(|k| scale * ((((k + salt) * 7919) % 41) as f64 - 20.0) / 20.0)
            .collect()
    }

    #[test]
    fn grid_max_equals_the_volumetric_map_maximum() {
        for (machine, counts) in [
            (zfyx(), [5, 4, 3]),
            (
                mtcal_machine::load_machine("CAFYXZ", Reading::FromWorkpiece)
                    .unwrap()
                    .machine,
                [3, 6, 4],
            ),
        ] {
            let layout = Layout::new(&machine, &counts).unwrap();
            let g = GridMax::new(&layout).unwrap();
            let mut s = g.scratch();
            for salt in 0..3 {
                let c = pseudo(layout.n_coeffs(), 1e-5, salt);
                let map = volumetric_map(
                    layout.model(),
                    &c,
                    layout.grid(),
                    &MapOptions {
                        pointwise: true,
                        ..MapOptions::default()
                    },
                );
                let want = map.summary(&[]).max_um;
                let got = g.max(&c, &mut s) * 1e6;
                assert!((got - want).abs() < 1e-9 * want.max(1.0), "{got} vs {want}");
            }
        }
    }

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn conversion_differs_from_the_raw_curves_by_a_rigid_motion_only() {
        // Raw model: unpinned tables, no squareness, so any curve is represented as is.
        let machine = zfyx();
        let counts = [5, 4, 6];
        let layout = Layout::new(&machine, &counts).unwrap();
        let mut config = Vec::new();
        for l in 0..N_LINEAR {
            let letter = machine.axes()[layout.axis(l)].letter();
            for d in Direction::ALL {
                config.push(ParamConfig {
                    name: ParamName::component(d, letter),
                    basis: Some(Basis::table(layout.knots(l).to_vec(), false, false).unwrap()),
                });
            }
        }
        let raw_model = MachineModel::new(machine.clone(), &config).unwrap();
        let mut raw = RawCurves::new(&layout);
        let mut raw_coeffs = Vec::new();
        for l in 0..N_LINEAR {
            for d in 0..6 {
                let scale = if d < 3 { 10e-6 } else { 20e-6 };
                let v = pseudo(counts[l], scale, 7 * l + d);
                // Add a sizeable constant and slope to every curve.
                let q = layout.knots(l).to_vec();
                for (k, x) in raw.curve_mut(l, d).iter_mut().enumerate() {
                    *x = v[k] + scale * (0.7 - 3.0 * q[k] * (d as f64 - 2.5));
                }
                raw_coeffs.extend_from_slice(raw.curve(l, d));
            }
        }
        let mut conv = vec![0.0; layout.n_coeffs()];
        layout.to_coefficients(&raw, &mut conv);
        let grid = layout.grid();
        let opts = MapOptions::default();
        let a = volumetric_map(&raw_model, &raw_coeffs, grid, &opts);
        let b = volumetric_map(layout.model(), &conv, grid, &opts);
        // Least-squares rigid motion (t, ω) of the difference: Δ = t + ω × p, p the nominal
        // tool point in the workpiece frame.
        let nominal: Vec<_> = (0..grid.len())
            .map(|k| machine.tool_in_workpiece(a.positions(k)).t)
            .collect();
        let mut ata = nalgebra::SMatrix::<f64, 6, 6>::zeros();
        let mut atb = nalgebra::SVector::<f64, 6>::zeros();
        let mut rows = Vec::new();
        for k in 0..grid.len() {
            let diff = (a.point(k).translation_um - b.point(k).translation_um) * 1e-6;
            let p = nominal[k];
            for r in 0..3 {
                // (ω × p)_r as a row in ω.
                let mut row = nalgebra::SVector::<f64, 6>::zeros();
                row[r] = 1.0;
                let e = nalgebra::Vector3::ith(r, 1.0);
                let w = p.cross(&e); // ω·(p × e_r) = (ω × p)·e_r
                row[3] = w.x;
                row[4] = w.y;
                row[5] = w.z;
                ata += row * row.transpose();
                atb += row * diff[r];
                rows.push((row, diff[r]));
            }
        }
        let sol = ata.lu().solve(&atb).unwrap();
        let resid = rows
            .iter()
            .map(|(row, y)| (row.dot(&sol) - y).abs())
            .fold(0.0, f64::max);
        let size = a.summary(&[]).max_um;
        assert!(size > 10.0, "the raw errors are visible: {size} µm");
        assert!(resid < 1e-12, "not rigid: residual {resid:e} m");
        // The angular errors are passed through: the rotation maps agree (straightness slopes
        // and squareness move the tool point only).
        for k in 0..grid.len() {
            let d = a.point(k).rotation_urad - b.point(k).rotation_urad;
            assert!(d.norm() < 1e-9);
        }
    }

    #[test]
    fn machines_without_xyz_and_small_grids_are_errors() {
        let m = mtcal_machine::load_machine("CAFYXZ", Reading::FromWorkpiece)
            .unwrap()
            .machine;
        assert!(matches!(
            Layout::new(&m, &[2, 5, 5]),
            Err(EvalError::GridTooSmall { .. })
        ));
        assert!(matches!(Layout::new(&m, &[5, 5]), Err(EvalError::Grid(_))));
    }
}
