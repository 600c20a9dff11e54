//! Real data: a four-axis positioning table measured point by point in an unknown instrument's
//! frame (`../shared/data/sscanss2-positioner`, from SScanSS-2, BSD 3-Clause; read at test time,
//! never copied). The stages, from the base: Z, a rotary stage, Y, X; a target on the X stage;
//! each axis swept alone (11 points each, the others at home).
//!
//! **As a session.** The stages form the tool branch of the machine (the target is its tool
//! point) and the instrument is fixed to the base (the workpiece frame). A measured point is the
//! target's position less the instrument's origin, along the instrument's axes: what an R-test
//! nest fixed on the table reads of a ball on the tool point (`mount = "ball-in-spindle"`), with
//! a range as wide as the strokes. Where the instrument's origin is (the nest's `ball_*`) and how
//! it is turned (the workpiece pose `WP_DA`, `WP_DB`, `WP_DC`) are fitted with the machine.
//!
//! **The nominal machine** (no drawing is published): the stages along the instrument's axes as
//! the sweeps show them (Z along z, Y along y, X along x); the rotary stage turns the target
//! clockwise seen from +z for a positive command (the data say so: a nominal axis −z), its line
//! where the circle fitted to its sweep has its centre (circle point analysis,
//! `mtcal_artefact::rotary_axis`). Its location errors are then what the model finds beyond
//! that first estimate, its tilts (`EA0C`, `EB0C`) what the circle's plane says.
//!
//! **The model, named** (`[identify] parameters`: the default choice weighs parameters
//! against a machine tool's plausible ranges, ±1 mm or mrad, and this table's squareness is
//! near a milliradian): the three squareness errors, the rotary line (position and tilt), the
//! linear axes' positioning and straightness as cubic Legendre polynomials, the rotary
//! positioning's first harmonic and the instrument's pose. Angular errors of the linear axes are
//! left out: with one target they act as straightness.
//!
//! **Checked against an independent formulation** (straight lines fitted to each sweep, no
//! model): the squareness errors are the angles between the fitted lines less 90° with ISO
//! 230-1's signs (a positive `EC0Y` opens the X–Y angle; `EB0Z` and `EA0Z` turn Z about Y and
//! X), and each linear axis' scale is its line's length per commanded millimetre; mtcal's
//! values lie within their 95 % intervals of those. **What the residuals show**: the model
//! does not explain the recordings (mtcal says so first), most of the misfit in the Y sweep,
//! whose positioning waves by about ±50 µm about a cubic; and the rotary sweep's −180° and
//! +180° (one physical angle) lie 0.095 mm apart (closure).

use mtcal_artefact::rotary_axis;
use mtcal_identify::pipeline::{PipelineOptions, Prepared};
use nalgebra::{DMatrix, DVector, Vector3};
use std::path::Path;

/// One measured point: joint (1 Z, 2 rotary, 3 Y, 4 X), the target (mm, instrument frame), the
/// commanded position (mm or degrees).
struct Point {
    joint: usize,
    p_mm: Vector3<f64>,
    q: f64,
}

fn points(file: &Path) -> Vec<Point> {
    std::fs::read_to_string(file)
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            let n = |k: usize| f[k].trim().parse::<f64>().unwrap();
            Point {
                joint: n(0) as usize,
                p_mm: Vector3::new(n(1), n(2), n(3)),
                q: n(4),
            }
        })
        .collect()
}

/// The sweep of `joint`.
fn sweep(all: &[Point], joint: usize) -> Vec<&Point> {
    all.iter().filter(|p| p.joint == joint).collect()
}

/// The straight line fitted to a linear sweep: position = a + b·q (least squares per
/// coordinate), `b` in mm per commanded mm.
fn line(points: &[&Point]) -> Vector3<f64> {
    let n = points.len() as f64;
    let qm = points.iter().map(|p| p.q).sum::<f64>() / n;
    let pm = points.iter().map(|p| p.p_mm).sum::<Vector3<f64>>() / n;
    let sqq: f64 = points.iter().map(|p| (p.q - qm).powi(2)).sum();
    points
        .iter()
        .map(|p| (p.p_mm - pm) * (p.q - qm))
        .sum::<Vector3<f64>>()
        / sqq
}

