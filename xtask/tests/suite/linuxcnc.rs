//! LinuxCNC loads the compensation file mtcal writes, and its motion controller applies what
//! mtcal meant: a simulated LinuxCNC (Debian `linuxcnc-uspace`, non-realtime) with
//! `COMP_FILE_TYPE = 1` on joint 0 is homed, moved to positions approached from below and from
//! above, and the correction it computes from the file for the direction of travel
//! (`joint.0.backlash-corr`; on forward approaches also the trim it adds,
//! `joint.0.motor-pos-cmd − joint.0.pos-cmd`) is compared with the forward and reverse
//! compensations mtcal's table gives there.
//!
//! A second test loads mtcal's rotary pivot parameters into LinuxCNC's `xyzac-trt-kins`
//! (table-table five-axis kinematics), commands workpiece poses, and checks with mtcal's model
//! that the joint positions LinuxCNC's own inverse kinematics chose put the tool where the
//! program meant.
//!
//! Skipped, with a message, where LinuxCNC is not installed (CI installs it: `.ci/run`).

use mtcal_testkit::cli::{assert_success, on_three_axis_example, run_in_repo};
use std::path::Path;
use std::process::Command;

fn mtcal(args: &[&str]) -> std::process::Output {
    run_in_repo(env!("CARGO_BIN_EXE_mtcal"), args)
}

