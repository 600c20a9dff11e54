//! The ball-bar's collision bodies for the test planner, and where a planned position goes:
//! the tool ball with the common stem and holder, the pivot ball on its post from the table
//! top, and the bar between the balls (a capsule shortened at each end by the cups).

use crate::setup::BallbarSetup;
use mtcal_instrument::SetupError;
use mtcal_instrument::collision::{
    self, Bodies, BodySpec, InstrumentBody, Planning, Primitive, SizeKey, at, column,
    tool_ball_stem_holder,
};
use mtcal_kinematics::Rigid;

/// Both balls.
pub const BALL_DIAMETER: SizeKey = SizeKey::positive("ballbar_ball_diameter_mm", 12.7);
/// The bar.
pub const BAR_DIAMETER: SizeKey = SizeKey::positive("ballbar_bar_diameter_mm", 16.0);
/// How far each cup covers the bar from its ball's centre.
pub const CUP: SizeKey = SizeKey::finite("ballbar_cup_mm", 20.0);
/// The pivot's post from the table top.
pub const POST_DIAMETER: SizeKey = SizeKey::positive("ballbar_post_diameter_mm", 16.0);

/// What the planner needs: positions go into `pivot`.
pub const PLANNING: Planning = Planning {
    position_key: Some("pivot"),
    written_out: &[],
    sizes: &[BALL_DIAMETER, BAR_DIAMETER, CUP, POST_DIAMETER],
    bodies: Some(bodies),
};

/// The bodies of a loaded ball-bar set-up.
pub fn bodies(spec: &BodySpec<'_>) -> Result<Option<Bodies>, SetupError> {
    let config = spec.own_setup::<BallbarSetup>()?.config();
    let p = config.pivot();
    let length = config.length();
    let r = 0.5 * spec.size_m(&BALL_DIAMETER);
    let mut bodies = tool_ball_stem_holder("tool ball", r, spec.tool_length, spec.tool_side);
    bodies.push(InstrumentBody {
        name: "pivot ball".into(),
        mount: collision::Mount::Workpiece,
        offset: at(p),
        primitive: Primitive::Sphere { radius: r },
        only_label: None,
    });
    bodies.extend(column(
        "pivot post",
        p.x,
        p.y,
        spec.tool_side.table_z,
        p.z - r,
        0.5 * spec.size_m(&POST_DIAMETER),
    ));
    let trim = spec.size_m(&CUP);
    if length > 2.0 * trim {
        bodies.push(InstrumentBody {
            name: "bar".into(),
            mount: collision::Mount::Bar { pivot: p, trim },
            offset: Rigid::IDENTITY,
            primitive: Primitive::Capsule {
                radius: 0.5 * spec.size_m(&BAR_DIAMETER),
                half_length: 0.5 * (length - 2.0 * trim),
            },
            only_label: None,
        });
    }
    Ok(Some((bodies, Vec::new())))
}
