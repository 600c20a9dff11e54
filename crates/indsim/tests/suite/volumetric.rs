//! The volumetric thermal test (docs/VOLUMETRIC.md): its deformation truth against a slow
//! computation of its own, the stream imported as the docs say giving the per-visit session,
//! the spindle's uniform and the drive's non-uniform deformation, and the files as mtcal reads
//! them.

use std::path::Path;

use mtcal_identify::Study;
use mtcal_indsim::{
    AmbientChange, Campaign, Effect, JointKind, Machine, OffBall, Programme, Realism, Side,
    StreamOptions, TemperatureProgramme, Truth, VolumetricLoad, VolumetricMachine, VolumetricSpec,
    VolumetricWritten, shipped_machine, write_volumetric,
};
use mtcal_session::{RunColumns, RunUse, load_session, read_run};
use nalgebra::{Matrix4, Point3, Rotation3, Translation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn truth_of(which: VolumetricMachine, seed: u64) -> Truth {
    let file = match which {
        VolumetricMachine::Trunnion => "mcu630-cafyxz.urdf",
        VolumetricMachine::ThreeAxis => "mcv754-zfyx.urdf",
    };
    let machine = Machine::from_urdf_file(&shipped_machine(file)).unwrap();
    Truth::random(&machine, &mut ChaCha8Rng::seed_from_u64(seed), 1.0)
}

fn write(
    dir: &Path,
    which: VolumetricMachine,
    spec: &VolumetricSpec,
    realism: &Realism,
) -> VolumetricWritten {
    let truth = truth_of(which, 17);
    match which {
        VolumetricMachine::Trunnion => Campaign::volumetric_trunnion(dir, &truth, spec, realism),
        VolumetricMachine::ThreeAxis => Campaign::volumetric_three_axis(dir, &truth, spec, realism),
    }
    .unwrap()
}

/// `x(t)` of the node `τ·ẋ = p(t) − x`, `x(0) = 0`, `p` the steps (0 before the first), by
/// fourth-order Runge–Kutta with steps of at most 1 s, cut at the steps' times.
fn node_rk4(steps: &[(f64, f64)], tau_s: f64, t: f64) -> f64 {
    let level = |s: f64| {
        steps
            .iter()
            .take_while(|b| b.0 <= s)
            .last()
            .map_or(0.0, |b| b.1)
    };
    let mut cuts: Vec<f64> = steps
        .iter()
        .map(|b| b.0)
        .filter(|&b| b > 0.0 && b < t)
        .collect();
    cuts.push(t);
    let (mut x, mut from) = (0.0f64, 0.0f64);
    for to in cuts {
        if to <= from {
            continue;
        }
        let p = level(from);
        let n = (to - from).ceil().max(1.0) as usize;
        let h = (to - from) / n as f64;
        let f = |x: f64| (p - x) / tau_s;
        for _ in 0..n {
            let k1 = f(x);
            let k2 = f(x + 0.5 * h * k1);
            let k3 = f(x + 0.5 * h * k2);
            let k4 = f(x + h * k3);
            x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
        }
        from = to;
    }
    x
}

/// `T(t) − T(0)` of a temperature programme, K, by [`node_rk4`].
fn rise_k(p: &TemperatureProgramme, t: f64) -> f64 {
    p.drift_k_per_h * t / 3600.0
        + p.rises
            .iter()
            .map(|r| match &r.power {
                Programme::Steps(steps) => r.gain * node_rk4(steps, r.tau_s, t),
                Programme::SpindleKrpm => panic!("a spindle-driven node in a drive session"),
            })
            .sum::<f64>()
}

/// The tool pose in the workpiece frame at the commands `q` (SI) and time `t`, by the effects'
/// formulas written out here: the Y scale's strain on the axis, then the branches with the
/// truth's errors, the ambient shift and the head's turn about its line between them.
fn actual_pose(
    machine: &Machine,
    truth: &Truth,
    effects: &[Effect],
    q: &[f64],
    t: f64,
) -> Matrix4<f64> {
    let mut a = q.to_vec();
    let mut shift = Vector3::zeros();
    let mut head = Matrix4::identity();
    for e in effects {
        match e {
            Effect::ThermalScale {
                axis,
                ppm_per_k,
                reference,
                temperature,
                ..
            } => {
                let i = machine.index(*axis).unwrap();
                a[i] += ppm_per_k * 1e-6 * rise_k(temperature, t) * (q[i] - reference);
            }
            Effect::AmbientStep {
                at_s,
                step_k,
                tau_s,
                shift_per_k,
                ..
            } => {
                if t > *at_s {
                    let x = 1.0 - (-(t - at_s) / tau_s).exp();
                    shift += Vector3::from(*shift_per_k) * (step_k * x);
                }
            }
            Effect::HeadRotationX {
                pivot_y,
                pivot_z,
                urad_per_k,
                temperature,
                ..
            } => {
                let theta = urad_per_k * 1e-6 * rise_k(temperature, t);
                let c = Vector3::new(0.0, *pivot_y, *pivot_z);
                head *= Translation3::from(c).to_homogeneous()
                    * Rotation3::from_axis_angle(&Vector3::x_axis(), theta).to_homogeneous()
                    * Translation3::from(-c).to_homogeneous();
            }
            Effect::TemperatureSensor { .. } => {}
            other => panic!("not expected in a drive session: {other:?}"),
        }
    }
    let f_t_w = machine.branch_pose(Side::Workpiece, &a, Some(truth));
    let f_t_t = machine.branch_pose(Side::Tool, &a, Some(truth));
    f_t_w.try_inverse().unwrap() * head * Translation3::from(shift).to_homogeneous() * f_t_t
}

fn si(machine: &Machine, positions: &[f64]) -> Vec<f64> {
    positions
        .iter()
        .zip(&machine.joints)
        .map(|(&v, j)| match j.kind {
            JointKind::Linear => v * 1e-3,
            JointKind::Rotary => v.to_radians(),
        })
        .collect()
}

fn parse_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    (header, rows)
}

