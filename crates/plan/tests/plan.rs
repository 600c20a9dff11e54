//! Measurement planning: collision queries against hand-computed cases, collision shapes placed
//! where the kinematics puts their links, a ball-bar that obviously hits the table, the optimiser
//! against random and exhaustive selections, the whole pipeline on the shipped example (a
//! colliding candidate is never chosen and is reported; the programs parse back to the poses;
//! the plan simulates), and bad planning files located by line and column.

use mtcal_kinematics::rigid::Rigid;
use mtcal_kinematics::{Machine, Side};
use mtcal_machine::{load_machine, topology::Reading};
use mtcal_plan::geometry::{Carrier, MachineGeometry, Primitive, Solid, signed_distance};
use mtcal_plan::info::{Choice, combinations};
use mtcal_plan::scene::{Scene, instrument_bodies};
use mtcal_plan::sizes::GeometryConfig;
use mtcal_testkit::random::SplitMix64;
use mtcal_testkit::repo;
use nalgebra::{DMatrix, Isometry3, Vector3};
use std::path::Path;

type Rng = SplitMix64;

/// A uniform index below `n`.
fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

fn machine(name: &str) -> Machine {
    let p = repo().join("machines").join(name);
    load_machine(p.to_str().unwrap(), Reading::default())
        .unwrap()
        .machine
}

fn tooled(m: &Machine, length: f64) -> Machine {
    let mut spec = m.to_spec();
    spec.tool.end *= Isometry3::translation(0.0, 0.0, -length);
    Machine::try_new(&spec).unwrap()
}

#[test]
fn box_and_sphere_distances_match_hand_computation() {
    let cube = Solid::new(&Primitive::Box {
        half: [0.1, 0.2, 0.3],
    });
    let ball = Solid::new(&Primitive::Sphere { radius: 0.05 });
    let at = |x: f64, y: f64, z: f64| Rigid::translation(Vector3::new(x, y, z));
    // Face distances: along x 0.25 − 0.1 − 0.05 = 0.1; along z 0.4 − 0.3 − 0.05 = 0.05.
    let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(0.25, 0.0, 0.0), 0.2).unwrap();
    assert!((d.unwrap() - 0.1).abs() < 1e-9, "{d:?}");
    let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(0.0, 0.0, 0.4), 0.2).unwrap();
    assert!((d.unwrap() - 0.05).abs() < 1e-9, "{d:?}");
    // Corner: the nearest point is (0.1, 0.2, 0.3); the ball centre 0.1 further along each axis.
    let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(0.2, 0.3, 0.4), 0.5).unwrap();
    assert!((d.unwrap() - (0.03f64.sqrt() - 0.05)).abs() < 1e-9, "{d:?}");
    // Overlap by 0.02: negative.
    let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(0.13, 0.0, 0.0), 0.1).unwrap();
    assert!((d.unwrap() + 0.02).abs() < 1e-9, "{d:?}");
    // Beyond the prediction distance: nothing.
    let d = signed_distance(&cube, &at(0.0, 0.0, 0.0), &ball, &at(0.5, 0.0, 0.0), 0.1).unwrap();
    assert_eq!(d, None);
    // A cylinder along z (URDF convention): radius 0.1, half length 0.2; a ball beside it and
    // one above its end cap.
    let cyl = Solid::new(&Primitive::Cylinder {
        radius: 0.1,
        half_length: 0.2,
    });
    let d = signed_distance(&cyl, &at(0.0, 0.0, 0.0), &ball, &at(0.0, 0.16, 0.0), 0.1).unwrap();
    assert!((d.unwrap() - 0.01).abs() < 1e-9, "{d:?}");
    let d = signed_distance(&cyl, &at(0.0, 0.0, 0.0), &ball, &at(0.0, 0.0, 0.26), 0.1).unwrap();
    assert!((d.unwrap() - 0.01).abs() < 1e-9, "{d:?}");
}