/// The coordinate along the sweep's line (`direction`), mm, as cubic Legendre coefficients over
/// the stroke `(lo, hi)` (commanded mm), by least squares: P0 … P3 in mm.
fn legendre_along(points: &[&Point], direction: &Vector3<f64>, (lo, hi): (f64, f64)) -> [f64; 4] {
    let u = direction.normalize();
    let n = points.len();
    let basis = |q: f64| {
        let x = (2.0 * q - lo - hi) / (hi - lo);
        [
            1.0,
            x,
            (3.0 * x * x - 1.0) / 2.0,
            (5.0 * x * x * x - 3.0 * x) / 2.0,
        ]
    };
    let a = DMatrix::from_fn(n, 4, |r, k| basis(points[r].q)[k]);
    let b = DVector::from_fn(n, |r, _| points[r].p_mm.dot(&u));
    let c = a.svd(true, true).solve(&b, 1e-12).unwrap();
    [c[0], c[1], c[2], c[3]]
}

/// The positioner's URDF: the rotary line through `centre_mm` (x, y).
fn urdf(centre_mm: [f64; 2]) -> String {
    let (cx, cy) = (centre_mm[0] * 1e-3, centre_mm[1] * 1e-3);
    let joint = |name: &str,
                 kind: &str,
                 xyz: String,
                 parent: &str,
                 child: &str,
                 axis: &str,
                 lim: (f64, f64)| {
        format!(
            "  <link name=\"{child}\"/>\n  <joint name=\"{name}\" type=\"{kind}\"><origin xyz=\"{xyz}\" rpy=\"0 0 0\"/>\
             <parent link=\"{parent}\"/><child link=\"{child}\"/><axis xyz=\"{axis}\"/>\
             <limit lower=\"{}\" upper=\"{}\" effort=\"1\" velocity=\"1\"/></joint>\n",
            lim.0, lim.1
        )
    };
    let pi = std::f64::consts::PI + 1e-6;
    format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"sscanss2-positioner\">\n  <link name=\"frame\"/>\n\
         <link name=\"workpiece\"/>\n  <joint name=\"instrument\" type=\"fixed\"><origin xyz=\"0 0 0\" \
         rpy=\"0 0 0\"/><parent link=\"frame\"/><child link=\"workpiece\"/></joint>\n{}{}{}{}\
         <link name=\"tool\"/>\n  <joint name=\"target\" type=\"fixed\"><origin xyz=\"0 0 0\" \
         rpy=\"0 0 0\"/><parent link=\"x_stage\"/><child link=\"tool\"/></joint>\n</robot>\n",
        joint(
            "Z",
            "prismatic",
            "0 0 0".into(),
            "frame",
            "z_stage",
            "0 0 1",
            (0.0, 0.5)
        ),
        joint(
            "C",
            "revolute",
            format!("{cx} {cy} 0"),
            "z_stage",
            "c_stage",
            "0 0 -1",
            (-pi, pi)
        ),
        joint(
            "Y",
            "prismatic",
            format!("{} {} 0", -cx, -cy),
            "c_stage",
            "y_stage",
            "0 1 0",
            (-0.2, 0.2)
        ),
        joint(
            "X",
            "prismatic",
            "0 0 0".into(),
            "y_stage",
            "x_stage",
            "1 0 0",
            (-0.2, 0.2)
        ),
    )
}