#[test]
fn the_deformation_truth_is_what_a_slow_4x4_computation_gives() {
    let tmp = tempfile::tempdir().unwrap();
    let which = VolumetricMachine::Trunnion;
    let mut spec = VolumetricSpec::short(VolumetricLoad::YDrive, 4);
    spec.ambient_step = Some(AmbientChange {
        at_s: 1500.0,
        step_k: -4.0,
    });
    spec.stream = None;
    let realism = Realism::realistic(5);
    let (machine, plan, effects) = Campaign::volumetric_plan(which, &spec, &realism).unwrap();
    let truth = truth_of(which, 17);
    let w = write_volumetric(
        &tmp.path().join("s"),
        &machine,
        &truth,
        &plan,
        &effects,
        &realism,
    )
    .unwrap();
    assert_eq!(w.visits.len(), 4 * 15);
    let offsets = |ball: &str| w.session.offsets.iter().find(|(n, _)| n == ball).unwrap().1;
    let nominal = |ball: &str| {
        let b = plan.balls.iter().find(|b| b.name == ball).unwrap().ball_mm;
        Vector3::new(b[0], b[1], b[2]) * 1e-3
    };
    // Per point: (the reading at its first visit, the nest at its first visit), µm and m.
    let mut first: Vec<(String, Vector3<f64>, Vector3<f64>)> = Vec::new();
    let mut largest = 0.0f64;
    for v in &w.visits {
        let q = si(&machine, &v.positions);
        let pose = actual_pose(&machine, &truth, &effects, &q, v.t);
        let off = offsets(&v.ball);
        let r_wt = pose.fixed_view::<3, 3>(0, 0).into_owned();
        let nest = pose.transform_point(&Point3::new(0.0, 0.0, -off.tool_length));
        let ball = nominal(&v.ball) + off.position;
        let reading = r_wt.transpose() * (ball - nest.coords) * 1e6;
        let (r0, n0) = match first.iter().find(|f| f.0 == v.point) {
            Some(f) => (f.1, f.2),
            None => {
                first.push((v.point.clone(), reading, nest.coords));
                (reading, nest.coords)
            }
        };
        for i in 0..3 {
            assert!(
                (reading[i] - v.clean_um[i]).abs() < 1e-6,
                "{} at {} s: reading {reading} vs {:?}",
                v.point,
                v.t,
                v.clean_um
            );
        }
        let d = -(reading - r0);
        for i in 0..3 {
            assert!(
                (d[i] - v.deformation_um[i]).abs() < 1e-6,
                "{} at {} s: {d} vs {:?}",
                v.point,
                v.t,
                v.deformation_um
            );
        }
        // The definition in words: the tool's displacement relative to the workpiece since the
        // first visit, in machine directions (the nominal table's turn undone). The nest's
        // tilt and the geometric errors' turns make a part in 10⁴ of it.
        let r_fw = machine
            .branch_pose(Side::Workpiece, &q, None)
            .fixed_view::<3, 3>(0, 0)
            .into_owned();
        let moved = r_fw * (nest.coords - n0) * 1e6;
        for i in 0..3 {
            assert!(
                (moved[i] - v.deformation_um[i]).abs() < 0.01,
                "{} at {} s: {moved} vs {:?}",
                v.point,
                v.t,
                v.deformation_um
            );
        }
        largest = largest.max(d.norm());
    }
    // The effects did something worth checking.
    assert!(largest > 5.0, "{largest} µm");

    // truth/deformation.csv says the same.
    let (header, rows) = parse_csv(&w.session.dir.join("truth/deformation.csv"));
    assert_eq!(
        header,
        ["t", "point", "ball", "cycle", "dx_um", "dy_um", "dz_um"]
    );
    assert_eq!(rows.len(), w.visits.len());
    for (row, v) in rows.iter().zip(&w.visits) {
        assert_eq!(row[0].parse::<f64>().unwrap(), v.t);
        assert_eq!((&row[1], &row[2]), (&v.point, &v.ball));
        assert_eq!(row[3].parse::<usize>().unwrap(), v.cycle);
        for i in 0..3 {
            assert_eq!(row[4 + i].parse::<f64>().unwrap(), v.deformation_um[i]);
        }
    }

    // Without the effects, the same truth and noise: no deformation at all.
    let still = write_volumetric(
        &tmp.path().join("still"),
        &machine,
        &truth,
        &plan,
        &[],
        &realism,
    )
    .unwrap();
    for v in still.visits.iter() {
        assert!(v.deformation_um.iter().all(|d| d.abs() < 1e-9), "{v:?}");
    }
    assert!(still.field.iter().all(|f| f.deformation_um == [0.0; 3]));
    assert!(!still.session.dir.join("truth/effects.toml").exists());
}