/// The clearance rule: a pair collides when its distance is below the clearance, so a gap of
/// 0.9 mm collides at 1 mm clearance and a gap of 1.1 mm does not.
#[test]
fn the_clearance_margin_decides() {
    let m = machine("mcv754-zfyx.urdf");
    let g = MachineGeometry::from_urdf_file(&repo().join("machines/mcv754-zfyx.urdf"), &m).unwrap();
    let t = tooled(&m, 0.1);
    let q = vec![0.0; m.n_axes()];
    // The table body: where is its top, in the workpiece frame?
    let table = g
        .bodies
        .iter()
        .position(|b| matches!(b.primitive, Primitive::Box { .. }))
        .unwrap();
    let Primitive::Box { half } = g.bodies[table].primitive else {
        unreachable!()
    };
    let w = m.branch_pose(Side::Workpiece, &q);
    let top_f = g
        .body_pose(&m, table, &q)
        .apply(&Vector3::new(0.0, 0.0, half[2]));
    let top_w = w.inverse().apply(&top_f);
    for (gap_mm, collides) in [(0.9, true), (1.1, false)] {
        let r = 0.01;
        // A free sphere on the bar mount with zero length stands in for a probe ball; here a
        // ball-bar pivot ball hanging over the table top edge is simplest: pivot ball radius
        // from the geometry config.
        let cfg = GeometryConfig::default()
            .with("ballbar_ball_diameter_mm", 2.0 * r * 1e3)
            .unwrap();
        let z = top_w.z + r + gap_mm * 1e-3;
        let setup: toml::Table =
            toml::from_str(&format!("pivot = [0.0, 0.0, {}]\nlength = 30.0", z * 1e3)).unwrap();
        let (bodies, allowed) = instrument_bodies("ballbar", &setup, 0.1, &m, &cfg)
            .unwrap()
            .unwrap();
        // Keep only the pivot ball: the post stands on the table by design.
        let bodies: Vec<_> = bodies
            .into_iter()
            .filter(|b| b.name == "pivot ball")
            .collect();
        // The ball hangs on the workpiece mount, which carries the table: that pair is skipped by
        // design. Re-mount it as a bar-free tool-side body at the same place to test the rule.
        let wp = w.compose(&Rigid::translation(Vector3::new(0.0, 0.0, z)));
        let tool = t.branch_pose(Side::Tool, &q);
        let mut b = bodies[0].clone();
        b.mount = mtcal_plan::scene::Mount::Tool;
        b.offset = tool.inverse().compose(&wp);
        let scene = Scene::new(&m, &t, &g, vec![b], allowed, 1e-3);
        let hits = scene.check(&q, None).unwrap();
        let table_hit = hits.iter().any(|h| h.b == g.bodies[table].name);
        assert_eq!(table_hit, collides, "gap {gap_mm} mm: {hits:?}");
    }
}

