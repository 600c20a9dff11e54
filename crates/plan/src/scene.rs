//! The instrument and fixture bodies of a run, and the collision check of a pose.

use crate::geometry::{Carrier, MachineGeometry, Primitive, Solid, at, signed_distance};
use mtcal_kinematics::rigid::Rigid;
use mtcal_kinematics::{Machine, Side};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Sizes of the instruments and fixtures, mm (the planning file's `[geometry]`; every key has
/// a default).
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct GeometryConfig {
    /// Where fixtures stand: the table top's z in the workpiece frame.
    pub table_z_mm: f64,
    /// Tool side: the holder (a cylinder up to the gauge point) and the stem below it.
    pub holder_diameter_mm: f64,
    pub holder_length_mm: f64,
    pub stem_diameter_mm: f64,
    /// R-test: the ball, the head (nest) and the post on the table. `mount = "ball-on-table"`
    /// (the default): the ball on the post, the head hanging from the holder above it;
    /// `"ball-in-spindle"`: the ball on the stem, the head below it on the post.
    pub rtest_ball_diameter_mm: f64,
    pub rtest_head_diameter_mm: f64,
    pub rtest_head_height_mm: f64,
    /// How far the head's near face lies from the ball centre (its bottom above it in the
    /// spindle, its top below it on the table).
    pub rtest_head_gap_mm: f64,
    pub rtest_post_diameter_mm: f64,
    /// Ball-bar: both balls, the bar (a capsule between them, shortened at each end by the
    /// cup), the pivot's post.
    pub ballbar_ball_diameter_mm: f64,
    pub ballbar_bar_diameter_mm: f64,
    pub ballbar_cup_mm: f64,
    pub ballbar_post_diameter_mm: f64,
    /// Artefact: the probe ball, the plate (features' outline plus margin, this thick below
    /// the feature plane).
    pub probe_ball_diameter_mm: f64,
    pub plate_margin_mm: f64,
    pub plate_thickness_mm: f64,
}

impl Default for GeometryConfig {
    fn default() -> Self {
        GeometryConfig {
            table_z_mm: 0.0,
            holder_diameter_mm: 50.0,
            holder_length_mm: 60.0,
            stem_diameter_mm: 8.0,
            rtest_ball_diameter_mm: 22.0,
            rtest_head_diameter_mm: 70.0,
            rtest_head_height_mm: 50.0,
            rtest_head_gap_mm: 8.0,
            rtest_post_diameter_mm: 30.0,
            ballbar_ball_diameter_mm: 12.7,
            ballbar_bar_diameter_mm: 16.0,
            ballbar_cup_mm: 20.0,
            ballbar_post_diameter_mm: 16.0,
            probe_ball_diameter_mm: 6.0,
            plate_margin_mm: 15.0,
            plate_thickness_mm: 20.0,
        }
    }
}

impl GeometryConfig {
    /// Every size must be finite and positive (`table_z_mm` finite).
    pub fn check(&self) -> Result<(), String> {
        let sizes = [
            ("holder_diameter_mm", self.holder_diameter_mm),
            ("holder_length_mm", self.holder_length_mm),
            ("stem_diameter_mm", self.stem_diameter_mm),
            ("rtest_ball_diameter_mm", self.rtest_ball_diameter_mm),
            ("rtest_head_diameter_mm", self.rtest_head_diameter_mm),
            ("rtest_head_height_mm", self.rtest_head_height_mm),
            ("rtest_post_diameter_mm", self.rtest_post_diameter_mm),
            ("ballbar_ball_diameter_mm", self.ballbar_ball_diameter_mm),
            ("ballbar_bar_diameter_mm", self.ballbar_bar_diameter_mm),
            ("ballbar_post_diameter_mm", self.ballbar_post_diameter_mm),
            ("probe_ball_diameter_mm", self.probe_ball_diameter_mm),
            ("plate_thickness_mm", self.plate_thickness_mm),
        ];
        for (k, v) in sizes {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("[geometry] `{k}` must be > 0, found {v}"));
            }
        }
        for (k, v) in [
            ("table_z_mm", self.table_z_mm),
            ("rtest_head_gap_mm", self.rtest_head_gap_mm),
            ("ballbar_cup_mm", self.ballbar_cup_mm),
            ("plate_margin_mm", self.plate_margin_mm),
        ] {
            if !v.is_finite() {
                return Err(format!(
                    "[geometry] `{k}` must be a finite number, found {v}"
                ));
            }
        }
        Ok(())
    }
}