/// A stream row: time and readings (`None`: off a ball).
struct Row {
    t: f64,
    v: Option<[f64; 3]>,
}

fn read_stream(dir: &Path, range_um: f64) -> Vec<Row> {
    let (header, rows) = parse_csv(&dir.join("stream/stream.csv"));
    assert_eq!(header, ["t", "dx", "dy", "dz"]);
    rows.iter()
        .map(|r| {
            let cells: Vec<Option<f64>> = r[1..].iter().map(|c| c.parse().ok()).collect();
            let on =
                cells.len() == 3 && cells.iter().all(|c| c.is_some_and(|v| v.abs() < range_um));
            Row {
                t: r[0].parse().unwrap(),
                v: on.then(|| [cells[0].unwrap(), cells[1].unwrap(), cells[2].unwrap()]),
            }
        })
        .collect()
}

/// The visits docs/VOLUMETRIC.md's import finds in a stream: stretches on a ball, trimmed to
/// where the readings have settled (within 20 µm of the stretch's median); each one's midpoint
/// and its mean over the middle half.
fn plateaus(rows: &[Row]) -> Vec<(f64, [f64; 3])> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < rows.len() {
        if rows[k].v.is_none() {
            k += 1;
            continue;
        }
        let start = k;
        while k < rows.len() && rows[k].v.is_some() {
            k += 1;
        }
        let stretch = &rows[start..k];
        let median = |c: usize| {
            let mut v: Vec<f64> = stretch.iter().map(|r| r.v.unwrap()[c]).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let m = [median(0), median(1), median(2)];
        let settled = |r: &Row| (0..3).all(|c| (r.v.unwrap()[c] - m[c]).abs() < 20.0);
        let a = stretch.iter().position(settled).unwrap();
        let b = stretch.iter().rposition(settled).unwrap();
        let plateau = &stretch[a..=b];
        let (t0, t1) = (plateau[0].t, plateau[plateau.len() - 1].t);
        let length = t1 - t0;
        let mid: Vec<[f64; 3]> = plateau
            .iter()
            .filter(|r| 4.0 * (r.t - t0) >= length && 4.0 * (t1 - r.t) >= length)
            .map(|r| r.v.unwrap())
            .collect();
        let mean = [0, 1, 2].map(|c| mid.iter().map(|v| v[c]).sum::<f64>() / mid.len() as f64);
        out.push((0.5 * (t0 + t1), mean));
    }
    out
}

