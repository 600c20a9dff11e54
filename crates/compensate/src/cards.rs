//! The convention cards of the formats written before the card existed: pitch tables (CSV,
//! LinuxCNC), the 3-D error grid, the ISG/Etalon error parameters and LinuxCNC's table-table
//! pivots. Each says in the card's words what the crate documentation says about the format.

use crate::output::PitchFormat;
use crate::parameters::ParameterFormat;
use mtcal_kinematics::Machine;
use mtcal_machine::card::{AxisMap, ConventionCard, Quantity, ROTARY_RIGHT_HAND, SQUARENESS_ISO};

const LINEAR_ONLY: &str = "not applicable: a linear axis' table";
const NO_SQUARENESS: &str = "not held: a pitch table holds positioning along its own axis only (use the grid or the error \
     parameters for squareness)";

/// The card of a pitch table of `axis`.
pub(crate) fn pitch(
    format: PitchFormat,
    axis: char,
    joint_offset_mm: f64,
    bidirectional: bool,
) -> ConventionCard {
    let control = if joint_offset_mm == 0.0 {
        format!("{axis} (same zero)")
    } else {
        format!("{axis} (joint position = axis position {joint_offset_mm:+} mm)")
    };
    let mut card = ConventionCard {
        format: String::new(),
        quantity: Quantity::Correction,
        sign: String::new(),
        squareness: NO_SQUARENESS.into(),
        rotary_direction: LINEAR_ONLY.into(),
        axis_mapping: vec![AxisMap {
            mtcal: axis,
            control,
        }],
        units: String::new(),
        control_will: Vec::new(),
    };
    match format {
        PitchFormat::Csv => {
            card.format = "mtcal CSV pitch table".into();
            card.sign = "compensation = −(positioning error along the axis): added to the \
                         command, the tool lands where it was commanded"
                .into();
            card.units = "positions mm, compensations µm".into();
            card.control_will
                .push("interpolate linearly between nodes and hold the end values outside".into());
        }
        PitchFormat::LinuxCnc => {
            card.format = "LinuxCNC axis compensation file, COMP_FILE_TYPE = 1".into();
            card.sign = "LinuxCNC adds the trim to the commanded joint position: column 2 while \
                         the joint moves forward, column 3 in reverse"
                .into();
            card.units = "machine units: positions and trims in mm (LINEAR_UNITS = mm)".into();
            card.control_will.extend([
                "read it from [JOINT_n] COMP_FILE with COMP_FILE_TYPE = 1 after a restart; \
                 remove BACKLASH (the file replaces it)"
                    .into(),
                "interpolate linearly between the ≤ 256 triplets and hold the end values outside"
                    .into(),
                "stop reading at the first line that is not a triplet, so this card is written \
                 beside the file (FILE.card.txt), not in it"
                    .into(),
            ]);
        }
    }
    if bidirectional {
        card.control_will.push(
            "use the forward values while the axis moves in +, the reverse values in −: \
             reverse = forward + B (ISO 230-2 reversal value)"
                .into(),
        );
    }
    card
}

/// The card of the 3-D error grid.
pub(crate) fn grid(machine: &Machine) -> ConventionCard {
    ConventionCard {
        format: "mtcal CSV 3-D error grid".into(),
        quantity: Quantity::Error,
        sign: "dx_um, dy_um, dz_um = actual − nominal tool point relative to the workpiece, \
               workpiece frame; the control subtracts them"
            .into(),
        squareness: "included: the grid holds the tool-point error every error causes, \
                     squareness too"
            .into(),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "positions mm, errors µm, orientation errors µrad".into(),
        control_will: vec![
            "interpolate trilinearly between the 8 nodes around a point and hold the edge values \
             outside the grid"
                .into(),
            "correct the tool point only; the rotary axes were held where the file's comment says"
                .into(),
        ],
    }
}

/// The card of the ISG CSV or Etalon error parameters.
pub(crate) fn parameters(machine: &Machine, format: ParameterFormat) -> ConventionCard {
    let name = match format {
        ParameterFormat::IsgCsv => "Beckhoff TF5280 / ISG volumetric compensation, ISG_CSV",
        ParameterFormat::Etalon => "Etalon Exchange Format (Vendor), ETALON_EXCHANGE",
    };
    ConventionCard {
        format: name.into(),
        quantity: Quantity::Error,
        sign: "ISO 230-1: functional errors of the tool relative to the workpiece in machine \
               X/Y/Z; leave the controller's `negate` empty"
            .into(),
        squareness: SQUARENESS_ISO.replace("; µrad", "; rad in this file"),
        rotary_direction: ROTARY_RIGHT_HAND.into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "values mm and rad; table arguments mm (linear) and degrees (rotary)".into(),
        control_will: vec![
            "build its own error model from the tables (linear between nodes) and apply −error"
                .into(),
            "need the list file's workpiece_axes and chain to match the header's axis sides".into(),
            "correct the tool point only, unless its orientation compensation is configured".into(),
        ],
    }
}

/// The card of LinuxCNC's table-table pivots.
pub(crate) fn trt(machine: &Machine, kinematics: &str, not_representable: usize) -> ConventionCard {
    ConventionCard {
        format: format!("LinuxCNC HAL settings of {kinematics}"),
        quantity: Quantity::Geometry,
        sign: "pivot points of the actual rotary axis lines in joint coordinates".into(),
        squareness: "not held: the kinematics have no squareness".into(),
        rotary_direction: "LinuxCNC's trt kinematics turn A/B and C the other way from ISO 841"
            .into(),
        axis_mapping: ConventionCard::same_letters(machine),
        units: "mm".into(),
        control_will: vec![
            "take the setp lines after the kinematics component is loaded in the HAL file".into(),
            format!(
                "ignore the {not_representable} identified errors these kinematics cannot hold \
                 (listed in the file)"
            ),
        ],
    }
}