fn has(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// A millimetre machine with LinuxCNC's simulated servo loops and the probe script as its user
/// interface; `[HAL]`, `[TRAJ]` and `[KINS]` follow.
const INI: &str = "\
[EMC]
VERSION = 1.1
MACHINE = mtcal-comp-test
[DISPLAY]
DISPLAY = ./probe.py
[TASK]
TASK = milltask
CYCLE_TIME = 0.001
[RS274NGC]
PARAMETER_FILE = sim.var
[EMCIO]
EMCIO = io
CYCLE_TIME = 0.100
[EMCMOT]
EMCMOT = motmod
SERVO_PERIOD = 1000000
[HAL]
HALFILE = LIB:basic_sim.tcl
";

/// Three joints, trivial kinematics, `x.comp` on joint 0.
const TRIVKINS: &str = "\
[TRAJ]
COORDINATES = XYZ
LINEAR_UNITS = mm
ANGULAR_UNITS = degree
MAX_LINEAR_VELOCITY = 500
[KINS]
JOINTS = 3
KINEMATICS = trivkins coordinates=XYZ
";

/// Five joints, LinuxCNC's table-table kinematics, pivots from mtcal's `pivots.hal`.
const TRT: &str = "\
HALFILE = pivots.hal
[TRAJ]
COORDINATES = XYZAC
LINEAR_UNITS = mm
ANGULAR_UNITS = degree
MAX_LINEAR_VELOCITY = 500
[KINS]
JOINTS = 5
KINEMATICS = xyzac-trt-kins
";

fn axis_and_joint(n: usize, letter: char, comp: bool) -> String {
    let limits =
        "MIN_LIMIT = -2000\nMAX_LIMIT = 2000\nMAX_VELOCITY = 500\nMAX_ACCELERATION = 5000\n";
    let kind = if "ABC".contains(letter) {
        "ANGULAR"
    } else {
        "LINEAR"
    };
    let comp = if comp {
        "COMP_FILE = x.comp\nCOMP_FILE_TYPE = 1\n"
    } else {
        ""
    };
    format!(
        "[AXIS_{letter}]\n{limits}[JOINT_{n}]\nTYPE = {kind}\n{limits}HOME_SEQUENCE = 0\n\
         HOME_SEARCH_VEL = 0\nHOME_LATCH_VEL = 0\nHOME = 0\n{comp}"
    )
}

/// The user interface LinuxCNC starts, around a test's `moves` (Python, run in MDI mode after
/// enabling and homing — at once: search velocity 0): `getp` reads a HAL pin as the double
/// itself (halcmd getp prints only 7 significant digits; it needs a HAL component of this
/// process), `out` is `result.txt`, which ends with `done` when everything ran. LinuxCNC shuts
/// down when the script exits.
fn probe(moves: &str) -> String {
    const START: &str = r#"#!/usr/bin/python3
import hal, linuxcnc, time
me = hal.component("mtcalprobe"); me.ready()
def getp(p):
    return float(hal.get_value(p))
s = linuxcnc.stat(); c = linuxcnc.command()
out = open("result.txt", "w")
try:
    c.state(linuxcnc.STATE_ESTOP_RESET); c.wait_complete()
    c.state(linuxcnc.STATE_ON); c.wait_complete()
    c.mode(linuxcnc.MODE_MANUAL); c.wait_complete()
    c.home(-1); c.wait_complete()
    for _ in range(400):
        s.poll()
        if all(j["homed"] for j in s.joint[:s.joints]): break
        time.sleep(0.05)
    c.mode(linuxcnc.MODE_MDI); c.wait_complete()
"#;
    const END: &str = r#"    out.write("done\n")
except Exception as e:
    out.write("error %s\n" % e)
out.close()
"#;
    format!("{START}{moves}{END}")
}

/// For each position, approach it from 20 mm below ("fwd") and from 20 mm above ("rev") and
/// record the commanded joint position, the motor command and the computed correction.
const PROBE_MOVES: &str = r#"    for x in [float(v) for v in open("positions.txt").read().split()]:
        for approach, tag in [(-1.0, "fwd"), (1.0, "rev")]:
            c.mdi("G90 G0 X%.6f" % (x + 20.0 * approach)); c.wait_complete()
            c.mdi("G90 G0 X%.6f" % x); c.wait_complete()
            time.sleep(0.05)
            out.write("%s %.6f %.12f %.12f %.12f\n" % (tag, x, getp("joint.0.pos-cmd"), getp("joint.0.motor-pos-cmd"), getp("joint.0.backlash-corr")))
"#;

#[test]
fn linuxcnc_applies_the_compensation_mtcal_writes() {
    if !linuxcnc_here() {
        return;
    }
    let dir = config_dir();
    let root = dir.path();

    let comp = root.join("x.comp");
    let mut args: Vec<&str> = "--axis X --format linuxcnc --spacing-mm 30 --reversal-um -2.5 --out"
        .split_whitespace()
        .collect();
    args.push(comp.to_str().unwrap());
    let out = mtcal(&on_three_axis_example("compensate", &args));
    assert_success(&out);
    let table = mtcal_compensate::read_linuxcnc_comp(&comp, 'X').unwrap();
    let largest = table.forward_um.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(largest > 1.0, "compensation {largest} µm too small to test");

    // Nodes, points between nodes, and the ends.
    let positions = [
        -270.0, -241.7, -150.0, -12.3, 0.0, 45.0, 101.1, 239.99, 270.0,
    ];
    let text: Vec<String> = positions.iter().map(|p| format!("{p}")).collect();
    std::fs::write(root.join("positions.txt"), text.join(" ")).unwrap();
    let ini = format!(
        "{INI}{TRIVKINS}{}{}{}",
        axis_and_joint(0, 'X', true),
        axis_and_joint(1, 'Y', false),
        axis_and_joint(2, 'Z', false)
    );
    let result = run_linuxcnc(root, &ini, &probe(PROBE_MOVES));

    let mut checked = 0;
    let mut worst_um: f64 = 0.0;
    for line in result.lines().filter(|l| *l != "done") {
        let f: Vec<&str> = line.split_whitespace().collect();
        let (tag, x): (&str, f64) = (f[0], f[1].parse().unwrap());
        let pos_cmd: f64 = f[2].parse().unwrap();
        let motor: f64 = f[3].parse().unwrap();
        let corr: f64 = f[4].parse().unwrap();
        assert!((pos_cmd - x).abs() < 1e-6, "{line}");
        // `backlash-corr` is the correction LinuxCNC computes from the file for the direction
        // of travel; `motor-pos-cmd − pos-cmd` what it applies. The applied value follows the
        // computed one through a velocity- and acceleration-limited ramp (`backlash-filt`),
        // which in this simulation stalls part-way after a reversal: so the applied trim is
        // checked on forward approaches only.
        let trim_um = corr * 1e3;
        if tag == "fwd" {
            let applied_um = (motor - pos_cmd) * 1e3;
            assert!(
                (applied_um - trim_um).abs() < 1e-6,
                "applied {applied_um} µm: {line}"
            );
        }
        let travel = match tag {
            "fwd" => mtcal_compensate::Travel::Forward,
            _ => mtcal_compensate::Travel::Reverse,
        };
        let want_um = table.correction_at_um(x, travel);
        // The file holds 9 decimals of mm (1 pm); LinuxCNC interpolates linearly as mtcal does.
        worst_um = worst_um.max((trim_um - want_um).abs());
        assert!(
            (trim_um - want_um).abs() < 1e-3,
            "{tag} at {x} mm: LinuxCNC computes {trim_um} µm, mtcal's table says {want_um} µm"
        );
        checked += 1;
    }
    assert_eq!(checked, 2 * positions.len());
    eprintln!("LinuxCNC applied mtcal's table at {checked} positions, worst {worst_um:.1e} µm");
}

fn linuxcnc_here() -> bool {
    let here = has("linuxcnc") && has("script");
    if !here {
        eprintln!(
            "skipped: LinuxCNC is not installed here (Debian package linuxcnc-uspace; CI \
             installs it)"
        );
    }
    here
}

/// A folder for a LinuxCNC configuration. rtapi_app drops root to RTAPI_UID and makes its FIFO
/// in the folder: let it write there.
fn config_dir() -> tempfile::TempDir {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o777)).unwrap();
    dir
}

