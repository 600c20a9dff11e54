//! The instrument and fixture bodies of a run (each instrument's own, from its plugin), and the
//! collision check of a pose.

use crate::geometry::{Carrier, MachineGeometry, Solid, signed_distance};
use crate::sizes::GeometryConfig;
use crate::tooled::tooled_machine;
use mtcal_instrument::collision::BodySpec;
use mtcal_instrument::{InstrumentPlugin, Setup, SetupContext};
use mtcal_kinematics::rigid::Rigid;
use mtcal_kinematics::{Machine, Side};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

pub use mtcal_instrument::collision::{Bodies, InstrumentBody, Mount};

/// The bodies of one set-up table of `instrument` and the pairs of them that touch by design,
/// from the instrument's own [`Planning::bodies`](mtcal_instrument::collision::Planning::bodies) hook: the set-up is loaded through its plugin
/// on the plan's machine (`nominal` with the tool point `tool_length` m down the tool axis).
/// `Ok(None)` for an instrument without collision geometry (it is then checked for nothing;
/// the report says so); `Err` says why the set-up or its bodies could not be made.
pub fn instrument_bodies(
    instrument: &str,
    setup: &toml::Table,
    tool_length: f64,
    nominal: &Machine,
    g: &GeometryConfig,
) -> Result<Option<Bodies>, String> {
    let plugin =
        mtcal_plugins::find(instrument).ok_or_else(|| mtcal_plugins::unknown(instrument))?;
    let tooled = tooled_machine(nominal, tool_length)?;
    let loaded = (plugin.load_setup)(setup, &SetupContext { machine: &tooled })
        .map_err(|e| format!("set-up: {e}"))?;
    bodies_of(plugin, &*loaded, setup, tool_length, nominal, g)
}

/// [`instrument_bodies`] of a set-up `plugin` has loaded (`loaded`, on `nominal` with the tool
/// point `tool_length` m down the tool axis; `table` its table as planned).
pub fn bodies_of(
    plugin: &InstrumentPlugin,
    loaded: &dyn Setup,
    table: &toml::Table,
    tool_length: f64,
    nominal: &Machine,
    g: &GeometryConfig,
) -> Result<Option<Bodies>, String> {
    let Some(bodies) = plugin.planning.and_then(|p| p.bodies) else {
        return Ok(None);
    };
    bodies(&BodySpec {
        setup: loaded,
        table,
        tool_length,
        machine: nominal,
        tool_side: &g.tool_side(),
        sizes: g.sizes(),
    })
    .map_err(|e| format!("collision bodies: {e}"))
}

/// One collision found at a pose.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Hit {
    pub a: String,
    pub b: String,
    /// Signed distance, mm (negative: overlap).
    pub distance_mm: f64,
}

/// Everything a pose is checked against: the machine's bodies and one set-up's.
#[derive(Debug)]
pub struct Scene<'a> {
    /// The machine as loaded (the URDF's links hang on its joints).
    pub nominal: &'a Machine,
    /// The machine whose tool point is the instrument's ball (the nominal one with the tool
    /// length added); the plan's poses are its poses.
    pub tooled: &'a Machine,
    pub geometry: &'a MachineGeometry,
    pub instrument: Vec<InstrumentBody>,
    /// Instrument body pairs that touch by design.
    pub allowed: Vec<(String, String)>,
    /// Pairs closer than this (m) collide.
    pub clearance: f64,
    solids_m: Vec<Solid>,
    solids_i: Vec<Solid>,
}

impl<'a> Scene<'a> {
    pub fn new(
        nominal: &'a Machine,
        tooled: &'a Machine,
        geometry: &'a MachineGeometry,
        instrument: Vec<InstrumentBody>,
        allowed: Vec<(String, String)>,
        clearance: f64,
    ) -> Self {
        let solids_m = geometry
            .bodies
            .iter()
            .map(|b| Solid::new(&b.primitive))
            .collect();
        let solids_i = instrument
            .iter()
            .map(|b| Solid::new(&b.primitive))
            .collect();
        Scene {
            nominal,
            tooled,
            geometry,
            instrument,
            allowed,
            clearance,
            solids_m,
            solids_i,
        }
    }

    fn allowed(&self, a: &str, b: &str) -> bool {
        self.allowed
            .iter()
            .any(|(x, y)| (x == a && y == b) || (x == b && y == a))
    }