#[test]
fn collision_shapes_sit_on_their_links_frames() {
    // Spheres on the tool link, on the workpiece link and on a link fixed below the A cradle
    // through two fixed joints.
    let text = std::fs::read_to_string(repo().join("machines/mcu630-cafyxz.urdf")).unwrap();
    let sphere = |link: &str, xyz: &str| {
        format!(
            "<link name=\"{link}\"><collision><origin xyz=\"{xyz}\" rpy=\"0 0 0\"/><geometry>\
             <sphere radius=\"0.01\"/></geometry></collision></link>"
        )
    };
    let extra = format!(
        "{}{}<joint name=\"f1\" type=\"fixed\"><origin xyz=\"0.1 0 0\" rpy=\"0 0 0.5\"/>\
         <parent link=\"a_cradle\"/><child link=\"bracket\"/></joint>\
         <joint name=\"f2\" type=\"fixed\"><origin xyz=\"0 0.2 0\" rpy=\"0.3 0 0\"/>\
         <parent link=\"bracket\"/><child link=\"sensor\"/></joint>",
        "<link name=\"bracket\"/>",
        sphere("sensor", "0 0 0.05")
    );
    let text = text
        .replace("<link name=\"tool\"/>", &sphere("tool", "0 0 0"))
        .replace(
            "<link name=\"workpiece\"/>",
            &sphere("workpiece", "0.01 0.02 0.03"),
        )
        .replace("</robot>", &format!("{extra}</robot>"));
    let m = mtcal_machine::urdf::load_urdf_str(&text, Path::new("t.urdf")).unwrap();
    let g = MachineGeometry::from_urdf_str(&text, Path::new("t.urdf"), &m).unwrap();
    let find = |n: &str| g.bodies.iter().position(|b| b.name == n).unwrap();
    let (tool, wp, sensor) = (find("tool"), find("workpiece"), find("sensor"));
    assert_eq!(
        g.bodies[sensor].carrier,
        Carrier::Axis(m.axis_index('A').unwrap())
    );
    let mut rng = SplitMix64(3);
    for _ in 0..20 {
        let q: Vec<f64> = m
            .axes()
            .iter()
            .map(|a| {
                let (lo, hi) = a.limits().unwrap_or((-3.0, 3.0));
                lo + (hi - lo) * rng.unit()
            })
            .collect();
        let t = m.branch_pose(Side::Tool, &q).t;
        assert!((g.body_pose(&m, tool, &q).t - t).norm() < 1e-12);
        let w = m.branch_pose(Side::Workpiece, &q);
        let expect = w.apply(&Vector3::new(0.01, 0.02, 0.03));
        assert!((g.body_pose(&m, wp, &q).t - expect).norm() < 1e-12);
        // The sensor: frame → A joint (origin, motion) → f1 → f2 → collision origin.
        let a = m.axis_index('A').unwrap();
        let ax = &m.axes()[a];
        let iso = |x: [f64; 3], rpy: [f64; 3]| {
            Rigid::from_isometry(&Isometry3::from_parts(
                nalgebra::Translation3::new(x[0], x[1], x[2]),
                nalgebra::UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
            ))
        };
        let expect = ax
            .origin()
            .compose(&ax.motion(q[a]))
            .compose(&iso([0.1, 0.0, 0.0], [0.0, 0.0, 0.5]))
            .compose(&iso([0.0, 0.2, 0.0], [0.3, 0.0, 0.0]))
            .apply(&Vector3::new(0.0, 0.0, 0.05));
        assert!((g.body_pose(&m, sensor, &q).t - expect).norm() < 1e-12);
    }
    // The shipped table: a cylinder 40 mm below the table top, which is the workpiece frame.
    let m = machine("mcu630-cafyxz.urdf");
    let g =
        MachineGeometry::from_urdf_file(&repo().join("machines/mcu630-cafyxz.urdf"), &m).unwrap();
    let q = [0.1, -0.2, -0.3, 0.7, 2.0];
    let table = g.bodies.iter().position(|b| b.name == "c_table").unwrap();
    let expect = m
        .branch_pose(Side::Workpiece, &q)
        .compose(&Rigid::translation(Vector3::new(0.0, 0.0, -0.04)));
    let got = g.body_pose(&m, table, &q);
    assert!((got.t - expect.t).norm() < 1e-12 && (got.r - expect.r).norm() < 1e-12);
}

/// A ball-bar on the MCU 630 table: a ZX circle of radius 100 mm about a pivot 90 mm above the
/// table sends the tool ball 10 mm below the table top (and the holder into the pivot post); an
/// XY circle about a pivot 150 mm up touches nothing.
#[test]
fn a_ballbar_that_dives_into_the_table_collides() {
    let m = machine("mcu630-cafyxz.urdf");
    let g =
        MachineGeometry::from_urdf_file(&repo().join("machines/mcu630-cafyxz.urdf"), &m).unwrap();
    let t = tooled(&m, 0.12);
    let plugin = mtcal_instrument::find("ballbar").unwrap();
    let cfg = GeometryConfig::default();
    let check = |pivot_z: f64, plane: &str| {
        let setup: toml::Table =
            toml::from_str(&format!("pivot = [0.0, 0.0, {pivot_z}]\nlength = 100.0")).unwrap();
        let path: toml::Table = toml::from_str(&format!(
            "kind = \"circle\"\nplane = \"{plane}\"\nsamples = 37"
        ))
        .unwrap();
        let loaded =
            (plugin.load_setup)(&setup, &mtcal_instrument::SetupContext { machine: &t }).unwrap();
        let poses = (plugin.path)(&mtcal_instrument::PathSpec {
            path: &path,
            setup: &*loaded,
            machine: &t,
        })
        .unwrap();
        let (bodies, allowed) = instrument_bodies("ballbar", &setup, 0.12, &m, &cfg)
            .unwrap()
            .unwrap();
        let scene = Scene::new(&m, &t, &g, bodies, allowed, 1e-3);
        poses
            .iter()
            .map(|q| scene.check(q, None).unwrap())
            .collect::<Vec<_>>()
    };
    let low = check(90.0, "ZX");
    // ZX angles run from +Z towards +X: sample 18 of 37 is at 180°, the tool ball straight
    // below the pivot, 10 mm under the table top.
    let bottom = &low[18];
    let ball = bottom
        .iter()
        .find(|h| h.a == "tool ball" && h.b == "c_table")
        .expect("the tool ball hits the table");
    assert!((ball.distance_mm + 10.0 + 6.35).abs() < 0.1, "{ball:?}");
    // At the top of the circle nothing touches.
    assert!(low[0].is_empty(), "{:?}", low[0]);
    let high = check(150.0, "XY");
    assert!(high.iter().all(|h| h.is_empty()), "{high:?}");
}