/// An instrument's bodies and the pairs of them that touch by design.
pub type Bodies = (Vec<InstrumentBody>, Vec<(String, String)>);

/// Where an instrument body is attached.
#[derive(Clone, Debug, PartialEq)]
pub enum Mount {
    /// The tool point of the tooled machine (offset in the tool frame; +z into the spindle).
    Tool,
    /// The workpiece frame.
    Workpiece,
    /// A bar from a point fixed in the workpiece frame to the tool point, shortened by `trim`
    /// at each end.
    Bar { pivot: Vector3<f64>, trim: f64 },
}

/// One body of an instrument or fixture.
#[derive(Clone, Debug, PartialEq)]
pub struct InstrumentBody {
    pub name: String,
    pub mount: Mount,
    /// `mount_T_shape` (unused for a bar).
    pub offset: Rigid,
    pub primitive: Primitive,
    /// Only present at the samples whose label starts with this (an artefact placement).
    pub only_label: Option<String>,
}

/// A vertical cylinder (workpiece frame) from `z0` to `z1` at `(x, y)`; `None` if empty.
fn column(name: &str, x: f64, y: f64, z0: f64, z1: f64, radius: f64) -> Option<InstrumentBody> {
    (z1 - z0 > 1e-9).then(|| InstrumentBody {
        name: name.into(),
        mount: Mount::Workpiece,
        offset: at(Vector3::new(x, y, 0.5 * (z0 + z1))),
        primitive: Primitive::Cylinder {
            radius,
            half_length: 0.5 * (z1 - z0),
        },
        only_label: None,
    })
}

/// The tool side: a ball at the tool point, a stem from the ball's top up to the holder, the
/// holder up to the gauge point `tool_length` above the tool point.
fn tool_side(
    ball_name: &str,
    ball_radius: f64,
    tool_length: f64,
    g: &GeometryConfig,
) -> Vec<InstrumentBody> {
    let mm = 1e-3;
    let mut out = vec![InstrumentBody {
        name: ball_name.into(),
        mount: Mount::Tool,
        offset: Rigid::IDENTITY,
        primitive: Primitive::Sphere {
            radius: ball_radius,
        },
        only_label: None,
    }];
    let holder_start = (tool_length - g.holder_length_mm * mm).max(0.0);
    let mut piece = |name: &str, z0: f64, z1: f64, radius: f64| {
        if z1 - z0 > 1e-9 {
            out.push(InstrumentBody {
                name: name.into(),
                mount: Mount::Tool,
                offset: at(Vector3::new(0.0, 0.0, 0.5 * (z0 + z1))),
                primitive: Primitive::Cylinder {
                    radius,
                    half_length: 0.5 * (z1 - z0),
                },
                only_label: None,
            });
        }
    };
    piece(
        "stem",
        ball_radius,
        holder_start,
        0.5 * g.stem_diameter_mm * mm,
    );
    piece(
        "holder",
        holder_start.max(ball_radius),
        tool_length,
        0.5 * g.holder_diameter_mm * mm,
    );
    out
}

fn vec3(t: &toml::Table, key: &str) -> Option<Vector3<f64>> {
    let a = t.get(key)?.as_array()?;
    let v: Vec<f64> = a
        .iter()
        .filter_map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64)))
        .collect();
    (v.len() == 3 && a.len() == 3).then(|| Vector3::new(v[0], v[1], v[2]) * 1e-3)
}

fn num(t: &toml::Table, key: &str) -> Option<f64> {
    let v = t.get(key)?;
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}