    /// Every pair closer than the clearance at axis positions `q` (the sample's label decides
    /// which artefact placement is on the table).
    pub fn check(&self, q: &[f64], label: Option<&str>) -> Result<Vec<Hit>, String> {
        let m = self.nominal;
        let mpose: Vec<Rigid> = (0..self.geometry.bodies.len())
            .map(|k| self.geometry.body_pose(m, k, q))
            .collect();
        let f_t_w = m.branch_pose(Side::Workpiece, q);
        let f_t_t = self.tooled.branch_pose(Side::Tool, q);
        let present = |b: &InstrumentBody| match (&b.only_label, label) {
            (Some(prefix), Some(l)) => l.starts_with(prefix.as_str()),
            _ => true,
        };
        let ipose: Vec<Option<Rigid>> = self
            .instrument
            .iter()
            .map(|b| present(b).then(|| self.instrument_pose(b, &f_t_w, &f_t_t)))
            .collect();
        let mut hits = Vec::new();
        let mut test = |a: &str, sa: &Solid, pa: &Rigid, b: &str, sb: &Solid, pb: &Rigid| {
            if let Some(d) = signed_distance(sa, pa, sb, pb, self.clearance)? {
                if d < self.clearance {
                    hits.push(Hit {
                        a: a.to_string(),
                        b: b.to_string(),
                        distance_mm: d * 1e3,
                    });
                }
            }
            Ok::<(), String>(())
        };
        let bodies = &self.geometry.bodies;
        for i in 0..bodies.len() {
            for j in i + 1..bodies.len() {
                if MachineGeometry::pair_checked(m, bodies[i].carrier, bodies[j].carrier) {
                    test(
                        &bodies[i].name,
                        &self.solids_m[i],
                        &mpose[i],
                        &bodies[j].name,
                        &self.solids_m[j],
                        &mpose[j],
                    )?;
                }
            }
        }
        let tool_mount = Carrier::end_of(m, Side::Tool);
        let wp_mount = Carrier::end_of(m, Side::Workpiece);
        for (i, b) in self.instrument.iter().enumerate() {
            let Some(pi) = &ipose[i] else { continue };
            for (j, mb) in bodies.iter().enumerate() {
                let skip = match b.mount {
                    Mount::Tool => mb.carrier == tool_mount,
                    Mount::Workpiece => mb.carrier == wp_mount,
                    Mount::Bar { .. } => false,
                };
                if !skip {
                    test(
                        &b.name,
                        &self.solids_i[i],
                        pi,
                        &mb.name,
                        &self.solids_m[j],
                        &mpose[j],
                    )?;
                }
            }
            for (j, c) in self.instrument.iter().enumerate().skip(i + 1) {
                let Some(pj) = &ipose[j] else { continue };
                let same = matches!(
                    (&b.mount, &c.mount),
                    (Mount::Tool, Mount::Tool) | (Mount::Workpiece, Mount::Workpiece)
                );
                if !same && !self.allowed(&b.name, &c.name) {
                    test(
                        &b.name,
                        &self.solids_i[i],
                        pi,
                        &c.name,
                        &self.solids_i[j],
                        pj,
                    )?;
                }
            }
        }
        Ok(hits)
    }

    /// `frame_T_shape` of an instrument body.
    fn instrument_pose(&self, b: &InstrumentBody, f_t_w: &Rigid, f_t_t: &Rigid) -> Rigid {
        match &b.mount {
            Mount::Tool => f_t_t.compose(&b.offset),
            Mount::Workpiece => f_t_w.compose(&b.offset),
            Mount::Bar { pivot, .. } => {
                let p = f_t_w.apply(pivot);
                let t = f_t_t.t;
                let d = t - p;
                let z = if d.norm() > 1e-12 {
                    d / d.norm()
                } else {
                    Vector3::z()
                };
                Rigid::new(frame_with_z(&z), 0.5 * (p + t))
            }
        }
    }
}

/// A rotation whose third column is the unit vector `z`.
fn frame_with_z(z: &Vector3<f64>) -> Matrix3<f64> {
    let helper = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let x = helper.cross(z).normalize();
    let y = z.cross(&x);
    Matrix3::from_columns(&[x, y, *z])
}