fn random_info(rng: &mut Rng, m: usize, rank: usize) -> DMatrix<f64> {
    let u = DMatrix::from_fn(m, rank, |_, _| rng.unit() * 2.0 - 1.0) * 1e4;
    &u * u.transpose()
}

#[test]
fn greedy_beats_random_selections_and_matches_exhaustive_search() {
    let mut rng = SplitMix64(11);
    let m = 6;
    let wanted = [0, 2, 3, 5];
    let mut greedy_gaps = Vec::new();
    for trial in 0..6 {
        let base = random_info(&mut rng, m, 1);
        let cands: Vec<DMatrix<f64>> = (0..9).map(|_| random_info(&mut rng, m, 2)).collect();
        // Two groups: five candidates (choose 2) and four (choose 1).
        let choice = Choice {
            base: &base,
            candidates: cands
                .iter()
                .enumerate()
                .map(|(c, i)| (usize::from(c >= 5), i))
                .collect(),
            budget: vec![2, 1],
            excluded: vec![false; 9],
            wanted: &wanted,
        };
        let chosen = choice.choose();
        let best = choice.exhaustive(10_000).unwrap();
        let (vc, vb) = (choice.value(&chosen), choice.value(&best));
        assert!(
            (vc - vb).abs() < 1e-9 * vb.abs().max(1.0),
            "trial {trial}: {chosen:?} {vc} vs {best:?} {vb}"
        );
        // The greedy heuristic (what larger candidate sets get) beats the typical random
        // selection of the same sizes, and nothing beats the exhaustive optimum.
        let vg = choice.value(&choice.greedy());
        let mut random = Vec::new();
        for _ in 0..30 {
            let mut first: Vec<usize> = (0..5).collect();
            let a = first.remove(below(&mut rng, 5));
            let b = first.remove(below(&mut rng, 4));
            let c = 5 + below(&mut rng, 4);
            let v = choice.value(&[a, b, c]);
            assert!(vb <= v + 1e-12);
            random.push(v);
        }
        random.sort_by(f64::total_cmp);
        assert!(
            vg <= random[random.len() / 2],
            "trial {trial}: greedy {vg} vs random median"
        );
        greedy_gaps.push(vg - vb);
    }
    // Greedy with exchanges finds the optimum in most of these small problems.
    let exact = greedy_gaps.iter().filter(|g| **g < 1e-9).count();
    assert!(exact * 2 >= greedy_gaps.len(), "{greedy_gaps:?}");
    assert_eq!(combinations(&[1, 2, 3, 4], 2).len(), 6);
}

#[test]
fn an_excluded_candidate_is_never_chosen() {
    let mut rng = SplitMix64(5);
    let m = 5;
    let base = DMatrix::zeros(m, m);
    let cands: Vec<DMatrix<f64>> = (0..6).map(|_| random_info(&mut rng, m, 2)).collect();
    let wanted = [0, 1, 2, 3, 4];
    let mut choice = Choice {
        base: &base,
        candidates: cands.iter().map(|i| (0, i)).collect(),
        budget: vec![2],
        excluded: vec![false; 6],
        wanted: &wanted,
    };
    let free = choice.greedy();
    // Exclude the best choice's members: the next choice avoids them.
    for &c in &free {
        choice.excluded[c] = true;
    }
    let forced = choice.greedy();
    assert!(
        forced.iter().all(|c| !free.contains(c)),
        "{free:?} {forced:?}"
    );
    assert!(choice.value(&forced) >= choice.value(&free) - 1e-12);
}

