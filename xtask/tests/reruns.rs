//! Interrupted and repeated runs (issue 7): every command that writes files, run twice into the
//! same place, writes byte-identical files and prints the same; no temporary file is left
//! beside its outputs; the inputs (example sessions, machines, parameter files, programs) are
//! not modified. A run killed (SIGKILL) at any moment leaves every output either as it was or
//! complete — never half a file.

use mtcal_testkit::cli::run_in_repo;
use mtcal_testkit::repo;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn mtcal(args: &[&str]) -> Output {
    run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

fn ok(args: &[&str]) -> Output {
    let out = mtcal(args);
    assert!(
        out.status.success(),
        "mtcal {}\n{}{}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Every file under `dir` (relative path → bytes), folders recursed.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                out.insert(p.strip_prefix(root).unwrap().to_path_buf(), bytes);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn temporaries(files: &BTreeMap<PathBuf, Vec<u8>>) -> Vec<&PathBuf> {
    files
        .keys()
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with('.') || name.ends_with(".tmp")
        })
        .collect()
}

const M5: &str = "machines/mcu630-cafyxz.urdf";
const P5: &str = "examples/mcu630-cafyxz.params.toml";
const M3: &str = "examples/three-axis/machine/zfyx.urdf";
const P3: &str = "examples/three-axis/truth.params.toml";
const PROGRAM3: &str = "G21 G90\nN10 G0 X-100 Y-50 Z-100 (start)\nN20 G1 X100 F500\nY50\nM30\n";
/// A five-axis program on the trunnion (away from A = 0, where C and the tool axis line up and
/// `correct` refuses the pose: `edge_cases.rs`).
const PROGRAM5: &str =
    "G21 G90\nG0 X0 Y0 Z-300 A5 C0\nG1 X50 Y20 A10 C30 F800\nA15 C90\nA-20 C180\nM30\n";
const CL3: &str = "x,y,z,i,j,k\n0,0,300,0,0,1\n100,50,280,0,0,1\n-200,-100,350,0,0,2\n";

/// The folders of the inputs the commands below read.
const INPUT_DIRS: [&str; 2] = ["examples", "machines"];