/// The bodies of one set-up of `instrument` and the pairs of them that touch by design.
/// `None` for an instrument without collision geometry here (it is then checked for nothing;
/// the report says so). The set-up table has already loaded through its plugin.
pub fn instrument_bodies(
    instrument: &str,
    setup: &toml::Table,
    tool_length: f64,
    nominal: &Machine,
    g: &GeometryConfig,
) -> Option<Bodies> {
    let mm = 1e-3;
    let table_z = g.table_z_mm * mm;
    match instrument {
        "rtest" if setup.get("mount").and_then(|v| v.as_str()) != Some("ball-in-spindle") => {
            // Ball on the table (the plugin's default mount): the ball on its post, the head
            // hanging from the holder, its bottom `gap` above the ball centre, and a stem from
            // the head's top up to the holder.
            let b = vec3(setup, "ball")?;
            let r = 0.5 * g.rtest_ball_diameter_mm * mm;
            let mut bodies = vec![InstrumentBody {
                name: "rtest ball".into(),
                mount: Mount::Workpiece,
                offset: at(b),
                primitive: Primitive::Sphere { radius: r },
                only_label: None,
            }];
            bodies.extend(column(
                "rtest post",
                b.x,
                b.y,
                table_z,
                b.z - r,
                0.5 * g.rtest_post_diameter_mm * mm,
            ));
            let head_bottom = g.rtest_head_gap_mm * mm;
            let head_top = head_bottom + g.rtest_head_height_mm * mm;
            let holder_start = (tool_length - g.holder_length_mm * mm).max(head_top);
            for (name, z0, z1, radius) in [
                (
                    "rtest head",
                    head_bottom,
                    head_top,
                    0.5 * g.rtest_head_diameter_mm,
                ),
                ("stem", head_top, holder_start, 0.5 * g.stem_diameter_mm),
                (
                    "holder",
                    holder_start,
                    tool_length,
                    0.5 * g.holder_diameter_mm,
                ),
            ] {
                if z1 - z0 > 1e-9 {
                    bodies.push(InstrumentBody {
                        name: name.into(),
                        mount: Mount::Tool,
                        offset: at(Vector3::new(0.0, 0.0, 0.5 * (z0 + z1))),
                        primitive: Primitive::Cylinder {
                            radius: radius * mm,
                            half_length: 0.5 * (z1 - z0),
                        },
                        only_label: None,
                    });
                }
            }
            Some((bodies, vec![("rtest ball".into(), "rtest head".into())]))
        }
        "rtest" => {
            // Ball in the spindle: the ball on the tool point, the head below it on its post.
            let b = vec3(setup, "ball")?;
            let r = 0.5 * g.rtest_ball_diameter_mm * mm;
            let mut bodies = tool_side("rtest ball", r, tool_length, g);
            let top = b.z - g.rtest_head_gap_mm * mm;
            let bottom = top - g.rtest_head_height_mm * mm;
            bodies.extend(column(
                "rtest head",
                b.x,
                b.y,
                bottom,
                top,
                0.5 * g.rtest_head_diameter_mm * mm,
            ));
            bodies.extend(column(
                "rtest post",
                b.x,
                b.y,
                table_z,
                bottom,
                0.5 * g.rtest_post_diameter_mm * mm,
            ));
            Some((bodies, vec![("rtest ball".into(), "rtest head".into())]))
        }
        "ballbar" => {
            let p = vec3(setup, "pivot")?;
            let length = num(setup, "length")? * mm;
            let r = 0.5 * g.ballbar_ball_diameter_mm * mm;
            let mut bodies = tool_side("tool ball", r, tool_length, g);
            bodies.push(InstrumentBody {
                name: "pivot ball".into(),
                mount: Mount::Workpiece,
                offset: at(p),
                primitive: Primitive::Sphere { radius: r },
                only_label: None,
            });
            bodies.extend(column(
                "pivot post",
                p.x,
                p.y,
                table_z,
                p.z - r,
                0.5 * g.ballbar_post_diameter_mm * mm,
            ));
            let trim = g.ballbar_cup_mm * mm;
            if length > 2.0 * trim {
                bodies.push(InstrumentBody {
                    name: "bar".into(),
                    mount: Mount::Bar { pivot: p, trim },
                    offset: Rigid::IDENTITY,
                    primitive: Primitive::Capsule {
                        radius: 0.5 * g.ballbar_bar_diameter_mm * mm,
                        half_length: 0.5 * (length - 2.0 * trim),
                    },
                    only_label: None,
                });
            }
            Some((bodies, Vec::new()))
        }
        "artefact" => artefact_bodies(setup, tool_length, nominal, g),
        _ => None,
    }
}