fn example() -> mtcal_plan::Planned {
    mtcal_plan::plan(&repo().join("examples/five-axis/planning.toml")).unwrap()
}

#[test]
fn the_example_plan_avoids_collisions_reports_them_and_writes_programs_that_parse_back() {
    let planned = example();
    let r = &planned.report;
    // Low balls collide in the YZA run (the spindle housing meets the tilted table); they are
    // reported, never chosen.
    let low = r.candidates.iter().find(|c| c.name == "rtest-01").unwrap();
    assert_eq!(low.status, "collides");
    assert!(
        low.runs
            .iter()
            .any(|x| x.collides() && x.worst.as_ref().unwrap().a == "c_table")
    );
    for c in &r.candidates {
        assert!(
            !c.chosen || c.status == "ok",
            "{} chosen with status {}",
            c.name,
            c.status
        );
    }
    assert_eq!(r.chosen().len(), 3, "{:?}", r.chosen());
    assert!(
        r.given_up.iter().any(|s| s.contains("rtest-01")),
        "{:?}",
        r.given_up
    );
    let zx = r
        .fixed_runs
        .iter()
        .find(|f| f.check.run == "ballbar-zx-low")
        .unwrap();
    assert!(!zx.kept);
    assert!(!planned.runs.iter().any(|x| x.name == "ballbar-zx-low"));
    // The choice beats the random selections and the hand-written plan on the wanted
    // parameters, and the collision-free choice is no better than the unconstrained one.
    let c = &r.criteria;
    assert!(c.chosen <= c.random_best.unwrap() + 1e-9, "{c:?}");
    assert!(c.chosen < c.hand.unwrap(), "{c:?}");
    assert!(c.ignoring_collisions <= c.chosen + 1e-9, "{c:?}");
    for row in r
        .intervals
        .iter()
        .filter(|i| i.wanted && i.chosen.is_some())
    {
        assert!(
            row.chosen.unwrap() <= row.hand.unwrap_or(f64::INFINITY) * 1.0001,
            "{row:?}"
        );
    }
    // Programs parse back to the planned poses; the plan simulates.
    let dir = tempfile::tempdir().unwrap();
    planned.write(dir.path()).unwrap();
    for run in &planned.runs {
        let text =
            std::fs::read_to_string(dir.path().join(format!("programs/{}.nc", run.name))).unwrap();
        let program = mtcal_ncprog::Program::parse(&text).unwrap();
        let states = program.modal_states();
        let moves: Vec<_> = program
            .lines
            .iter()
            .zip(&states)
            .filter(|(l, _)| l.has_axis_word())
            .map(|(_, s)| s.axes)
            .collect();
        assert_eq!(moves.len(), run.poses.len(), "{}", run.name);
        for (axes, q) in moves.iter().zip(&run.poses) {
            // X Y Z A C of the program against the pose (mm, degrees), 4 decimals.
            let expect = [
                q[0] * 1e3,
                q[1] * 1e3,
                q[2] * 1e3,
                q[3].to_degrees(),
                q[4].to_degrees(),
            ];
            let got = [axes[0], axes[1], axes[2], axes[3], axes[5]];
            for (g, e) in got.iter().zip(expect) {
                assert!(
                    (g.unwrap() - e).abs() < 6e-5,
                    "{}: {got:?} vs {expect:?}",
                    run.name
                );
            }
        }
    }
    let sim = mtcal_simulate::simulate(&dir.path().join("plan.toml"), &dir.path().join("session"))
        .unwrap();
    assert_eq!(sim.runs, planned.runs.len());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["schema"], "mtcal.plan/1");
}

fn check_bad(text: &str, line: usize, expect: &str) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    let machine = repo().join("machines/mcu630-cafyxz.urdf");
    let text = text.replace("MACHINE", machine.to_str().unwrap());
    std::fs::write(&p, &text).unwrap();
    let e = mtcal_plan::plan(&p).expect_err("an error").to_string();
    let at = format!("{}:{line}:", p.display());
    assert!(e.starts_with(&at), "expected {at}…, got: {e}");
    assert!(e.contains(expect), "expected `{expect}` in: {e}");
}