#[test]
fn every_command_twice_gives_byte_identical_outputs_and_leaves_inputs_alone() {
    let started = Instant::now();
    let repo = repo();
    let before: Vec<_> = INPUT_DIRS.iter().map(|d| snapshot(&repo.join(d))).collect();
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path();
    let inputs = o.join("inputs");
    std::fs::create_dir(&inputs).unwrap();
    std::fs::write(inputs.join("p3.nc"), PROGRAM3).unwrap();
    std::fs::write(inputs.join("p5.nc"), PROGRAM5).unwrap();
    std::fs::write(inputs.join("cl3.csv"), CL3).unwrap();
    let inputs_before = snapshot(&inputs);
    let out = o.join("out");
    std::fs::create_dir(&out).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let i = |name: &str| s(&inputs.join(name));
    let w = |name: &str| s(&out.join(name));
    let commands: Vec<Vec<String>> = vec![
        vec![
            "identify".into(),
            "examples/five-axis/session".into(),
            "--quiet".into(),
            "--json".into(),
            w("id.json"),
            "--predict".into(),
            w("predict"),
            "--report".into(),
            w("report"),
        ],
        vec![
            "identify".into(),
            "examples/five-axis-warm/session".into(),
            "--search".into(),
            "--quiet".into(),
            "--json".into(),
            w("search.json"),
            "--report".into(),
            w("search-report"),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("grid.csv"),
            "--spacing-mm".into(),
            "100".into(),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("x.csv"),
            "--axis".into(),
            "X".into(),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("x.comp"),
            "--axis".into(),
            "X".into(),
            "--format".into(),
            "linuxcnc".into(),
            "--reversal-um".into(),
            "2".into(),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("isg.csv"),
            "--format".into(),
            "isg".into(),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("etalon.txt"),
            "--format".into(),
            "etalon".into(),
        ],
        vec![
            "compensate".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--out".into(),
            w("trt.hal"),
            "--format".into(),
            "linuxcnc-trt".into(),
        ],
        vec![
            "correct".into(),
            M3.into(),
            "--params".into(),
            P3.into(),
            "--program".into(),
            i("p3.nc"),
            "--out".into(),
            w("c3.nc"),
        ],
        vec![
            "correct".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--program".into(),
            i("p5.nc"),
            "--out".into(),
            w("c5.nc"),
        ],
        vec![
            "zero-point".into(),
            M3.into(),
            "--params".into(),
            P3.into(),
            "--program".into(),
            i("p3.nc"),
            "--out".into(),
            w("z3.nc"),
        ],
        vec![
            "cl-error".into(),
            M3.into(),
            "--params".into(),
            P3.into(),
            "--cl".into(),
            i("cl3.csv"),
            "--out".into(),
            w("cl3-errors.csv"),
            "--plot".into(),
            w("cl3-errors.svg"),
        ],
        vec![
            "map".into(),
            M5.into(),
            "--params".into(),
            P5.into(),
            "--grid".into(),
            "5x5x5".into(),
            "--orientations".into(),
            "A=-30..90/3,C=0..270/4".into(),
        ],
        vec![
            "simulate".into(),
            "examples/five-axis/plan.toml".into(),
            "--out".into(),
            w("simulated"),
        ],
        vec![
            "tolerance".into(),
            M3.into(),
            "--spec".into(),
            "examples/three-axis/tolerances.toml".into(),
            "--samples".into(),
            "60".into(),
            "--grid".into(),
            "4x3x3".into(),
            "--bootstrap".into(),
            "10".into(),
            "--json".into(),
            w("tolerance.json"),
        ],
        vec![
            "plan".into(),
            "examples/five-axis/planning.toml".into(),
            "--out".into(),
            w("plan"),
        ],
        vec![
            "topology".into(),
            "CAFYXZ".into(),
            "--out".into(),
            w("cafyxz.urdf"),
        ],
    ];
    let run_all = || -> Vec<Vec<u8>> {
        commands
            .iter()
            .map(|c| {
                let args: Vec<&str> = c.iter().map(String::as_str).collect();
                ok(&args).stdout
            })
            .collect()
    };
    let first_stdout = run_all();
    let first = snapshot(&out);
    let second_stdout = run_all();
    let second = snapshot(&out);
    for (c, (a, b)) in commands.iter().zip(first_stdout.iter().zip(&second_stdout)) {
        assert_eq!(
            String::from_utf8_lossy(a),
            String::from_utf8_lossy(b),
            "standard output of mtcal {}",
            c.join(" ")
        );
    }
    assert_eq!(
        first.keys().collect::<Vec<_>>(),
        second.keys().collect::<Vec<_>>(),
        "the same files"
    );
    for (path, bytes) in &first {
        assert!(
            bytes == &second[path],
            "{} differs between two runs of the same command",
            path.display()
        );
    }
    // Every command wrote something (the folders hold their files), and nothing temporary.
    for f in [
        "id.json",
        "predict/rtest-xyzac.csv",
        "report/index.html",
        "search.json",
        "search-report/index.html",
        "grid.csv",
        "x.csv",
        "x.comp",
        "isg.csv",
        "etalon.txt",
        "trt.hal",
        "c3.nc",
        "c5.nc",
        "z3.nc",
        "cl3-errors.csv",
        "cl3-errors.svg",
        "simulated/session.toml",
        "tolerance.json",
        "plan/plan.toml",
        "plan/report.json",
        "cafyxz.urdf",
    ] {
        assert!(first.contains_key(Path::new(f)), "{f} was written");
    }
    assert!(temporaries(&first).is_empty(), "{:?}", temporaries(&first));
    // The thread count changes no output: the same identification on one thread.
    let one = o.join("one-thread.json");
    ok(&[
        "identify",
        "examples/five-axis/session",
        "--quiet",
        "--threads",
        "1",
        "--json",
        &s(&one),
    ]);
    assert!(
        std::fs::read(&one).unwrap() == first[Path::new("id.json")],
        "identify --threads 1 writes the same JSON"
    );
    assert_eq!(snapshot(&inputs), inputs_before, "the programs and CL data");
    for (d, b) in INPUT_DIRS.iter().zip(&before) {
        assert!(&snapshot(&repo.join(d)) == b, "{d}/ was modified");
    }
    eprintln!("reruns took {:.1} s", started.elapsed().as_secs_f64());
}

