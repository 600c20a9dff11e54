//! From the recordings to the control, on a machine nobody here wrote the numbers of.
//!
//! The independent simulator measures a three-axis machine with a random truth (laser
//! interferometer and laser tracer, realistic noise: coloured, quantised, a σ that is not the
//! one declared, set-ups off nominal); mtcal identifies it; each control's file is made from
//! the identify JSON as `mtcal compensate --params id.json` makes it (the same reader of the
//! JSON, the same writer), read back, and applied as the control's manual says; the
//! simulator's machine then moves to the corrected command. At every node of the file the
//! tool point's residual error (actual − target, machine X/Y/Z) lies within the u95 the
//! identification gives for the modelled error there (`1.96·√(k·gᵀCg)`: `C` the fitted
//! parameters' covariance, `g` the error's gradient, `k` the noise inflation the residuals
//! show), plus the file's written resolution, for at least 90 % of the node components, pooled
//! over three machines, and within 2.5 times it for all: what is left after compensation is
//! what the recordings could not pin down, and nothing a file got wrong. A linear axis'
//! constant angular error turns the whole workspace, which these set-ups cannot see: the truth
//! and the model leave it out, so that every machine error gets a number.
//!
//! Each family of files is applied as its control does:
//! - **axis tables** (LinuxCNC and Fanuc pitch error compensation, SINUMERIK EEC, Heidenhain
//!   `.COM`): the control shifts each axis' command by the table's value at the axis position
//!   (a compensation it adds, or an error it subtracts); checked at the table's nodes, the other
//!   axes at the held position, on what the table holds (a pitch table: along its axis). A
//!   table made zero at the axis' reference point (Fanuc, EEC) leaves the constant there to the
//!   work offset: the residual is taken relative to the reference node, with the u95 of that
//!   difference.
//! - **a model of the machine** (ISG, Etalon, KinematicsComp): the control commands the axes so
//!   that its model of the machine puts the tool on the target; checked on a grid over the
//!   workspace, all three components.
//! - **a grid of tool-point errors** (CSV): the target moved by minus the interpolated error.
//! - **the rotary axes' lines in the control's kinematics** (LinuxCNC's table-table pivots,
//!   CYCLE800's `$TC_CARR`), on the five-axis trunnion measured by R-test and ball bar: the
//!   rotary axes stay where the program puts them and X, Y, Z move so that the control's
//!   kinematics put the tool on the target; the residual less what the truth's other errors do
//!   at the node lies within the u95 of the rotary lines.
//!
//! Each control's side (how it reads its file and moves the axes) is written in the test
//! modules `heidenhain_control`, `carr_control` and `trt_control` from the manuals, or here
//! from the format's documented meaning, on the crate's readers.

use crate::carr_control;
use crate::heidenhain_control;
use crate::trt_control;

use heidenhain_control::KcControl;
use mtcal_compensate::*;
use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use mtcal_indsim::campaign::Campaign;
use mtcal_indsim::machine::{Machine as SimMachine, translation_of};
use mtcal_indsim::session::Realism;
use mtcal_indsim::truth::Truth;
use mtcal_kinematics::model::Role;
use mtcal_kinematics::{AxisKind, MachineModel};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;

/// The identification's numbers, as `compensate` takes them and with their uncertainty.
struct Identified {
    model: MachineModel,
    /// What the identify JSON gives the control (SI); undetermined parameters at zero.
    coeffs: Vec<f64>,
    /// Per machine coefficient of the model: its index in the fit's parameter vector.
    x_index: Vec<Option<usize>>,
    solution: mtcal_solve::Solution,
    inflation: f64,
}

impl Identified {
    /// The tool-point error's gradient (machine X/Y/Z rows) in the fitted parameters, at `q`:
    /// through the machine errors `kept` keeps.
    fn gradient(&self, q: &[f64], kept: &dyn Fn(&Role) -> bool) -> Vec<[f64; 3]> {
        let n = self.model.n_coeffs();
        let mut jac = vec![0.0; 6 * n];
        let mut ws = self.model.workspace();
        self.model
            .pose_error_jacobian(q, &self.coeffs, &mut ws, &mut jac);
        let mut g = vec![[0.0; 3]; self.solution.x.len()];
        for p in self.model.errors().params() {
            if !matches!(p.role, Role::Component { .. } | Role::Location { .. }) || !kept(&p.role) {
                continue;
            }
            for k in p.offset..p.offset + p.len {
                if let Some(i) = self.x_index[k] {
                    for r in 0..3 {
                        g[i][r] += jac[6 * k + r];
                    }
                }
            }
        }
        g
    }