/// Writes the session: the machine, its model, one run per sweep.
fn write_session(dir: &Path, all: &[Point], centre_mm: [f64; 2]) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("machine.urdf"), urdf(centre_mm)).unwrap();
    std::fs::write(
        dir.join("machine.errors.toml"),
        "components = [\"EXX\", \"EYX\", \"EZX\", \"EYY\", \"EXY\", \"EZY\", \"EZZ\", \"EXZ\", \
         \"EYZ\", \"ECC\"]\nlocations = \"iso\"\nsetup = [\"WP_DA\", \"WP_DB\", \"WP_DC\"]\n\n\
         [basis.linear]\nkind = \"legendre\"\ndegree = 3\n\n[basis.rotary]\nkind = \"fourier\"\n\
         harmonics = 1\n",
    )
    .unwrap();
    // σ 10 µm: the instrument is not named (a laser tracker at these distances reads to about
    // that); the fit's noise account says what the residuals show.
    let mut manifest = String::from(
        "machine = \"machine.urdf\"\n\n[setup.instrument]\nmount = \"ball-in-spindle\"\n\
         ball = [0.0, 0.0, 0.0]\nrange_um = 600000.0\nsigma_um = 10.0\ntool_length_free = false\n",
    );
    for (joint, name, axis) in [
        (1, "z-sweep", 0),
        (2, "c-sweep", 1),
        (3, "y-sweep", 2),
        (4, "x-sweep", 3),
    ] {
        let mut csv = String::from("t,Z,C,Y,X,dx,dy,dz\n");
        for (k, p) in sweep(all, joint).iter().enumerate() {
            let mut q = [0.0; 4];
            q[axis] = p.q;
            let d = p.p_mm * 1e3;
            csv.push_str(&format!(
                "{},{},{},{},{},{},{},{}\n",
                10 * k,
                q[0],
                q[1],
                q[2],
                q[3],
                d.x,
                d.y,
                d.z
            ));
        }
        std::fs::write(dir.join(format!("{name}.csv")), csv).unwrap();
        manifest.push_str(&format!(
            "\n[[run]]\nname = \"{name}\"\ninstrument = \"rtest\"\nfile = \"{name}.csv\"\n\
             use = \"fit\"\nsetup = \"instrument\"\n"
        ));
    }
    manifest.push_str(
        "\n[identify]\nparameters = [\"EC0Y\", \"EB0Z\", \"EA0Z\", \"EX0C\", \"EY0C\", \"EA0C\", \
         \"EB0C\", \"EXX\", \"EYY\", \"EZZ\", \"EYX\", \"EZX\", \"EXY\", \"EZY\", \"EXZ\", \"EYZ\", \
         \"ECC\", \"WP_DA\", \"WP_DB\", \"WP_DC\"]\n",
    );
    std::fs::write(dir.join("session.toml"), manifest).unwrap();
}