/// The axes commanded when each `G4` of the program starts, in the order of `letters`.
fn program_dwells(program: &str, letters: &[char]) -> Vec<Vec<f64>> {
    let mut modal = vec![f64::NAN; letters.len()];
    let mut out = Vec::new();
    for line in program.lines() {
        let code = line.split(['(', ';']).next().unwrap();
        let words: Vec<&str> = code.split_whitespace().collect();
        if words.contains(&"G4") {
            out.push(modal.clone());
            continue;
        }
        for w in words {
            let mut chars = w.chars();
            let letter = chars.next().unwrap();
            if let Some(i) = letters.iter().position(|&l| l == letter) {
                modal[i] = chars.as_str().parse().unwrap();
            }
        }
    }
    out
}

/// Every visit of the session in `dir` as mtcal's reader gives it, in time order: time,
/// axes, readings, context by name.
type ReadVisit = (f64, Vec<f64>, Vec<f64>, Vec<(String, f64)>);

fn session_visits(dir: &Path) -> Vec<ReadVisit> {
    let session = load_session(dir).unwrap();
    let m = Machine::from_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
    let letters: Vec<char> = m.letters().chars().collect();
    let cols = RunColumns {
        axes: &letters,
        readings: &["dx", "dy", "dz"],
        readings_optional: false,
        labels: &[],
    };
    let mut out = Vec::new();
    for run in &session.runs {
        let table = read_run(&run.file, &cols).unwrap();
        for k in 0..table.len() {
            out.push((
                table.t[k],
                table.q_row(k).to_vec(),
                table.reading_row(k).unwrap().to_vec(),
                table
                    .context
                    .iter()
                    .map(|(n, v)| (n.clone(), v[k]))
                    .collect(),
            ));
        }
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

#[test]
fn importing_the_stream_gives_the_per_visit_session() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        (
            VolumetricMachine::Trunnion,
            VolumetricLoad::YDrive,
            StreamOptions::default(),
        ),
        (
            VolumetricMachine::ThreeAxis,
            VolumetricLoad::Spindle,
            StreamOptions {
                off_ball: OffBall::Empty,
                approach_ramps: true,
                ..StreamOptions::default()
            },
        ),
        (
            VolumetricMachine::Trunnion,
            VolumetricLoad::Spindle,
            StreamOptions {
                approach_ramps: true,
                range_um: 1500.0,
                ..StreamOptions::default()
            },
        ),
    ];
    for (n, (which, load, options)) in cases.into_iter().enumerate() {
        let dir = tmp.path().join(format!("s{n}"));
        let mut spec = VolumetricSpec::short(load, 3);
        spec.stream = Some(options.clone());
        spec.ambient_step = Some(AmbientChange {
            at_s: 1000.0,
            step_k: -4.0,
        });
        let w = write(&dir, which, &spec, &Realism::realistic(3 + n as u64));
        let rows = read_stream(&dir, options.range_um);
        assert_eq!(rows.len(), w.stream_rows);
        assert!(rows.windows(2).all(|r| r[1].t > r[0].t), "case {n}");
        // On the balls the stream runs at 500 Hz.
        let on: Vec<f64> = rows
            .windows(2)
            .filter(|r| r[0].v.is_some() && r[1].v.is_some())
            .map(|r| r[1].t - r[0].t)
            .collect();
        assert!(on.iter().all(|dt| (dt - 0.002).abs() < 1e-9), "case {n}");
        let found = plateaus(&rows);
        let visits = session_visits(&dir);
        assert_eq!(found.len(), 3 * 15, "case {n}");
        assert_eq!(visits.len(), found.len(), "case {n}");
        let session = load_session(&dir).unwrap();
        let m = Machine::from_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
        let letters: Vec<char> = m.letters().chars().collect();
        let program = std::fs::read_to_string(dir.join("stream/cycle.nc")).unwrap();
        assert!(program.contains("G90") && program.trim_end().ends_with("M30"));
        let dwells = program_dwells(&program, &letters);
        assert_eq!(dwells.len(), 15);
        let (log_header, log_rows) = parse_csv(&dir.join("stream/log.csv"));
        let log_t: Vec<f64> = log_rows.iter().map(|r| r[0].parse().unwrap()).collect();
        for (k, ((t, mean), (vt, q, reading, context))) in found.iter().zip(&visits).enumerate() {
            assert_eq!(t, vt, "case {n}, visit {k}");
            // The same samples summed in the same order: the same bits.
            assert_eq!(&mean[..], &reading[..], "case {n}, visit {k}");
            // The k-th plateau is the program's (k mod 15)-th dwell.
            let commanded = &dwells[k % 15];
            assert!(
                commanded.iter().zip(q).all(|(a, b)| (a - b).abs() < 1e-9),
                "case {n}, visit {k}: {commanded:?} vs {q:?}"
            );
            // The context is the log interpolated to the visit's time.
            let j = log_t.iter().rposition(|&lt| lt <= *t).unwrap();
            let w = (t - log_t[j]) / (log_t[j + 1] - log_t[j]);
            for (name, value) in context {
                let c = log_header.iter().position(|h| h == name).unwrap();
                let (a, b): (f64, f64) = (
                    log_rows[j][c].parse().unwrap(),
                    log_rows[j + 1][c].parse().unwrap(),
                );
                assert!(
                    (a + w * (b - a) - value).abs() < 1e-9,
                    "case {n}, visit {k}, {name}"
                );
            }
        }
        // Every context column of the runs is in the log, and nothing else.
        let names: Vec<&str> = visits[0].3.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(log_header[1..], names[..], "case {n}");
        // The head's range is the set-ups' when it is not the default.
        let manifest = std::fs::read_to_string(dir.join("session.toml")).unwrap();
        assert_eq!(
            manifest.contains("range_um = 1500.0"),
            options.range_um == 1500.0,
            "case {n}"
        );
    }
}