#[test]
fn bad_planning_files_name_file_line_and_column() {
    let head = "machine = \"MACHINE\"\nwanted = [\"EX0C\"]\n";
    check_bad("machine = \"MACHINE\"\nwanted = [\"EX0C\"\n", 2, "");
    check_bad(&format!("{head}bogus = 1\n"), 3, "unknown field `bogus`");
    check_bad(
        &format!("{head}tool_length_mm = -5.0\n"),
        3,
        "`tool_length_mm` must be",
    );
    check_bad(
        "machine = \"MACHINE\"\nwanted = \"some\"\n",
        2,
        "\"all\" or a list",
    );
    check_bad(
        &format!(
            "{head}[[candidates]]\nname = \"r\"\ninstrument = \"rtest\"\nchoose = 0\ngrid = {{ x = [0.0], y = [0.0], z = [100.0] }}\nruns = [{{ name = \"xyc\", path = {{ kind = \"xyc\" }} }}]\n"
        ),
        6,
        "`choose` must be at least 1",
    );
    check_bad(
        &format!(
            "{head}[[candidates]]\nname = \"r\"\ninstrument = \"rtest\"\nchoose = 1\nruns = [{{ name = \"xyc\" }}]\n"
        ),
        3,
        "has no positions",
    );
    check_bad(
        &format!(
            "{head}[[candidates]]\nname = \"r\"\ninstrument = \"laserx\"\nchoose = 1\npoints = [[0.0, 0.0, 100.0]]\nruns = [{{ name = \"a\" }}]\n"
        ),
        5,
        "unknown instrument `laserx`",
    );
    check_bad(
        &format!("{head}[[run]]\nname = \"b\"\ninstrument = \"ballbar\"\nsetup = \"nope\"\n"),
        3,
        "no [setup.nope]",
    );
    check_bad(
        "machine = \"MACHINE\"\nwanted = [\"EQQQ\"]\n[[run]]\nname = \"b\"\ninstrument = \"ballbar\"\nsetup = { pivot = [0.0, 0.0, 150.0], length = 100.0 }\npath = { kind = \"circle\", plane = \"XY\", samples = 19 }\n",
        2,
        "wanted `EQQQ` is not an estimated parameter",
    );
    check_bad(
        "machine = \"nowhere.urdf\"\nwanted = \"all\"\n",
        1,
        "machine:",
    );
}

/// An artefact (a 2-D hole plate probed with a touch probe): the plate sits where the artefact
/// plugin puts it (origin in axis coordinates of the probe's tool point), so a placement on the
/// table is clear and one 40 mm lower puts the probe into the table; the chosen placement's
/// program probes every feature at its nominal position.
#[test]
fn artefact_placements_are_collision_checked_and_their_programs_probe_the_features() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("planning.toml");
    let machine = repo().join("machines/mcu630-cafyxz.urdf");
    let text = format!(
        r#"machine = "{}"
wanted = ["EC0Y"]
tool_length_mm = 120.0
random_trials = 4

[[candidates]]
name = "plate"
instrument = "artefact"
choose = 1
setup = {{ features = {{ h1 = [0.0, 0.0], h2 = [100.0, 0.0], h3 = [0.0, 100.0], h4 = [100.0, 100.0] }} }}
points = [[-50.0, -50.0, -500.0], [-50.0, -50.0, -540.0]]
runs = [ {{ name = "probe", path = {{}} }} ]
"#,
        machine.display()
    );
    std::fs::write(&p, text).unwrap();
    let planned = mtcal_plan::plan(&p).unwrap();
    let r = &planned.report;
    let status = |n: &str| &r.candidates.iter().find(|c| c.name == n).unwrap().status;
    assert_eq!(status("plate-01"), "ok");
    assert_eq!(status("plate-02"), "collides");
    assert!(
        r.given_up.iter().any(|s| s.contains("plate-02")),
        "{:?}",
        r.given_up
    );
    let run = planned
        .runs
        .iter()
        .find(|x| x.name == "plate-01-probe")
        .expect("the clear placement is planned");
    assert!(!planned.runs.iter().any(|x| x.name.starts_with("plate-02")));
    let out = tempfile::tempdir().unwrap();
    planned.write(out.path()).unwrap();
    let text = std::fs::read_to_string(out.path().join("programs/plate-01-probe.nc")).unwrap();
    let program = mtcal_ncprog::Program::parse(&text).unwrap();
    let states = program.modal_states();
    let probed: Vec<[f64; 3]> = program
        .lines
        .iter()
        .zip(&states)
        .filter(|(l, _)| l.has_axis_word())
        .map(|(_, s)| [s.axes[0].unwrap(), s.axes[1].unwrap(), s.axes[2].unwrap()])
        .collect();
    // Features in name order at origin + feature (mm).
    let want = [[-50.0, -50.0], [50.0, -50.0], [-50.0, 50.0], [50.0, 50.0]];
    assert_eq!(probed.len(), want.len());
    assert_eq!(run.poses.len(), want.len());
    for (got, w) in probed.iter().zip(want) {
        assert!(
            (got[0] - w[0]).abs() < 1e-4 && (got[1] - w[1]).abs() < 1e-4,
            "{got:?}"
        );
        assert!((got[2] + 500.0).abs() < 1e-4, "{got:?}");
    }
}