/// Old contents planted at every output path of `identify --json --predict --report`, then a
/// run killed at several moments: every file is the old one or the complete new one.
#[cfg(unix)]
#[test]
fn a_killed_identification_leaves_old_or_complete_files() {
    killed_runs_leave_old_or_complete_files(|o| {
        vec![
            "identify".into(),
            "examples/five-axis/session".into(),
            "--quiet".into(),
            "--json".into(),
            o.join("id.json").to_str().unwrap().into(),
            "--predict".into(),
            o.join("predict").to_str().unwrap().into(),
            "--report".into(),
            o.join("report").to_str().unwrap().into(),
        ]
    });
}

/// The same for `simulate` (a session folder: manifest, machine, one CSV and one NC program per
/// run, written one after another).
#[cfg(unix)]
#[test]
fn a_killed_simulation_leaves_old_or_complete_files() {
    killed_runs_leave_old_or_complete_files(|o| {
        vec![
            "simulate".into(),
            "examples/five-axis/plan.toml".into(),
            "--out".into(),
            o.to_str().unwrap().into(),
        ]
    });
}

/// Runs `args(dir)` once to completion for the reference files, then again into folders where
/// every one of those files holds old contents, killed (SIGKILL) at moments spread over the run:
/// afterwards each file is either the old contents or byte for byte the reference; the only
/// other files allowed are a killed write's own temporary file.
#[cfg(unix)]
fn killed_runs_leave_old_or_complete_files(args: impl Fn(&Path) -> Vec<String>) {
    const OLD: &[u8] = b"old contents\n";
    let dir = tempfile::tempdir().unwrap();
    let reference = dir.path().join("reference");
    std::fs::create_dir(&reference).unwrap();
    let t0 = Instant::now();
    let a = args(&reference);
    ok(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let full = t0.elapsed();
    let complete = snapshot(&reference);
    assert!(temporaries(&complete).is_empty(), "{:?}", complete.keys());
    for (rel, bytes) in &complete {
        if rel.extension().is_some_and(|e| e == "json") {
            serde_json::from_slice::<serde_json::Value>(bytes).unwrap();
        }
    }
    // Kill points spread over the whole run, and a few right at the start.
    let mut delays: Vec<Duration> = (1..=8).map(|k| full * k / 8).collect();
    delays.extend([0, 2, 5, 10, 20].map(Duration::from_millis));
    for (n, delay) in delays.into_iter().enumerate() {
        let o = dir.path().join(format!("killed-{n}"));
        for rel in complete.keys() {
            std::fs::create_dir_all(o.join(rel).parent().unwrap()).unwrap();
            std::fs::write(o.join(rel), OLD).unwrap();
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_mtcal"))
            .args(args(&o))
            .current_dir(repo())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(delay);
        let _ = child.kill(); // SIGKILL; an error means it had already finished
        let status = child.wait().unwrap();
        let after = snapshot(&o);
        for (rel, bytes) in &after {
            let name = rel.file_name().unwrap().to_string_lossy();
            if name.starts_with('.') && name.ends_with(".tmp") {
                // A killed write's temporary file: never the output itself.
                assert!(
                    !status.success(),
                    "{} left by a finished run",
                    rel.display()
                );
                continue;
            }
            let new = complete
                .get(rel)
                .unwrap_or_else(|| panic!("unexpected file {}", rel.display()));
            assert!(
                bytes == OLD || bytes == new,
                "{} is neither the old file nor the complete new one after a kill at {delay:?}",
                rel.display()
            );
        }
        for rel in complete.keys() {
            assert!(after.contains_key(rel), "{} vanished", rel.display());
        }
    }
}

/// `--predict` into the session's own folder would replace the validation run's recordings:
/// refused with exit code 2 before anything is written, and the session is unchanged.
#[test]
fn predictions_never_replace_the_sessions_own_files() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("session");
    std::fs::create_dir(&session).unwrap();
    for e in std::fs::read_dir(repo().join("examples/five-axis/session")).unwrap() {
        let p = e.unwrap().path();
        if p.is_file() {
            std::fs::copy(&p, session.join(p.file_name().unwrap())).unwrap();
        }
    }
    let before = snapshot(&session);
    let out = mtcal(&[
        "identify",
        session.to_str().unwrap(),
        "--quiet",
        "--predict",
        session.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let msg = String::from_utf8_lossy(&out.stderr);
    assert!(
        msg.contains("rtest-xyzac.csv") && msg.contains("would replace a run file"),
        "{msg}"
    );
    assert!(snapshot(&session) == before, "the session was modified");
}