#[test]
fn the_per_visit_session_is_the_same_whatever_the_stream_shows() {
    let tmp = tempfile::tempdir().unwrap();
    let variants = [
        None,
        Some(StreamOptions::default()),
        Some(StreamOptions {
            off_ball: OffBall::Empty,
            approach_ramps: true,
            off_ball_interval_s: 0.5,
            ..StreamOptions::default()
        }),
    ];
    let mut texts: Vec<Vec<(String, String)>> = Vec::new();
    for (n, stream) in variants.into_iter().enumerate() {
        let dir = tmp.path().join(format!("s{n}"));
        let mut spec = VolumetricSpec::short(VolumetricLoad::YDrive, 2);
        let with_stream = stream.is_some();
        spec.stream = stream;
        write(
            &dir,
            VolumetricMachine::ThreeAxis,
            &spec,
            &Realism::realistic(9),
        );
        assert_eq!(dir.join("stream").exists(), with_stream);
        let mut files: Vec<(String, String)> = Vec::new();
        for sub in ["", "truth"] {
            for e in std::fs::read_dir(dir.join(sub)).unwrap() {
                let p = e.unwrap().path();
                if p.is_file() {
                    let name = p.strip_prefix(&dir).unwrap().display().to_string();
                    files.push((name, std::fs::read_to_string(&p).unwrap()));
                }
            }
        }
        files.sort();
        texts.push(files);
    }
    assert!(texts[0].len() > 30);
    assert_eq!(texts[0], texts[1]);
    assert_eq!(texts[0], texts[2]);
}