    /// u95 (µm) of the modelled tool-point error along each of `directions` at `q`, or of its
    /// change from `reference` to `q`; of the part the machine errors `kept` make.
    fn u95_um(
        &self,
        q: &[f64],
        reference: Option<&[f64]>,
        directions: &[Vector3<f64>],
        kept: &dyn Fn(&Role) -> bool,
    ) -> Vec<f64> {
        let at = self.gradient(q, kept);
        let from = reference.map(|r| self.gradient(r, kept));
        let diff = |i: usize| {
            let f = from.as_ref().map_or([0.0; 3], |f| f[i]);
            Vector3::new(at[i][0] - f[0], at[i][1] - f[1], at[i][2] - f[2])
        };
        let gradients: Vec<Vector3<f64>> = (0..at.len()).map(diff).collect();
        directions
            .iter()
            .map(|d| {
                let g: Vec<f64> = gradients.iter().map(|v| v.dot(d)).collect();
                let mut var = 0.0;
                for (i, gi) in g.iter().enumerate().filter(|(_, g)| **g != 0.0) {
                    for (j, gj) in g.iter().enumerate().filter(|(_, g)| **g != 0.0) {
                        var += gi * gj * self.solution.cov(i, j);
                    }
                }
                1.96 * (self.inflation * var.max(0.0)).sqrt() * 1e6
            })
            .collect()
    }
}

/// Machine X, Y, Z.
const XYZ: [Vector3<f64>; 3] = [
    Vector3::new(1.0, 0.0, 0.0),
    Vector3::new(0.0, 1.0, 0.0),
    Vector3::new(0.0, 0.0, 1.0),
];

/// The simulated session, its truth and the identification.
struct Case {
    _dir: tempfile::TempDir,
    /// The machine coefficients the identify JSON gives no number.
    not_given: Vec<String>,
    out: std::path::PathBuf,
    sim: SimMachine,
    truth: Truth,
    id: Identified,
    settings: Settings,
}

/// The three-axis machine with the random truth of `seed`, measured and identified.
fn case(seed: u64) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    let urdf = mtcal_indsim::shipped_machine("mcv754-zfyx.urdf");
    let sim = SimMachine::from_urdf_file(&urdf).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut truth = Truth::random(&sim, &mut rng, 1.0);
    // A linear axis' constant angular error turns the whole workspace: laser and tracer
    // readings, each with set-up poses of their own, cannot see it, and the workpiece's
    // alignment takes it. The machine's frame is its axes: no constant, in the truth and in
    // the model.
    for axis in truth.axes.iter_mut() {
        for d in 3..6 {
            axis.component[d][0] = 0.0;
        }
    }
    Campaign::three_axis_laser_tracer(&session, &truth, &[], &Realism::realistic(seed)).unwrap();
    mtcal_testkit::sessions::as_a_user_has_it(&session, None);
    let mut model = String::from(
        "components = \"all\"\nlocations = \"iso\"\n\n[basis.linear]\nkind = \"legendre\"\n\
         degree = 3\n",
    );
    for axis in ['X', 'Y', 'Z'] {
        for d in ['A', 'B', 'C'] {
            model.push_str(&format!("\n[component.E{d}{axis}]\nmin_degree = 1\n"));
        }
    }
    std::fs::write(session.join("machine.errors.toml"), model).unwrap();
    let case = identified(dir, sim, truth);
    // Every machine error gets a number (what is held is of the set-ups).
    assert!(
        case.not_given.is_empty(),
        "the session determines every error: {:?}",
        case.not_given
    );
    case
}