/// A plate per placement: the features' outline plus the margin, `plate_thickness_mm` thick
/// below the feature plane, where the artefact plugin puts it (origin in axis coordinates,
/// turned by `rotation_deg`, flipped about X). The probe ball touches it by design.
fn artefact_bodies(
    setup: &toml::Table,
    tool_length: f64,
    nominal: &Machine,
    g: &GeometryConfig,
) -> Option<Bodies> {
    let mm = 1e-3;
    let features = setup.get("features")?.as_table()?;
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for v in features.values() {
        let a = v.as_array()?;
        let mut p = Vector3::zeros();
        for (k, x) in a.iter().enumerate().take(3) {
            p[k] = x.as_float().or_else(|| x.as_integer().map(|i| i as f64))? * mm;
        }
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    if !lo.x.is_finite() {
        return None;
    }
    let margin = g.plate_margin_mm * mm;
    let thick = g.plate_thickness_mm * mm;
    let half = [
        0.5 * (hi.x - lo.x) + margin,
        0.5 * (hi.y - lo.y) + margin,
        0.5 * (hi.z - lo.z + thick),
    ];
    let centre = Vector3::new(
        0.5 * (hi.x + lo.x),
        0.5 * (hi.y + lo.y),
        0.5 * (hi.z + lo.z - thick),
    );
    // The probe's tool point at q = 0 (the loaded machine's tool point `tool_length` further
    // along −z of the tool, as the plan's machine has it): axis coordinates → workpiece frame.
    let zero = nominal.tool_in_workpiece(&vec![0.0; nominal.n_axes()]);
    let c = zero.t + zero.r * Vector3::new(0.0, 0.0, -tool_length);
    let mut placements: Vec<(String, toml::Table)> = match setup.get("placements") {
        Some(toml::Value::Table(t)) => t
            .iter()
            .filter_map(|(k, v)| Some((k.clone(), v.as_table()?.clone())))
            .collect(),
        _ => vec![("p1".into(), setup.clone())],
    };
    let several = placements.len() > 1;
    let r = 0.5 * g.probe_ball_diameter_mm * mm;
    let mut bodies = tool_side("probe ball", r, tool_length, g);
    let mut allowed = Vec::new();
    for (name, p) in placements.drain(..) {
        let origin = vec3(&p, "origin").unwrap_or_else(Vector3::zeros);
        let rot = num(&p, "rotation_deg").unwrap_or(0.0).to_radians();
        let flip = p.get("flipped").and_then(|v| v.as_bool()).unwrap_or(false);
        let rz = Matrix3::new(
            rot.cos(),
            -rot.sin(),
            0.0,
            rot.sin(),
            rot.cos(),
            0.0,
            0.0,
            0.0,
            1.0,
        );
        let f = if flip {
            Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
        } else {
            Matrix3::identity()
        };
        let plate = Rigid::new(rz * f, c + origin);
        let body = format!("plate {name}");
        allowed.push(("probe ball".to_string(), body.clone()));
        bodies.push(InstrumentBody {
            name: body,
            mount: Mount::Workpiece,
            offset: plate.compose(&at(centre)),
            primitive: Primitive::Box { half },
            only_label: several.then(|| format!("{name}/")),
        });
    }
    Some((bodies, allowed))
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