#[test]
fn the_positioners_squareness_and_scales_match_straight_lines_through_its_sweeps() {
    let Some(data) = mtcal_testkit::shared_data("sscanss2-positioner") else {
        eprintln!("../shared/data/sscanss2-positioner not found: skipped outside CI");
        return;
    };
    let all = points(&data.join("table.txt"));
    assert_eq!(all.len(), 44, "11 points per sweep");
    // The rotary sweep without its repeated +180° (the same angle as −180°).
    let rotary: Vec<Vector3<f64>> = sweep(&all, 2)
        .iter()
        .filter(|p| p.q < 180.0)
        .map(|p| p.p_mm)
        .collect();
    let circle = rotary_axis::fit_circle(&rotary).unwrap();
    let ends: Vec<&Point> = sweep(&all, 2)
        .into_iter()
        .filter(|p| p.q.abs() == 180.0)
        .collect();
    let closure_mm = (ends[0].p_mm - ends[1].p_mm).norm();

    let tmp = tempfile::tempdir().unwrap();
    // `KEEP=dir` keeps the session (as `dir/positioner`) to look at with `mtcal`.
    let dir = match std::env::var("KEEP") {
        Ok(keep) => Path::new(&keep).join("positioner"),
        Err(_) => tmp.path().join("session"),
    };
    write_session(&dir, &all, [circle.centre.x, circle.centre.y]);
    let prepared = Prepared::load(&dir, PipelineOptions::default()).unwrap();
    let outcome = prepared.run(&mut mtcal_solve::Silent).unwrap();
    let id = &outcome.identification;
    let value = |name: &str| {
        let p = id
            .parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap_or_else(|| panic!("{name} has no value"));
        (p.value, p.u95)
    };

    // The independent formulation: a straight line through each linear sweep.
    let (x, y, z) = (
        line(&sweep(&all, 4)),
        line(&sweep(&all, 3)),
        line(&sweep(&all, 1)),
    );
    let angle_urad = |a: &Vector3<f64>, b: &Vector3<f64>| {
        (a.normalize().dot(&b.normalize())).acos() * 1e6 - std::f64::consts::FRAC_PI_2 * 1e6
    };
    let lines = [
        ("EC0Y", angle_urad(&x, &y)),
        ("EB0Z", -angle_urad(&x, &z)),
        ("EA0Z", angle_urad(&y, &z)),
    ];
    // A scale is the P1 coefficient of the coordinate along the line, as the model expands
    // positioning (cubic Legendre over the stroke): µm over half the stroke, or ppm.
    let scales = [
        (
            "EXX.P1",
            legendre_along(&sweep(&all, 4), &x, (-200.0, 200.0))[1],
            200.0,
        ),
        (
            "EYY.P1",
            legendre_along(&sweep(&all, 3), &y, (-200.0, 200.0))[1],
            200.0,
        ),
        (
            "EZZ.P1",
            legendre_along(&sweep(&all, 1), &z, (0.0, 500.0))[1],
            250.0,
        ),
    ];
    let mut report = vec![format!(
        "fit: rms {:.1} µm, χ²/dof {:.2}; verdict: {}",
        id.fit.rms_um,
        id.fit.chi2_reduced,
        id.verdict().unwrap_or_else(|| "none".into())
    )];
    for (name, from_lines) in lines {
        let (v, u) = value(name);
        report.push(format!(
            "{name} {v:+.1} ± {u:.1} µrad; lines {from_lines:+.1} µrad"
        ));
    }
    for (name, p1_mm, half_mm) in scales {
        let (v, u) = value(name);
        let ppm = |um: f64| um / half_mm * 1e3;
        report.push(format!(
            "{name}: scale {:+.0} ± {:.0} ppm; line {:+.0} ppm",
            ppm(v),
            ppm(u),
            ppm((p1_mm - half_mm) * 1e3)
        ));
    }
    for name in ["EX0C", "EY0C", "EA0C", "EB0C"] {
        let (v, u) = value(name);
        report.push(format!("{name} {v:+.1} ± {u:.1}"));
    }
    report.push(format!(
        "rotary sweep: circle radius {:.3} mm, plane tilt from z {:.0} µrad; closure of ±180°: \
         {closure_mm:.3} mm",
        circle.radius,
        circle.normal.z.abs().acos() * 1e6
    ));
    for r in &id.fit.runs {
        report.push(format!("{}: rms {:.1} µm", r.name, r.rms_um));
    }
    eprintln!("{}", report.join("\n"));

    assert!(outcome.solution.converged, "the fit converges");
    for (name, from_lines) in lines {
        let (v, u) = value(name);
        assert!(
            (v - from_lines).abs() <= u,
            "{name}: {v} ± {u} µrad, the lines say {from_lines}"
        );
        assert!(u < 100.0, "{name} determined: ± {u} µrad");
    }
    for (name, p1_mm, half_mm) in scales {
        let (v, u) = value(name);
        let line_um = (p1_mm - half_mm) * 1e3;
        assert!(
            (v - line_um).abs() <= u,
            "{name}: {v} ± {u} µm over half the stroke, the line says {line_um}"
        );
    }
    // What the residuals show, said first: the model does not explain, most of it in the Y
    // sweep (its positioning waves about the cubic).
    assert!(id.fit.chi2_reduced > 2.0, "χ²/dof {}", id.fit.chi2_reduced);
    let verdict = id.verdict().unwrap_or_default();
    assert!(
        verdict.starts_with("THE MODEL DOES NOT EXPLAIN") && verdict.contains("run `y-sweep`"),
        "{verdict}"
    );
    assert!(
        (closure_mm - 0.095).abs() < 0.005,
        "closure {closure_mm} mm"
    );
    // The physics search has no candidate for the Y sweep's waves (eleven points: too sparse
    // for a cycle or a bump) and weighs the runs by the noise their residuals show, 2 × the
    // stated σ and more: it claims nothing, and still says first that at the stated σ the
    // model does not explain the recordings, and where.
    let options = PipelineOptions {
        search: true,
        ..Default::default()
    };
    let searched = Prepared::load(&dir, options)
        .unwrap()
        .run(&mut mtcal_solve::Silent)
        .unwrap();
    let findings = &searched.search.as_ref().expect("the search ran").findings;
    assert!(findings.discoveries.is_empty(), "{}", findings.summary());
    let verdict = searched.identification.verdict().unwrap_or_default();
    assert!(
        verdict.starts_with("THE MODEL DOES NOT EXPLAIN THE RECORDINGS AT THE NOISE")
            && verdict.contains("run `y-sweep`"),
        "{verdict}"
    );
}