/// The trunnion (a C table on an A cradle) with the random truth of `seed`, measured by R-test
/// and ball bar ([`Campaign::trunnion_rtest_ballbar_with`]) and identified in the eleven
/// location and squareness errors such an R-test check determines, less where the A line
/// passes in Z (the balls' heights take it); the truth has those ten alone, without the rotary
/// lines' tilts unless `tilts`.
fn trunnion_case(seed: u64, tilts: bool) -> Case {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    let sim =
        SimMachine::from_urdf_file(&mtcal_indsim::shipped_machine("mcu630-cafyxz.urdf")).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut truth = Truth::random(&sim, &mut rng, 1.0);
    for axis in truth.axes.iter_mut() {
        axis.component = [[0.0; 4]; 6];
    }
    truth.axes[sim.index('A').unwrap()].location[2] = 0.0;
    if !tilts {
        for letter in ['A', 'C'] {
            truth.axes[sim.index(letter).unwrap()].location[3..].fill(0.0);
        }
    }
    Campaign::trunnion_rtest_ballbar_with(&session, &truth, &Realism::realistic(seed)).unwrap();
    mtcal_testkit::sessions::as_a_user_has_it(
        &session,
        Some(r#"["EC0Y", "EB0Z", "EA0Z", "EY0A", "EB0A", "EC0A", "EX0C", "EY0C", "EA0C", "EB0C"]"#),
    );
    identified(dir, sim, truth)
}

/// The session in `dir/session` identified as `mtcal identify` does.
fn identified(dir: tempfile::TempDir, sim: SimMachine, truth: Truth) -> Case {
    let session = dir.path().join("session");
    let prepared = Prepared::load(&session, PipelineOptions::default()).unwrap();
    let outcome = prepared.run(&mut mtcal_solve::Silent).unwrap();
    assert!(outcome.solution.converged, "the fit converges");
    let study = &outcome.study;
    let model = MachineModel::clone(&study.model);
    // The identify JSON as the user has it, read as `compensate --params id.json` reads it.
    let json = outcome.to_json();
    let json_path = dir.path().join("id.json");
    let from = mtcal_machine::from_identify::read_identify_json(&json, &json_path, model.errors())
        .unwrap();
    let mut x_index = vec![None; model.n_coeffs()];
    for (i, &k) in study.layout().estimated().iter().enumerate() {
        x_index[k] = Some(i);
    }
    let inflation = mtcal_identify::band::noise_inflation(study, &outcome.solution);
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let settings = Settings::new(model.machine(), 50.0, 30.0);
    Case {
        _dir: dir,
        not_given: from.not_given,
        out,
        sim,
        truth,
        id: Identified {
            model,
            coeffs: from.coeffs,
            x_index,
            solution: outcome.solution,
            inflation,
        },
        settings,
    }
}

impl Case {
    /// Writes `what` from the identified coefficients to `name` in the output folder.
    fn write(&self, what: Compensation, name: &str) -> std::path::PathBuf {
        let path = self.out.join(name);
        write_compensation(&self.id.model, &self.id.coeffs, &path, what, &self.settings)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        path
    }

    /// The simulator's axis positions (its own order) for mtcal's `q`.
    fn sim_q(&self, q: &[f64]) -> Vec<f64> {
        let m = self.id.model.machine();
        self.sim
            .letters()
            .chars()
            .map(|c| q[m.axis_index(c).unwrap()])
            .collect()
    }

    /// The actual tool point (m) of the simulated machine at command `q`.
    fn actual(&self, q: &[f64]) -> Vector3<f64> {
        translation_of(
            &self
                .sim
                .tool_in_workpiece(&self.sim_q(q), Some(&self.truth)),
        )
    }

    /// The nominal tool point (m) at `q`.
    fn nominal(&self, q: &[f64]) -> Vector3<f64> {
        self.id.model.machine().tool_in_workpiece(q).t
    }

    /// ∂(nominal tool point)/∂q of the three linear axes (constant on this machine).
    fn nominal_jacobian(&self, q: &[f64]) -> Matrix3<f64> {
        let mut j = Matrix3::zeros();
        for i in 0..3 {
            let mut dq = q.to_vec();
            dq[i] += 1e-3;
            j.set_column(i, &((self.nominal(&dq) - self.nominal(q)) / 1e-3));
        }
        j
    }

    /// The command that puts `believed` (the control's idea of the tool point at a command) on
    /// the nominal tool point of `q`: Newton steps on the nominal Jacobian.
    fn command_for(&self, q: &[f64], mut believed: impl FnMut(&[f64]) -> Vector3<f64>) -> Vec<f64> {
        let target = self.nominal(q);
        let j_inv = self.nominal_jacobian(q).try_inverse().unwrap();
        let mut c = q.to_vec();
        for _ in 0..4 {
            let step = j_inv * (believed(&c) - target);
            for i in 0..3 {
                c[i] -= step[i];
            }
        }
        c
    }

    /// The residual (µm, machine X/Y/Z) at node `q` with command `c`.
    fn residual_um(&self, q: &[f64], c: &[f64]) -> Vector3<f64> {
        (self.actual(c) - self.nominal(q)) * 1e6
    }

    /// The error (µm) the machine has at `q` with no compensation.
    fn uncompensated_um(&self, q: &[f64]) -> Vector3<f64> {
        self.residual_um(q, q)
    }

    /// The nodes (mm) of axis `i` within its limits, in m: a table's rows may reach a spacing
    /// beyond a limit, where it only serves the interpolation up to the limit and the machine
    /// cannot go.
    fn reachable(&self, i: usize, nodes_mm: &[f64]) -> Vec<f64> {
        let (lo, hi) = self.id.model.machine().axes()[i].limits().unwrap();
        nodes_mm
            .iter()
            .map(|p| p * 1e-3)
            .filter(|p| (lo - 1e-9..=hi + 1e-9).contains(p))
            .collect()
    }

    /// A 4 × 4 × 4 grid over 80 % of the strokes.
    fn grid(&self) -> Vec<Vec<f64>> {
        let m = self.id.model.machine();
        let levels: Vec<Vec<f64>> = (0..3)
            .map(|i| {
                let (lo, hi) = m.axes()[i].limits().unwrap();
                let (a, b) = (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo));
                (0..4).map(|k| a + (b - a) * k as f64 / 3.0).collect()
            })
            .collect();
        let mut out = Vec::new();
        for &x in &levels[0] {
            for &y in &levels[1] {
                for &z in &levels[2] {
                    out.push(vec![x, y, z]);
                }
            }
        }
        out
    }
}