/// Runs LinuxCNC on `ini` in `root` with `probe` as its user interface; returns what the probe
/// wrote to `result.txt` (which must end with `done`).
fn run_linuxcnc(root: &Path, ini: &str, probe: &str) -> String {
    use std::os::unix::fs::PermissionsExt;
    // One LinuxCNC at a time: instances share HAL and NML shared memory.
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    std::fs::write(root.join("test.ini"), ini).unwrap();
    let path = root.join("probe.py");
    std::fs::write(&path, probe).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    // `linuxcnc` writes its console to a log unless it has a terminal: `script` gives it one.
    let mut cmd = Command::new("timeout");
    cmd.args(["180", "script", "-qec", "linuxcnc test.ini", "/dev/null"])
        .current_dir(root)
        .env("RTAPI_FIFO_PATH", root.join(".rtapi_fifo"))
        .env_remove("DISPLAY");
    if is_root() {
        cmd.env("RTAPI_UID", "65534");
    }
    let run = cmd.output().unwrap();
    let console = String::from_utf8_lossy(&run.stdout);
    let result = std::fs::read_to_string(root.join("result.txt")).unwrap_or_default();
    assert!(
        result.ends_with("done\n"),
        "LinuxCNC did not finish the probe.\nresult:\n{result}\nconsole:\n{console}"
    );
    result
}

/// Move to each workpiece pose of `poses.txt` (X Y Z A C per line, mm and LinuxCNC's degrees)
/// and record the joint positions LinuxCNC's inverse kinematics give.
const TRT_MOVES: &str = r#"    for line in open("poses.txt"):
        w = [float(v) for v in line.split()]
        c.mdi("G90 G0 X%.6f Y%.6f Z%.6f A%.6f C%.6f" % tuple(w)); c.wait_complete()
        time.sleep(0.05)
        joints = [getp("joint.%d.pos-cmd" % i) for i in range(5)]
        out.write("%s %s\n" % (line.strip(), " ".join("%.12f" % v for v in joints)))
"#;

