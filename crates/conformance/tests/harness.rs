//! The harness on tiny in-test plugins: a correct one passes, broken ones fail the right check.

use mtcal_conformance::{shipped_machines, try_check_plugin};
use mtcal_instrument::config::{self, Number, Vec3, required};
use mtcal_instrument::{
    At, Channel, Fixture, InstrumentPlugin, Nuisance, PathSpec, Setup, SetupContext, SetupError,
    SetupFormat, Unit,
};
use mtcal_kinematics::{AxisKind, Machine};
use serde::Deserialize;

/// A point probe: readings are the spindle ball centre minus a target point, plus a lever arm
/// on a small tilt nuisance.
#[derive(Debug)]
struct Probe {
    target_mm: [f64; 3],
    sigma_um: f64,
    fault: Fault,
    channels: Vec<Channel>,
    nuisance: Vec<Nuisance>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    None,
    Jacobian,
    Lenient,
    Offset,
}

const LEVER: f64 = 0.1;

impl Setup for Probe {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }
    fn nuisance(&self) -> &[Nuisance] {
        &self.nuisance
    }
    fn predict(&self, at: &At<'_>, nuis: &[f64], out: &mut [f64]) {
        let z = at.w_t_t.r.column(2);
        for i in 0..3 {
            out[i] = at.w_t_t.t[i] - nuis[3] * z[i] - (self.target_mm[i] * 1e-3 + nuis[i]);
        }
        out[2] += LEVER * nuis[4];
        if self.fault == Fault::Offset {
            out[0] += 1e-9;
        }
    }
    fn derivatives(
        &self,
        at: &At<'_>,
        nuis: &[f64],
        d_pose: &mut [f64],
        d_nuis: &mut [f64],
    ) -> bool {
        let z = at.w_t_t.r.column(2);
        let l = nuis[3];
        // δℓ·[z]×
        let zx = [
            [0.0, -z[2] * l, z[1] * l],
            [z[2] * l, 0.0, -z[0] * l],
            [-z[1] * l, z[0] * l, 0.0],
        ];
        for i in 0..3 {
            for j in 0..3 {
                d_pose[i * 6 + j] = if i == j { 1.0 } else { 0.0 };
                d_pose[i * 6 + 3 + j] = zx[i][j];
                d_nuis[i * 5 + j] = if i == j { -1.0 } else { 0.0 };
            }
            d_nuis[i * 5 + 3] = -z[i];
            d_nuis[i * 5 + 4] = if i == 2 { LEVER } else { 0.0 };
        }
        if self.fault == Fault::Jacobian {
            d_pose[3 + 1] *= -1.0;
            d_pose[3 + 1] += 1e-3;
        }
        true
    }
}

impl SetupFormat for Probe {
    fn to_toml(&self) -> toml::Table {
        let mut t = toml::Table::new();
        t.insert(
            "target".into(),
            toml::Value::Array(self.target_mm.iter().map(|&v| v.into()).collect()),
        );
        t.insert("sigma_um".into(), self.sigma_um.into());
        t
    }
}

/// The probe's set-up table. Without `deny_unknown_fields`, so that the lenient probe can read
/// it with [`config::read_part`], which lets unknown keys pass; [`config::read`] rejects them.
#[derive(Deserialize)]
struct ProbeKeys {
    target: Option<Vec3>,
    sigma_um: Option<Number>,
}

fn load(table: &toml::Table, fault: Fault) -> Result<Box<dyn Setup>, SetupError> {
    let keys: ProbeKeys = if fault == Fault::Lenient {
        config::read_part(table)?
    } else {
        config::read(table)?
    };
    let target_mm = required(keys.target, "target", "the target point, mm")?.0;
    let sigma_um = keys.sigma_um.map_or(1.0, f64::from);
    let um = |name: &str| Nuisance {
        name: name.into(),
        unit: Unit::Um,
        free: true,
        prior_sigma: None,
    };
    Ok(Box::new(Probe {
        target_mm,
        sigma_um,
        fault,
        channels: ["ex", "ey", "ez"]
            .iter()
            .map(|n| Channel {
                name: (*n).into(),
                unit: Unit::Um,
                sigma: sigma_um * 1e-6,
            })
            .collect(),
        nuisance: vec![
            um("p_x"),
            um("p_y"),
            um("p_z"),
            um("tool_length"),
            Nuisance {
                name: "tilt".into(),
                unit: Unit::Urad,
                free: false,
                prior_sigma: Some(1e-5),
            },
        ],
    }))
}