/// Residuals against their u95 over a file's nodes.
#[derive(Default)]
struct Tally {
    components: usize,
    within: usize,
    worst_ratio: f64,
    residual_ss: f64,
    uncompensated_ss: f64,
    u95_sum: f64,
}

impl Tally {
    /// One node component: residual and uncompensated error (µm), u95 (µm), the file's
    /// resolution (µm).
    fn add(&mut self, residual: f64, uncompensated: f64, u95: f64, resolution: f64) {
        let bound = u95 + resolution;
        self.components += 1;
        self.within += usize::from(residual.abs() <= bound);
        self.worst_ratio = self.worst_ratio.max(residual.abs() / bound);
        self.residual_ss += residual * residual;
        self.uncompensated_ss += uncompensated * uncompensated;
        self.u95_sum += u95;
    }

    fn merge(&mut self, other: &Tally) {
        self.components += other.components;
        self.within += other.within;
        self.worst_ratio = self.worst_ratio.max(other.worst_ratio);
        self.residual_ss += other.residual_ss;
        self.uncompensated_ss += other.uncompensated_ss;
        self.u95_sum += other.u95_sum;
    }

    fn rms_um(&self) -> (f64, f64) {
        let n = self.components as f64;
        (
            (self.residual_ss / n).sqrt(),
            (self.uncompensated_ss / n).sqrt(),
        )
    }

    fn share(&self) -> f64 {
        self.within as f64 / self.components as f64
    }

    fn print(&self, name: &str) {
        let n = self.components as f64;
        let (rms, before) = self.rms_um();
        let share = self.share();
        eprintln!(
            "{name}: {} node components, {:.0} % within u95 (mean {:.2} µm), worst {:.2} × u95; \
             RMS {rms:.2} µm after, {before:.2} µm before",
            self.components,
            100.0 * share,
            self.u95_sum / n,
            self.worst_ratio
        );
    }

    fn check(&self, name: &str) {
        let (rms, before) = self.rms_um();
        let share = self.share();
        assert!(self.components >= 10, "{name}: too few nodes");
        // The test bites: the machine's error is many times what is left.
        assert!(
            before > 4.0 * rms,
            "{name}: {before} µm before, {rms} µm after"
        );
        assert!(share >= 0.9, "{name}: {:.0} % within u95", 100.0 * share);
        // Pooled over hundreds of node components, a 95 % band's tail reaches twice the u95
        // by chance (3.9 σ: 1e-4 per component); 2.5 × is 4.9 σ.
        assert!(
            self.worst_ratio <= 2.5,
            "{name}: {} × u95",
            self.worst_ratio
        );
    }
}

/// The held position with axis `i` at `position` (SI).
fn along(hold: &[f64], i: usize, position: f64) -> Vec<f64> {
    let mut q = hold.to_vec();
    q[i] = position;
    q
}