/// The R-test's bodies follow its `mount`: ball on the table (the default) puts the ball on a
/// post and the head on the tool above it; ball in the spindle the ball on the tool and the
/// head on a post below it.
#[test]
fn rtest_bodies_follow_the_mount() {
    use mtcal_plan::scene::Mount;
    let m = machine("mcu630-cafyxz.urdf");
    let cfg = GeometryConfig::default();
    let bodies = |extra: &str| {
        let setup: toml::Table =
            toml::from_str(&format!("ball = [100.0, 0.0, 200.0]\n{extra}")).unwrap();
        instrument_bodies("rtest", &setup, 0.12, &m, &cfg)
            .unwrap()
            .unwrap()
    };
    let find = |b: &[mtcal_plan::scene::InstrumentBody], name: &str| {
        b.iter()
            .find(|x| x.name == name)
            .unwrap_or_else(|| panic!("{name}"))
            .clone()
    };
    for extra in ["", "mount = \"ball-on-table\""] {
        let (b, allowed) = bodies(extra);
        assert_eq!(
            allowed,
            [("rtest ball".to_string(), "rtest head".to_string())]
        );
        let ball = find(&b, "rtest ball");
        assert_eq!(ball.mount, Mount::Workpiece);
        assert!((ball.offset.t - Vector3::new(0.1, 0.0, 0.2)).norm() < 1e-12);
        // The head hangs from the tool: its bottom 8 mm above the ball centre, 50 mm tall.
        let head = find(&b, "rtest head");
        assert_eq!(head.mount, Mount::Tool);
        assert!((head.offset.t - Vector3::new(0.0, 0.0, 0.033)).norm() < 1e-12);
        // The post stands on the table top up to the ball's bottom (200 − 11 mm).
        let post = find(&b, "rtest post");
        assert_eq!(post.mount, Mount::Workpiece);
        assert!(
            (post.offset.t.z - 0.0945).abs() < 1e-12,
            "{:?}",
            post.offset
        );
        assert_eq!(find(&b, "holder").mount, Mount::Tool);
    }
    let (b, _) = bodies("mount = \"ball-in-spindle\"");
    assert_eq!(find(&b, "rtest ball").mount, Mount::Tool);
    let head = find(&b, "rtest head");
    assert_eq!(head.mount, Mount::Workpiece);
    // The head's top 8 mm below the ball centre: centre at 200 − 8 − 25 mm.
    assert!((head.offset.t - Vector3::new(0.1, 0.0, 0.167)).norm() < 1e-12);
}