fn fixture(machine: &Machine, seed: u64) -> Option<Fixture> {
    if machine.axes().iter().all(|a| a.kind() == AxisKind::Linear) && seed % 2 == 1 {
        return None;
    }
    let q: Vec<f64> = machine
        .axes()
        .iter()
        .map(|a| match (a.kind(), a.limits()) {
            (AxisKind::Linear, Some((lo, hi))) => lo + (hi - lo) * (0.3 + 0.05 * seed as f64),
            _ => 0.0,
        })
        .collect();
    let p = machine.tool_in_workpiece(&q).t * 1e3;
    let mut setup = toml::Table::new();
    setup.insert(
        "target".into(),
        toml::Value::Array(vec![p.x.into(), p.y.into(), p.z.into()]),
    );
    Some(Fixture {
        setup,
        poses: vec![q.clone(), q],
        labels: Vec::new(),
    })
}

fn no_path(_: &PathSpec<'_>) -> Result<Vec<Vec<f64>>, SetupError> {
    Err(SetupError::new("path", "no paths"))
}

macro_rules! dummy {
    ($name:literal, $fault:expr) => {
        inventory::submit! {
            InstrumentPlugin {
                name: $name,
                about: "a test probe",
                load_setup: |t: &toml::Table, _: &SetupContext<'_>| load(t, $fault),
                fixture,
                path: no_path,
                path_labels: None,
                evaluate: None,
                polar_view: None,
                diagnose: None,
                planning: None,
            }
        }
    };
}

dummy!("dummy", Fault::None);
dummy!("dummy-bad-jacobian", Fault::Jacobian);
dummy!("dummy-lenient", Fault::Lenient);
dummy!("dummy-offset", Fault::Offset);

#[test]
fn shipped_machines_load() {
    let ms = shipped_machines();
    assert!(ms.len() >= 6, "{}", ms.len());
    assert!(ms.iter().any(|(n, _)| n == "mcu630-cafyxz"));
    let mut names: Vec<&str> = ms.iter().map(|(n, _)| n.as_str()).collect();
    let unsorted = names.clone();
    names.sort();
    assert_eq!(names, unsorted);
}

#[test]
fn a_correct_plugin_passes() {
    let report = try_check_plugin("dummy", 3).unwrap_or_else(|f| panic!("{f}"));
    assert_eq!(report.machines.len(), shipped_machines().len());
    // Machines without a rotary axis get a fixture on even seeds only.
    let linear_only = shipped_machines()
        .iter()
        .filter(|(_, m)| m.axes().iter().all(|a| a.kind() == AxisKind::Linear))
        .count();
    assert_eq!(report.fixtures, 3 * shipped_machines().len() - linear_only);
    assert_eq!(report.without_analytic, 0);
    mtcal_conformance::check_plugin("dummy", 2);
}

#[test]
fn a_wrong_jacobian_fails_naming_channel_and_column() {
    let f = try_check_plugin("dummy-bad-jacobian", 1).unwrap_err();
    assert_eq!(f.check, "jacobian", "{f}");
    assert_eq!(f.seed, Some(0));
    let msg = f.to_string();
    assert!(msg.contains("plugin `dummy-bad-jacobian`"), "{msg}");
    assert!(msg.contains("channel `ex`"), "{msg}");
    assert!(msg.contains("δθ_y"), "{msg}");
    assert!(msg.contains("machine `"), "{msg}");
}

#[test]
#[should_panic(expected = "check `jacobian` failed")]
fn check_plugin_panics_on_a_wrong_jacobian() {
    mtcal_conformance::check_plugin("dummy-bad-jacobian", 1);
}

#[test]
fn an_unknown_key_must_be_rejected() {
    let f = try_check_plugin("dummy-lenient", 1).unwrap_err();
    assert_eq!(f.check, "rejection", "{f}");
    assert!(f.detail.contains("conformance_unknown_key"), "{f}");
}

#[test]
fn nonzero_readings_on_the_fixture_fail() {
    let f = try_check_plugin("dummy-offset", 1).unwrap_err();
    assert_eq!(f.check, "zero residual", "{f}");
    assert!(f.detail.contains("channel `ex`"), "{f}");
}

#[test]
fn an_unregistered_name_fails() {
    let f = try_check_plugin("no-such-instrument", 1).unwrap_err();
    assert_eq!(f.check, "registered");
    assert!(f.detail.contains("dummy"), "{f}");
}