/// An axis table's nodes: the residual along the axis' travel direction (a pitch table holds
/// nothing else); `reference`: the position (SI) the table is zero at, whose residual the work
/// offset takes.
fn check_axis_table(
    case: &Case,
    tally: &mut Tally,
    axis: char,
    nodes: &[f64],
    reference: Option<f64>,
    command: impl Fn(&[f64]) -> Vec<f64>,
    resolution_um: f64,
) {
    let m = case.id.model.machine();
    let i = m.axis_index(axis).unwrap();
    let hold = &case.settings.hold_q;
    let d = case.nominal_jacobian(hold).column(i).normalize();
    let at_reference = reference.map(|r| {
        let q = along(hold, i, r);
        (q.clone(), case.residual_um(&q, &command(&q)))
    });
    for p in case.reachable(i, &nodes.iter().map(|p| p * 1e3).collect::<Vec<_>>()) {
        let q = along(hold, i, p);
        let mut r = case.residual_um(&q, &command(&q));
        let mut before = case.uncompensated_um(&q);
        if let Some((q_ref, r_ref)) = &at_reference {
            r -= r_ref;
            before -= case.uncompensated_um(q_ref);
        }
        let reference = at_reference.as_ref().map(|(q, _)| q.as_slice());
        let u95 = case.id.u95_um(&q, reference, &[d], &|_| true)[0];
        tally.add(r.dot(&d), before.dot(&d), u95, resolution_um);
    }
}

/// Three machines, each with its own truth and noise: the residuals pooled per file.
#[test]
fn each_controls_file_from_an_identification_cancels_the_error_to_its_uncertainty() {
    pooled_check([37, 38, 39].map(|seed| tallies(&case(seed))));
}