#[test]
fn linuxcnc_trt_kinematics_with_mtcal_pivots_put_the_tool_where_the_model_says() {
    if !linuxcnc_here() {
        return;
    }
    let dir = config_dir();
    let root = dir.path();
    // A machine whose errors are all ones these kinematics hold: where the C and A lines pass.
    let params = root.join("pivots.params.toml");
    std::fs::write(
        &params,
        "schema = \"mtcal.params/1\"\n[values]\nEX0C = 35.0\nEY0C = -22.0\nEY0A = 41.0\nEZ0A = -18.0\n",
    )
    .unwrap();
    let machine = "machines/mcu630-cafyxz.urdf";
    let out = mtcal(&[
        "compensate",
        machine,
        "--params",
        params.to_str().unwrap(),
        "--format",
        "linuxcnc-trt",
        "--out",
        root.join("pivots.hal").to_str().unwrap(),
    ]);
    assert_success(&out);
    // Workpiece poses (mm, LinuxCNC degrees: mtcal's angles negated).
    let poses = [
        [10.0, 20.0, -100.0, 30.0, 45.0],
        [-50.0, 80.0, -200.0, -20.0, 170.0],
        [120.0, -60.0, -150.0, -90.0, -35.0],
        [0.0, 0.0, -50.0, 10.0, 270.0],
    ];
    let text: Vec<String> = poses
        .iter()
        .map(|p| p.map(|v| v.to_string()).join(" "))
        .collect();
    std::fs::write(root.join("poses.txt"), text.join("\n") + "\n").unwrap();
    let ini = format!(
        "{INI}{TRT}{}{}{}{}{}",
        axis_and_joint(0, 'X', false),
        axis_and_joint(1, 'Y', false),
        axis_and_joint(2, 'Z', false),
        axis_and_joint(3, 'A', false),
        axis_and_joint(4, 'C', false)
    );
    let result = run_linuxcnc(root, &ini, &probe(TRT_MOVES));

    // mtcal's model of the machine at the joints LinuxCNC chose.
    let loaded = mtcal_machine::load_machine(
        mtcal_testkit::repo().join(machine).to_str().unwrap(),
        mtcal_machine::topology::Reading::FromWorkpiece,
    )
    .unwrap();
    let model = mtcal_kinematics::MachineModel::new(loaded.machine, &loaded.config).unwrap();
    let coeffs = mtcal_machine::params::load_params(&params, model.errors()).unwrap();
    let m = model.machine();
    let idx = ['X', 'Y', 'Z', 'A', 'C'].map(|l| m.axis_index(l).unwrap());
    let origin = m.tool_in_workpiece(&vec![0.0; m.n_axes()]).t;
    let mut ws = model.workspace();
    let (mut worst, mut moved) = (0.0f64, 0.0f64);
    let mut checked = 0;
    for line in result.lines().filter(|l| *l != "done") {
        let v: Vec<f64> = line
            .split_whitespace()
            .map(|f| f.parse().unwrap())
            .collect();
        let (w, j) = (&v[..5], &v[5..]);
        let mut q = vec![0.0; m.n_axes()];
        for k in 0..3 {
            q[idx[k]] = j[k] * 1e-3;
        }
        q[idx[3]] = -j[3].to_radians();
        q[idx[4]] = -j[4].to_radians();
        let tool = (model.tool_pose(&q, &coeffs, &mut ws).t - origin) * 1e3;
        let nominal = (m.tool_in_workpiece(&q).t - origin) * 1e3;
        let err =
            ((tool[0] - w[0]).powi(2) + (tool[1] - w[1]).powi(2) + (tool[2] - w[2]).powi(2)).sqrt();
        worst = worst.max(err);
        moved = moved.max((tool - nominal).norm());
        checked += 1;
    }
    assert_eq!(checked, poses.len());
    eprintln!(
        "LinuxCNC xyzac-trt-kins with mtcal's pivots: tool {worst:.1e} mm from the programmed \
         point by mtcal's model (the pivots moved it by up to {moved:.3} mm)"
    );
    assert!(worst < 1e-6, "{worst} mm");
    assert!(
        moved > 0.02,
        "the identified pivots must matter: {moved} mm"
    );
}

/// Whether this process runs as root (rtapi_app then needs a user to drop to).
fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}