#[test]
fn spindle_heat_deforms_uniformly_and_drive_heat_does_not() {
    let tmp = tempfile::tempdir().unwrap();
    for which in [VolumetricMachine::Trunnion, VolumetricMachine::ThreeAxis] {
        // Per load: the largest spread between points at one instant (max − min over the 15
        // points, any axis) and the largest mean deformation, µm.
        let mut seen = Vec::new();
        for load in [VolumetricLoad::Spindle, VolumetricLoad::YDrive] {
            let mut spec = VolumetricSpec::short(load, 12);
            spec.stream = None;
            let dir = tmp.path().join(format!("{which:?}-{load:?}"));
            let w = write(&dir, which, &spec, &Realism::realistic(4));
            // truth/field.csv is the field the campaign returns.
            let (_, rows) = parse_csv(&dir.join("truth/field.csv"));
            assert_eq!(rows.len(), 12 * 15);
            for (row, f) in rows.iter().zip(&w.field) {
                assert_eq!(row[0].parse::<f64>().unwrap(), f.t);
                assert_eq!(row[1], f.point);
                for i in 0..3 {
                    assert_eq!(row[4 + i].parse::<f64>().unwrap(), f.deformation_um[i]);
                }
            }
            let (mut spread, mut mean) = (0.0f64, 0.0f64);
            for cycle in w.field.chunks(15) {
                for i in 0..3 {
                    let v: Vec<f64> = cycle.iter().map(|f| f.deformation_um[i]).collect();
                    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    spread = spread.max(hi - lo);
                    mean = mean.max((v.iter().sum::<f64>() / 15.0).abs());
                }
            }
            seen.push((load, spread, mean));
        }
        let (_, spindle_spread, spindle_mean) = seen[0];
        let (_, drive_spread, drive_mean) = seen[1];
        // Spindle heat: tens of µm, the same at every point but for the Z screw's share.
        assert!(spindle_mean > 40.0, "{which:?}: {seen:?}");
        assert!(spindle_spread < 0.05 * spindle_mean, "{which:?}: {seen:?}");
        // Drive heat: smaller, but differing between points by several µm.
        assert!(drive_mean > 5.0, "{which:?}: {seen:?}");
        assert!(drive_spread > 5.0, "{which:?}: {seen:?}");
        assert!(drive_spread > 0.2 * drive_mean, "{which:?}: {seen:?}");
    }
}

#[test]
fn the_volumetric_sessions_load_in_mtcal() {
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        (
            VolumetricMachine::Trunnion,
            VolumetricLoad::YDrive,
            true,
            vec!["T_ambient", "T_ydrive"],
        ),
        (
            VolumetricMachine::ThreeAxis,
            VolumetricLoad::Spindle,
            false,
            vec!["T_ambient", "S", "T_spindle", "T_znut"],
        ),
    ];
    for (which, load, step, columns) in cases {
        let dir = tmp.path().join(format!("{which:?}"));
        let mut spec = VolumetricSpec::short(load, 3);
        spec.stream = None;
        if step {
            spec.ambient_step = Some(AmbientChange {
                at_s: 1200.0,
                step_k: -4.0,
            });
        }
        let w = write(&dir, which, &spec, &Realism::realistic(8));
        let study = Study::load(&dir).unwrap_or_else(|e| panic!("{which:?}: {e}"));
        let balls = match which {
            VolumetricMachine::Trunnion => 5,
            VolumetricMachine::ThreeAxis => 15,
        };
        let mut want: Vec<String> = (1..=balls).map(|b| format!("ball{b}")).collect();
        want.extend((1..=balls).map(|b| format!("ball{b}-c3")));
        let names: Vec<&str> = study.session.runs.iter().map(|r| r.name.as_str()).collect();
        assert_eq!(names, want);
        let validate: Vec<&str> = study
            .session
            .runs
            .iter()
            .filter(|r| r.use_ == RunUse::Validate)
            .map(|r| r.name.as_str())
            .collect();
        assert_eq!(validate, want[balls..]);
        // One row per visit: a trunnion's ball at three table positions per cycle.
        let per_cycle = 15 / balls;
        for run in &w.session.runs {
            let cycles = if run.name.contains("-c") { 1 } else { 2 };
            assert_eq!(run.t.len(), per_cycle * cycles, "{}", run.name);
            let names: Vec<&str> = run.context.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(names, columns, "{}", run.name);
        }
        let planted: toml::Table = std::fs::read_to_string(dir.join("truth/effects.toml"))
            .unwrap()
            .parse()
            .unwrap();
        let kinds: Vec<&str> = planted["effect"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["kind"].as_str().unwrap())
            .collect();
        let want_kinds: &[&str] = match (load, step) {
            (VolumetricLoad::YDrive, true) => &["ambient-step", "thermal-scale", "head-rotation-x"],
            _ => &[
                "temperature-sensor",
                "spindle-speed",
                "thermal",
                "temperature-sensor",
                "thermal-scale",
            ],
        };
        assert_eq!(kinds, want_kinds);
        let schedule: toml::Table = std::fs::read_to_string(dir.join("truth/volumetric.toml"))
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(schedule["point"].as_array().unwrap().len(), 15);
        assert_eq!(schedule["validate_cycle"].as_integer(), Some(3));
    }
}

