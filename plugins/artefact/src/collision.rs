//! The artefact's collision bodies for the test planner, and where a planned position goes:
//! the probe ball with the common stem and holder, and a plate per placement — the features'
//! outline plus a margin, a given thickness below the feature plane, where the set-up puts it
//! (origin in axis coordinates, turned by `rotation_deg`, flipped about X). The probe ball
//! touches the plates by design; with several placements each plate is present only at the
//! samples of its placement.

use crate::setup::ArtefactSetup;
use mtcal_instrument::SetupError;
use mtcal_instrument::collision::{
    self, Bodies, BodySpec, InstrumentBody, Planning, Primitive, SizeKey, at, tool_ball_stem_holder,
};
use mtcal_kinematics::Rigid;
use nalgebra::{Matrix3, Vector3};

/// The probe ball.
pub const PROBE_BALL_DIAMETER: SizeKey = SizeKey::positive("probe_ball_diameter_mm", 6.0);
/// How far the plate reaches beyond its outermost features.
pub const PLATE_MARGIN: SizeKey = SizeKey::finite("plate_margin_mm", 15.0);
/// How thick the plate is below its feature plane.
pub const PLATE_THICKNESS: SizeKey = SizeKey::positive("plate_thickness_mm", 20.0);

/// What the planner needs: positions go into `origin` (axis coordinates, as the set-up reads
/// it).
pub const PLANNING: Planning = Planning {
    position_key: Some("origin"),
    written_out: &[],
    sizes: &[PROBE_BALL_DIAMETER, PLATE_MARGIN, PLATE_THICKNESS],
    bodies: Some(bodies),
};

/// The bodies of a loaded artefact set-up.
pub fn bodies(spec: &BodySpec<'_>) -> Result<Option<Bodies>, SetupError> {
    let setup: &ArtefactSetup = spec.own_setup()?;
    let mm = 1e-3;
    let (mut lo, mut hi) = (
        Vector3::repeat(f64::INFINITY),
        Vector3::repeat(f64::NEG_INFINITY),
    );
    for (_, f) in setup.features() {
        let p = Vector3::new(f[0] * mm, f[1] * mm, f[2] * mm);
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    if !lo.x.is_finite() {
        return Ok(None);
    }
    let margin = spec.size_m(&PLATE_MARGIN);
    let thick = spec.size_m(&PLATE_THICKNESS);
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
    let machine = spec.machine;
    let zero = machine.tool_in_workpiece(&vec![0.0; machine.n_axes()]);
    let c = zero.t + zero.r * Vector3::new(0.0, 0.0, -spec.tool_length);
    let placements = setup.placements();
    let several = placements.len() > 1;
    let r = 0.5 * spec.size_m(&PROBE_BALL_DIAMETER);
    let mut bodies = tool_ball_stem_holder("probe ball", r, spec.tool_length, spec.tool_side);
    let mut allowed = Vec::new();
    for p in placements {
        let origin = Vector3::new(p.origin_mm[0], p.origin_mm[1], p.origin_mm[2]) * mm;
        let plate = Rigid::new(turned(p.rotation_deg, p.flipped), c + origin);
        let body = format!("plate {}", p.name);
        allowed.push(("probe ball".to_string(), body.clone()));
        bodies.push(InstrumentBody {
            name: body,
            mount: collision::Mount::Workpiece,
            offset: plate.compose(&at(centre)),
            primitive: Primitive::Box { half },
            only_label: several.then(|| format!("{}/", p.name)),
        });
    }
    Ok(Some((bodies, allowed)))
}

/// The plate's nominal rotation, plate frame → axis frame: `Rz(rotation)·Flip` (Flip =
/// diag(1, −1, −1) when turned over about its X axis).
fn turned(rotation_deg: f64, flipped: bool) -> Matrix3<f64> {
    let rot = rotation_deg.to_radians();
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
    let f = if flipped {
        Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
    } else {
        Matrix3::identity()
    };
    rz * f
}
