//! The R-test's collision bodies for the test planner, and where a planned position goes.
//!
//! `mount = "ball-on-table"` (the default, written into every planned set-up): the ball on a
//! post on the table, the head (nest) on the tool above it, hanging from the holder by a stem;
//! `mount = "ball-in-spindle"`: the ball on the tool point with the common stem and holder, the
//! head below it on a post from the table top. The ball sits in its head by design.

use crate::setup::{Mount, RTest};
use mtcal_instrument::SetupError;
use mtcal_instrument::collision::{
    self, Bodies, BodySpec, InstrumentBody, Planning, Primitive, SizeKey, at, column, on_tool_axis,
    tool_ball_stem_holder,
};

/// The ball.
pub const BALL_DIAMETER: SizeKey = SizeKey::positive("rtest_ball_diameter_mm", 22.0);
/// The head (nest): a cylinder coaxial with the part it sits on.
pub const HEAD_DIAMETER: SizeKey = SizeKey::positive("rtest_head_diameter_mm", 70.0);
pub const HEAD_HEIGHT: SizeKey = SizeKey::positive("rtest_head_height_mm", 50.0);
/// How far the head's near face lies from the ball centre (its bottom above it in the
/// spindle, its top below it on the table).
pub const HEAD_GAP: SizeKey = SizeKey::finite("rtest_head_gap_mm", 8.0);
/// The post from the table top to the ball (ball on the table) or to the head (in the spindle).
pub const POST_DIAMETER: SizeKey = SizeKey::positive("rtest_post_diameter_mm", 30.0);

/// What the planner needs: positions go into `ball`; `mount` is written out (the plan says
/// which arrangement it checked).
pub const PLANNING: Planning = Planning {
    position_key: Some("ball"),
    written_out: &["mount"],
    sizes: &[
        BALL_DIAMETER,
        HEAD_DIAMETER,
        HEAD_HEIGHT,
        HEAD_GAP,
        POST_DIAMETER,
    ],
    bodies: Some(bodies),
};

/// The bodies of a loaded R-test set-up on its mount.
pub fn bodies(spec: &BodySpec<'_>) -> Result<Option<Bodies>, SetupError> {
    let setup: &RTest = spec.own_setup()?;
    let b = setup.ball_m();
    let r = 0.5 * spec.size_m(&BALL_DIAMETER);
    let table_z = spec.tool_side.table_z;
    let bodies = match setup.mount() {
        Mount::BallOnTable => {
            // The ball on its post, the head hanging from the holder, its bottom `gap` above
            // the ball centre, and a stem from the head's top up to the holder.
            let mut bodies = vec![InstrumentBody {
                name: "rtest ball".into(),
                mount: collision::Mount::Workpiece,
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
                0.5 * spec.size_m(&POST_DIAMETER),
            ));
            let head_bottom = spec.size_m(&HEAD_GAP);
            let head_top = head_bottom + spec.size_m(&HEAD_HEIGHT);
            let tool = spec.tool_side;
            let holder_start = (spec.tool_length - tool.holder_length).max(head_top);
            bodies.extend(on_tool_axis(
                "rtest head",
                head_bottom,
                head_top,
                0.5 * spec.size_m(&HEAD_DIAMETER),
            ));
            bodies.extend(on_tool_axis(
                "stem",
                head_top,
                holder_start,
                0.5 * tool.stem_diameter,
            ));
            bodies.extend(on_tool_axis(
                "holder",
                holder_start,
                spec.tool_length,
                0.5 * tool.holder_diameter,
            ));
            bodies
        }
        Mount::BallInSpindle => {
            // The ball on the tool point, the head below it on its post.
            let mut bodies =
                tool_ball_stem_holder("rtest ball", r, spec.tool_length, spec.tool_side);
            let top = b.z - spec.size_m(&HEAD_GAP);
            let bottom = top - spec.size_m(&HEAD_HEIGHT);
            bodies.extend(column(
                "rtest head",
                b.x,
                b.y,
                bottom,
                top,
                0.5 * spec.size_m(&HEAD_DIAMETER),
            ));
            bodies.extend(column(
                "rtest post",
                b.x,
                b.y,
                table_z,
                bottom,
                0.5 * spec.size_m(&POST_DIAMETER),
            ));
            bodies
        }
    };
    Ok(Some((
        bodies,
        vec![("rtest ball".into(), "rtest head".into())],
    )))
}