#[test]
fn the_default_course_is_source_000s() {
    for which in [VolumetricMachine::Trunnion, VolumetricMachine::ThreeAxis] {
        let spec = VolumetricSpec::new(VolumetricLoad::YDrive);
        let realism = Realism::realistic(1);
        let (machine, plan, _) = Campaign::volumetric_plan(which, &spec, &realism).unwrap();
        let s = plan.schedule(&machine, &realism).unwrap();
        // ≥ 30 cycles of 15 visits, each cycle 4–5 min, 10 min between them.
        assert!(plan.cycles >= 30 && plan.points.len() == 15);
        assert!(
            s.cycle_s > 240.0 && s.cycle_s < 300.0,
            "{which:?}: {}",
            s.cycle_s
        );
        for (k, &(from, to)) in s.between_s.iter().enumerate() {
            assert_eq!(to - from, 600.0);
            assert!(from > s.cycle_start_s[k] + s.cycle_s);
            assert_eq!(to, s.cycle_start_s[k + 1]);
        }
        assert_eq!(s.cycle_start_s.len(), 36);
    }
}

#[test]
fn the_program_puts_the_nominal_tool_point_on_each_ball() {
    let tmp = tempfile::tempdir().unwrap();
    for which in [VolumetricMachine::Trunnion, VolumetricMachine::ThreeAxis] {
        let dir = tmp.path().join(format!("{which:?}"));
        let mut spec = VolumetricSpec::short(VolumetricLoad::Spindle, 1);
        spec.dwell_s = 0.2;
        let w = write(&dir, which, &spec, &Realism::realistic(2));
        let session = load_session(&dir).unwrap();
        let m = Machine::from_urdf_file(session.machine_path.as_ref().unwrap()).unwrap();
        let letters: Vec<char> = m.letters().chars().collect();
        let program = std::fs::read_to_string(dir.join("stream/cycle.nc")).unwrap();
        let dwells = program_dwells(&program, &letters);
        assert_eq!(dwells.len(), 15);
        for (q, v) in dwells.iter().zip(&w.visits) {
            let ball = session.setups[&v.ball]["ball"].as_array().unwrap();
            let ball: Vec<f64> = ball.iter().map(|x| x.as_float().unwrap()).collect();
            let pose = m.tool_in_workpiece(&si(&m, q), None);
            let at = pose.fixed_view::<3, 1>(0, 3).into_owned() * 1e3;
            for c in 0..3 {
                // The positions as the controller writes them: 0.1 µm.
                assert!(
                    (at[c] - ball[c]).abs() < 2e-4,
                    "{which:?} {}: {at}",
                    v.point
                );
            }
        }
    }
}

#[test]
fn bad_volumetric_plans_are_refused_and_nothing_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let base = VolumetricSpec::short(VolumetricLoad::YDrive, 3);
    let cases = [
        (
            VolumetricSpec {
                dwell_s: 1.001,
                ..base.clone()
            },
            "dwell_s = 1.001 s: a whole number of 8 ms expected",
        ),
        (
            VolumetricSpec {
                validate_cycle: Some(4),
                ..base.clone()
            },
            "validate_cycle = 4",
        ),
        (
            VolumetricSpec {
                load_s: 605.0,
                ..base.clone()
            },
            "load_s = 605: a whole number of log intervals",
        ),
        (
            VolumetricSpec {
                cycles: 0,
                validate_cycle: None,
                ..base.clone()
            },
            "one cycle or more",
        ),
    ];
    for (n, (spec, want)) in cases.into_iter().enumerate() {
        let dir = tmp.path().join(format!("s{n}"));
        let truth = truth_of(VolumetricMachine::ThreeAxis, 1);
        let err = Campaign::volumetric_three_axis(&dir, &truth, &spec, &Realism::ideal())
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{err:?} lacks {want:?}");
        assert!(!dir.exists());
    }
}