/// New plans say which R-test mount they were planned for: the plugin's default
/// (`ball-on-table`) written out where the planning file says nothing, the given one kept.
#[test]
fn planned_rtest_set_ups_say_their_mount() {
    let dir = tempfile::tempdir().unwrap();
    let machine = repo().join("machines/mcu630-cafyxz.urdf");
    let text = format!(
        "machine = {machine:?}\nwanted = [\"EX0C\", \"EY0C\"]\ntool_length_mm = 120.0\n\
         move_step = 0.0\nrandom_trials = 2\n\
         [setup.fixed]\nball = [100.0, 0.0, 250.0]\n\
         [[run]]\nname = \"fixed-xyc\"\ninstrument = \"rtest\"\nsetup = \"fixed\"\n\
         path = {{ kind = \"xyc\", samples = 13 }}\n\
         [[candidates]]\nname = \"table\"\ninstrument = \"rtest\"\nchoose = 1\n\
         points = [[150.0, 0.0, 200.0]]\nruns = [{{ name = \"xyc\", path = {{ kind = \"xyc\", samples = 13 }} }}]\n\
         [[candidates]]\nname = \"spindle\"\ninstrument = \"rtest\"\nchoose = 1\n\
         setup = {{ mount = \"ball-in-spindle\" }}\n\
         points = [[150.0, 0.0, 200.0]]\nruns = [{{ name = \"xyc\", path = {{ kind = \"xyc\", samples = 13 }} }}]\n"
    );
    let p = dir.path().join("planning.toml");
    std::fs::write(&p, text).unwrap();
    let planned = mtcal_plan::plan(&p).unwrap();
    let mount_of = |run: &str| {
        let r = planned
            .runs
            .iter()
            .find(|r| r.name == run)
            .unwrap_or_else(|| panic!("{run} planned"));
        r.setup
            .get("mount")
            .and_then(|v| v.as_str())
            .map(str::to_string)
    };
    assert_eq!(mount_of("fixed-xyc").as_deref(), Some("ball-on-table"));
    assert_eq!(mount_of("table-01-xyc").as_deref(), Some("ball-on-table"));
    assert_eq!(
        mount_of("spindle-01-xyc").as_deref(),
        Some("ball-in-spindle")
    );
    // …and the written plan.toml carries them into simulate.
    let out = dir.path().join("out");
    planned.write(&out).unwrap();
    let plan: toml::Table =
        toml::from_str(&std::fs::read_to_string(out.join("plan.toml")).unwrap()).unwrap();
    let setup_mount = |s: &str| plan["setup"][s]["mount"].as_str().map(str::to_string);
    assert_eq!(setup_mount("fixed").as_deref(), Some("ball-on-table"));
    assert_eq!(setup_mount("table-01").as_deref(), Some("ball-on-table"));
    assert_eq!(
        setup_mount("spindle-01").as_deref(),
        Some("ball-in-spindle")
    );
}

/// The `[geometry]` keys and defaults docs/PLANNING.md documents are what the planner and the
/// instruments declare: moving each instrument's sizes into its plugin changed no user's file.
#[test]
fn the_documented_geometry_keys_keep_their_defaults() {
    let documented = [
        ("table_z_mm", 0.0),
        ("holder_diameter_mm", 50.0),
        ("holder_length_mm", 60.0),
        ("stem_diameter_mm", 8.0),
        ("rtest_ball_diameter_mm", 22.0),
        ("rtest_head_diameter_mm", 70.0),
        ("rtest_head_height_mm", 50.0),
        ("rtest_head_gap_mm", 8.0),
        ("rtest_post_diameter_mm", 30.0),
        ("ballbar_ball_diameter_mm", 12.7),
        ("ballbar_bar_diameter_mm", 16.0),
        ("ballbar_cup_mm", 20.0),
        ("ballbar_post_diameter_mm", 16.0),
        ("probe_ball_diameter_mm", 6.0),
        ("plate_margin_mm", 15.0),
        ("plate_thickness_mm", 20.0),
    ];
    let mut declared: Vec<(&str, f64)> = mtcal_plan::sizes::SHARED
        .iter()
        .chain(
            mtcal_instrument::plugins()
                .iter()
                .filter_map(|p| p.planning)
                .flat_map(|p| p.sizes),
        )
        .map(|k| (k.name, k.default_mm))
        .collect();
    declared.sort_by(|a, b| a.0.cmp(b.0));
    let mut want = documented.to_vec();
    want.sort_by(|a, b| a.0.cmp(b.0));
    assert_eq!(declared, want);
    let text = std::fs::read_to_string(repo().join("docs/PLANNING.md")).unwrap();
    for (key, default) in documented {
        assert!(text.contains(&format!("`{key}`")), "{key} undocumented");
        // Every key is read as a planning file gives it.
        let given = toml::Value::Float(default + 1.0);
        let g = GeometryConfig::read([(key, &given)]).unwrap();
        assert_eq!(g.sizes().given_mm().get(key), Some(&(default + 1.0)));
    }
}