/// Each file's tallies over several machines pooled, printed, then checked.
fn pooled_check(per_machine: impl IntoIterator<Item = Vec<(&'static str, Tally)>>) {
    let mut pooled: Vec<(&'static str, Tally)> = Vec::new();
    for (name, t) in per_machine.into_iter().flatten() {
        match pooled.iter_mut().find(|(n, _)| *n == name) {
            Some((_, p)) => p.merge(&t),
            None => pooled.push((name, t)),
        }
    }
    for (name, t) in &pooled {
        t.print(name);
    }
    for (name, t) in &pooled {
        t.check(name);
    }
}

/// The files that hold only where a table-table machine's rotary axis lines pass (LinuxCNC's
/// trt kinematics) or also how they tilt (CYCLE800's `$TC_CARR`), on the trunnion: the control
/// keeps the rotary axes where the program puts them and moves X, Y, Z so that its kinematics
/// put the tool on the target. What the file does not hold stays: the residual less the effect
/// the truth's other errors have at the node lies within the u95 of what the file holds.
#[test]
fn the_rotary_axis_lines_in_a_controls_kinematics_cancel_to_their_uncertainty() {
    pooled_check(
        [41, 42]
            .map(|seed| rotary_tallies(&trunnion_case(seed, false), &trunnion_case(seed, true))),
    );
}

/// The rotary location errors of `model` other than along the axis' own direction; with
/// `tilts`, the turns of the lines too.
fn rotary_line(model: &MachineModel, role: &Role, tilts: bool) -> bool {
    match *role {
        Role::Location { axis, direction } => {
            let a = &model.machine().axes()[axis];
            a.kind() == AxisKind::Rotary
                && direction.cartesian() != a.own_cartesian()
                && (tilts || !direction.is_rotation())
        }
        _ => false,
    }
}

/// LinuxCNC's pivots on a machine whose rotary lines are not tilted (`level`), `$TC_CARR` on
/// one whose lines are (`tilted`).
fn rotary_tallies(level: &Case, tilted: &Case) -> Vec<(&'static str, Tally)> {
    let mut out = Vec::new();
    for (case, name, tilts) in [
        (level, "linuxcnc-trt", false),
        (tilted, "siemens-carr", true),
    ] {
        out.push((name, rotary_tally(case, tilts)));
    }
    out
}

/// A control's kinematics: the tool point (mm from the origin) at linear axes `lin` (mm), the
/// rotary axes of node `q`.
type Forward = dyn Fn(&[f64], Vector3<f64>) -> Vector3<f64>;

/// The residuals of LinuxCNC's pivots (`tilts` false) or of `$TC_CARR` (true) on `case`.
fn rotary_tally(case: &Case, tilts: bool) -> Tally {
    let model = &case.id.model;
    let m = model.machine();
    let idx = |l: char| m.axis_index(l).unwrap();
    let (x, y, z, a, c) = (idx('X'), idx('Y'), idx('Z'), idx('A'), idx('C'));
    let zero = vec![0.0; m.n_axes()];
    let origin = m.tool_in_workpiece(&zero).t;
    // Nodes: the cradle at −30°, 0°, 30°, the table at every 90°, the tool at the held position
    // and 60 mm off it.
    let mut nodes = Vec::new();
    let hold = &case.settings.hold_q;
    for a_deg in [-30.0f64, 0.0, 30.0] {
        for c_deg in [0.0f64, 90.0, 180.0, 270.0] {
            for off in [[0.0, 0.0, 0.0], [0.06, -0.06, -0.06]] {
                let mut q = hold.clone();
                q[x] += off[0];
                q[y] += off[1];
                q[z] += off[2];
                q[a] = a_deg.to_radians();
                q[c] = c_deg.to_radians();
                nodes.push(q);
            }
        }
    }
    // The X, Y, Z command (SI) at which `forward` (linear axes in mm → the tool point in mm
    // from the origin) reaches node `q`'s nominal tool point; the rotary axes as programmed.
    let solve = |q: &[f64], forward: &dyn Fn(Vector3<f64>) -> Vector3<f64>| {
        let target = (case.nominal(q) - origin) * 1e3;
        let mut lin = Vector3::new(q[x], q[y], q[z]) * 1e3;
        for _ in 0..4 {
            let f0 = forward(lin);
            let mut j = Matrix3::zeros();
            for k in 0..3 {
                let mut d = lin;
                d[k] += 1.0;
                j.set_column(k, &(forward(d) - f0));
            }
            lin -= j.try_inverse().unwrap() * (f0 - target);
        }
        let mut cmd = q.to_vec();
        for (k, &i) in [x, y, z].iter().enumerate() {
            cmd[i] = lin[k] * 1e-3;
        }
        cmd
    };
    // The pivots are where the lines pass as the model has them, tilts included: the u95 is of
    // every rotary line error (the estimated tilts are near zero on a level machine).
    let kept = |role: &Role| rotary_line(model, role, true);
    let given = model
        .errors()
        .params()
        .iter()
        .filter(|p| kept(&p.role) && case.id.x_index[p.offset].is_some())
        .all(|p| !case.not_given.contains(&p.name.to_string()));
    assert!(
        given,
        "the session determines the rotary lines: {:?}",
        case.not_given
    );
    // The truth without what the file holds: where the rotary lines pass and how they tilt.
    let mut rest = case.truth.clone();
    for ax in m.axes().iter().filter(|a| a.kind() == AxisKind::Rotary) {
        let own = ax.own_cartesian();
        let j = case.sim.index(ax.letter().as_char()).unwrap();
        for d in (0..6).filter(|d| d % 3 != own) {
            rest.axes[j].location[d] = 0.0;
        }
    }
    let forward: Box<Forward> = if tilts {
        let path = case.write(Compensation::SiemensCarr, "carr.mpf");
        let rec = carr_control::record_of(&std::fs::read_to_string(&path).unwrap());
        let rot = rec.axes.clone().map(|l| idx(l.chars().next().unwrap()));
        Box::new(move |q, lin| {
            rec.apply(lin, [q[rot[0]].to_degrees(), q[rot[1]].to_degrees()])
                .0
        })
    } else {
        let path = case.write(Compensation::TrtPivots, "pivots.hal");
        let p = trt_control::pivots_of_hal(&std::fs::read_to_string(&path).unwrap());
        // LinuxCNC turns the rotary axes the other way from mtcal (ISO 841).
        Box::new(move |q, lin| {
            let (ra, rc) = (-q[a].to_degrees(), -q[c].to_degrees());
            trt_control::xyzac_forward(&p, [lin.x, lin.y, lin.z, ra, rc])
        })
    };
    let mut tally = Tally::default();
    for q in &nodes {
        let cmd = solve(q, &|lin| forward(q, lin));
        let others = (translation_of(&case.sim.tool_in_workpiece(&case.sim_q(q), Some(&rest)))
            - case.nominal(q))
            * 1e6;
        let r = case.residual_um(q, &cmd) - others;
        let before = case.uncompensated_um(q) - others;
        let u95 = case.id.u95_um(q, None, &XYZ, &kept);
        for k in 0..3 {
            tally.add(r[k], before[k], u95[k], 0.001);
        }
    }
    tally
}

/// Each file made, read back and applied: its residuals against their u95.
fn tallies(case: &Case) -> Vec<(&'static str, Tally)> {
    let mut out = Vec::new();
    let m = case.id.model.machine();
    let letters = ['X', 'Y', 'Z'];

    // LinuxCNC: a compensation (−error) each axis' command gets.
    let mut tally = Tally::default();
    for axis in letters {
        let what = Compensation::PitchTable {
            axis,
            format: PitchFormat::LinuxCnc,
        };
        let path = case.write(what, &format!("{axis}.comp"));
        let table = read_linuxcnc_comp(&path, axis).unwrap();
        let i = m.axis_index(axis).unwrap();
        let nodes: Vec<f64> = table.positions_mm.iter().map(|p| p * 1e-3).collect();
        let command = |q: &[f64]| {
            let mut c = q.to_vec();
            c[i] += table.correction_at_um(q[i] * 1e3, Travel::Forward) * 1e-6;
            c
        };
        check_axis_table(case, &mut tally, axis, &nodes, None, command, 0.0005);
    }
    out.push(("linuxcnc", tally));

    // Fanuc: the total of the pitch data from the reference position (X, Y, Z numbered 1–3),
    // added to the command; IS-C, one detection unit 0.1 µm.
    let path = case.write(Compensation::Fanuc { axis: None }, "fanuc.txt");
    let axes: Vec<FanucAxis> = (1u32..)
        .zip(letters)
        .map(|(n, a)| FanucAxis::new(a, n, false))
        .collect();
    let tables = read_fanuc_parameters(&path, &case.settings.fanuc, &axes).unwrap();
    let mut tally = Tally::default();
    for t in &tables {
        let i = m.axis_index(t.axis.letter).unwrap();
        let positions = t.positions();
        let total = t.compensation(Travel::Forward);
        let command = |q: &[f64]| {
            let mut c = q.to_vec();
            c[i] += heidenhain_control::interpolate(&positions, &total, q[i] * 1e3) * 1e-3;
            c
        };
        let nodes: Vec<f64> = positions.iter().map(|p| p * 1e-3).collect();
        let reference = t.axis.reference_position * 1e-3;
        check_axis_table(
            case,
            &mut tally,
            t.axis.letter,
            &nodes,
            Some(reference),
            command,
            0.1,
        );
    }
    out.push(("fanuc", tally));

    // SINUMERIK EEC: the axis' error, which the control subtracts; zero at the reference
    // point (the axis' 0).
    let path = case.write(Compensation::SiemensEec { axis: None }, "eec.ini");
    let eec = read_siemens_eec(&path, &case.settings.siemens).unwrap();
    let mut tally = Tally::default();
    for t in &eec {
        let axis = t.axis.chars().next().unwrap();
        let i = m.axis_index(axis).unwrap();
        let command = |q: &[f64]| {
            let mut c = q.to_vec();
            c[i] -= t.value_at(q[i] * 1e3) * 1e-3;
            c
        };
        let nodes: Vec<f64> = t.positions.iter().map(|p| p * 1e-3).collect();
        check_axis_table(case, &mut tally, axis, &nodes, Some(0.0), command, 0.0005);
    }
    out.push(("siemens-eec", tally));

    // SINUMERIK EEC and CEC together: each CEC table's value (the output axis' error along
    // its input axis, zero at the held position) subtracted from the output axis' command as
    // the EEC's; the three lines through the held position, every component, relative to the
    // held position (the EEC tables' constants go to the work offset).
    let cec_path = case.write(Compensation::SiemensCec { input: None }, "cec.ini");
    let cec = read_siemens_cec(&cec_path, &case.settings.siemens).unwrap();
    let letter = |name: &str| m.axis_index(name.chars().next().unwrap()).unwrap();
    let command = |q: &[f64]| {
        let mut c = q.to_vec();
        for t in &eec {
            let i = letter(&t.axis);
            c[i] -= t.value_at(q[i] * 1e3) * 1e-3;
        }
        for t in &cec {
            let (i, o) = (letter(&t.input_axis), letter(&t.output_axis));
            c[o] -= t.value_at(q[i] * 1e3) * 1e-3;
        }
        c
    };
    let hold = &case.settings.hold_q;
    let mut tally = Tally::default();
    for t in &eec {
        let i = letter(&t.axis);
        for p in case.reachable(i, &t.positions) {
            let q = along(hold, i, p);
            let reference = Some((hold.as_slice(), &command(hold)[..]));
            check_point_from(case, &mut tally, &q, &command(&q), reference, 0.0005);
        }
    }
    out.push(("siemens-eec+cec", tally));

    // Heidenhain .COM: every table's columns are errors the control subtracts from the axis
    // they name, at the position of the table's input axis; the three lines through the held
    // position, every component.
    let cma = case.write(Compensation::HeidenhainCom, "CONFIG.CMA");
    let control = heidenhain_control::control_tables(&cma);
    let command = |q: &[f64]| {
        let mut c = q.to_vec();
        for (input, t) in &control {
            let at = q[m.axis_index(*input).unwrap()] * 1e3;
            for (axis, v) in &t.columns {
                c[m.axis_index(*axis).unwrap()] -=
                    heidenhain_control::interpolate(&t.positions_mm, v, at) * 1e-3;
            }
        }
        c
    };
    let mut tally = Tally::default();
    for (input, t) in &control {
        let i = m.axis_index(*input).unwrap();
        for p in case.reachable(i, &t.positions_mm) {
            let q = along(&case.settings.hold_q, i, p);
            check_point(case, &mut tally, &q, &command(&q), 0.05);
        }
    }
    out.push(("heidenhain-com", tally));

    // Controls that model the machine: they command the axes so that their model puts the
    // tool on the target.
    let grid = case.grid();
    for (format, name) in [
        (ParameterFormat::IsgCsv, "isg.csv"),
        (ParameterFormat::Etalon, "etalon.txt"),
    ] {
        let path = case.write(Compensation::Parameters(format), name);
        let params = read_error_parameters(&path, format).unwrap();
        let (control, coeffs) = params.model(m).unwrap();
        let mut ws = control.workspace();
        let mut tally = Tally::default();
        for q in &grid {
            let c = case.command_for(q, |c| {
                control.machine().tool_in_workpiece(c).t
                    + control.pose_error(c, &coeffs, &mut ws).translation
            });
            check_point(case, &mut tally, q, &c, 0.001);
        }
        out.push((name, tally));
    }
    let tab = case.write(Compensation::HeidenhainKinematicsComp, "KINCOMP.TAB");
    let kc = KcControl::read(&tab);
    let mut tally = Tally::default();
    for q in &grid {
        let c = case.command_for(q, |c| {
            let pose = kc.tool_in_table(&case.id.model, c);
            Vector3::new(pose[(0, 3)], pose[(1, 3)], pose[(2, 3)])
        });
        check_point(case, &mut tally, q, &c, 0.001);
    }
    out.push(("heidenhain-kinematicscomp", tally));

    // A grid of tool-point errors over the axis positions: the target moved by minus the
    // error there.
    let path = case.write(Compensation::Grid, "grid.csv");
    let errors = read_grid_csv(&path).unwrap();
    let mut tally = Tally::default();
    let xyz: Vec<usize> = letters.iter().map(|&a| m.axis_index(a).unwrap()).collect();
    for q in &grid {
        let e = errors.error_at_um([q[xyz[0]] * 1e3, q[xyz[1]] * 1e3, q[xyz[2]] * 1e3]);
        let c = case.command_for(q, |c| {
            case.nominal(c) + Vector3::new(e[0], e[1], e[2]) * 1e-6
        });
        check_point(case, &mut tally, q, &c, 0.001);
    }
    out.push(("grid", tally));
    out
}

/// One node, every component of the tool point's residual.
fn check_point(case: &Case, tally: &mut Tally, q: &[f64], c: &[f64], resolution_um: f64) {
    check_point_from(case, tally, q, c, None, resolution_um);
}

/// [`check_point`], relative to the residual at `reference` (pose and command) when a table
/// made zero somewhere leaves a constant shift to the work offset.
fn check_point_from(
    case: &Case,
    tally: &mut Tally,
    q: &[f64],
    c: &[f64],
    reference: Option<(&[f64], &[f64])>,
    resolution_um: f64,
) {
    let mut r = case.residual_um(q, c);
    let mut before = case.uncompensated_um(q);
    if let Some((q_ref, c_ref)) = reference {
        r -= case.residual_um(q_ref, c_ref);
        before -= case.uncompensated_um(q_ref);
    }
    let u95 = case
        .id
        .u95_um(q, reference.map(|(q_ref, _)| q_ref), &XYZ, &|_| true);
    for k in 0..3 {
        tally.add(r[k], before[k], u95[k], resolution_um);
    }
}
