//! Heidenhain compensation files: nonlinear axis error compensation (`.COM` tables assigned by
//! a `.CMA` file) and KinematicsComp (ISO 230-1 errors in the kinematics description).
//!
//! # Sources (read through the search tool's `pages` corpus; the manuals are OEM documents)
//! - **TNC 407/415/425 technical manual** (01.98): p.151 (MP720, linear axis error: "positive if
//!   the table travels too far"; MP730 switches each axis to linear or nonlinear compensation),
//!   p.153 (the `.CMA` assigns a `.COM` table to each axis; several lines, one active, chosen by
//!   soft key or PLC module 9095; inactive without MP730 and a valid `.CMA`; worked example
//!   "required distance 7 mm, possible power of two 2^16 = 6.5536 mm", datum −90 mm; the
//!   example's graph is labelled "Error in Z [mm]"), p.156 (rotary axes only 0–360°; transfer
//!   extensions `.S`/`.V`; the older code-number tables of 64 points), p.622 (module 9095:
//!   "more than 256 entries", "permissible total number of compensation points exceeded",
//!   "too many compensation value tables"). Pages 152, 154 and 155, with the `.COM` layout, were
//!   not in the mirror.
//! - TNC 306 / TNC 360 technical manuals (older controls, context only): the spacing entered as
//!   an exponent of 2 in µm (11 → 2.048 mm), "only the compensation points of the error curve
//!   are entered, the control interpolates linearly between them".
//! - **MANUALplus 620 technical manual** (01.2012): p.713, p.716 (`.COM`: AXISPOS, the points,
//!   from the machine datum; BACKLASH, values measured in the negative direction; the values in
//!   the column named after the axis, from CfgAxes/axisList), p.718 (`.CMA`: one column per
//!   axis, table names line by line, `*` in ACTIVE; "[axis of the column in the .COM] =
//!   F(axis of the .CMA column the .COM is entered in)"; Z = F(Y) sag and Y = F(Y) pitch).
//! - **iTNC 530 HSCI technical manual** (07.2013): p.666 (ISO 230-1 names: EXX… component,
//!   X0C… location errors), p.670 (43 errors on five axes; description table NR KEY AXIS COORD,
//!   the example chain "Trans X 0.016, Trans Z 250.051, MachAxis B, MachAxis Y, …"), p.671
//!   (COMPTAB links the chain to compensation tables; the TCP is corrected; MP4070 sets the
//!   rate), p.680 (errors are defined before the affected axis; the `.COM` columns C1–C6 of a
//!   linear axis hold EXX, EYX, EZX, EAX, EBX, ECX, of a rotary axis EXA … ECA), p.684
//!   (location errors as `Trans` with their value before the axis and negated after it), p.686
//!   (at most 100 COMPTAB entries less the MachAxis entries; at most 50 COORD entries), p.722
//!   (KEY: MachAxis, MachBase, Trans; "the start of the sequence is always the tool reference
//!   point").
//! - The table framing shared by Heidenhain tables (`BEGIN NAME.SUFFIX MM`, a header of column
//!   names, fixed-width rows, `[END]`) as the public LSV2 client pyLSV2 reads and writes them
//!   (read to learn; no code taken).
//!
//! # Nonlinear axis error compensation: `.COM` + `.CMA` ([`heidenhain_com_set`])
//! - **Tables**: `X.COM`, `Y.COM`, `Z.COM`, one per principal linear axis of the machine, each a
//!   function of its own axis (its `.CMA` column). Columns `NR` (0, 1, …), `AXISPOS` (mm), and
//!   one column per corrected axis named by its letter: the table of X holds X = F(X)
//!   (positioning) and Y = F(X), Z = F(X) (straightness, including the squareness slope). The
//!   `.CMA` has `NR`, one column per input axis holding the table's file name, and `ACTIVE`
//!   with `*` on its one line. U/V/W and rotary axes get no table.
//! - **Errors, not corrections**: a value is the axis' error, actual − nominal along it,
//!   projected on the directions of travel (a positive command moves the tool positively
//!   relative to the workpiece) at the held position; the control moves the axis by −value.
//!   Inferred, since the layout pages are missing: the TNC 4xx example plots "Error in Z",
//!   the older manuals enter "the error curve", and the linear compensation (MP720) takes the
//!   error with "positive if the table travels too far". The card says so; check one point on
//!   the machine before relying on the sign.
//! - **Points**: on a lattice through the held position (snapped to 0.1 µm), covering the stroke
//!   (the last rows may lie up to one spacing beyond a limit, where the model is extrapolated).
//!   TNC 4xx: the spacing is `2^k × 0.1 µm`, the largest power of two not above the requested
//!   spacing, as the manual's example picks 6.5536 mm for 7 mm; at most 256 rows per table.
//! - **Adding up**: the control adds the columns of an axis over all tables of the active line.
//!   So that this gives the model's error, the positioning column carries the error at the
//!   held position and the straightness columns are written relative to it (zero there): on
//!   the three lines through the held position the sum is the model's error. Away from them
//!   the sum of 1-D functions misses what depends on two axes at once (Abbe effects of
//!   angular errors); KinematicsComp can hold those.
//! - **Precision**: positions and values to 0.1 µm (4 decimals, the unit of the TNC 4xx
//!   spacing); a straightness value is rounded after subtracting the written held-position
//!   value, so every component of the sum carries one rounding (≤ 0.05 µm).
//! - **Limits** ([`ComLimits`]): entries per table, spacing rule, total points and table count
//!   of the active line (the TNC 4xx numbers for these two are not in the pages read: fields to
//!   set), plausible values (|value| ≤ 1 mm, else probably µm written as mm).
//!
//! # KinematicsComp ([`kinematics_comp`])
//! - **What goes where** (the manual's assignment, p.680/p.686): a linear axis' straightness and
//!   angular errors (EYX, EZX, EAX, EBX, ECX) and a rotary axis' radial, axial and tilt errors
//!   (EXC, EYC, EZC, EAC, EBC) as COMPTAB entries; its positioning error (EXX, ECC, with a rotary
//!   axis' zero offset EC0C) in the table's column named after the axis, "corrected as usual in
//!   columns 1–18 of the COM files", activated by a `.CMA` written beside the description;
//!   location errors as COORD entries around the axis.
//! - **Description** (`<name>.TAB`): entries `NR DOC KEY AXIS COORD COMPTAB` in the order of
//!   the chain from the tool to the table: for each tool-side axis from the tool inwards, then
//!   `MachBase`, then each workpiece-side axis outwards: its location errors as `Trans` with
//!   COORD (ISO value, DOC `X0C`), `MachAxis <axis>`, the location errors negated in reverse
//!   order (DOC `-X0C`), and its five component entries `Trans` with COMPTAB `KC_<axis>.COM:Cn`
//!   on the side where mtcal's model defines the error: a linear axis' move with its carriage
//!   (before a tool-side axis, after a workpiece-side one), a rotary axis' are measured in the
//!   frame that does not turn (before a table axis, after a head axis). There the entries are
//!   the inverse of the axis' functional error exactly, with no Abbe terms. The nominal
//!   `Trans`/`MachAxis` entries are the control's own and are not written. With all errors
//!   known, the inverse component entries of the manual's isolated scheme (p.684, "−EYX where
//!   X = 0") are not needed and not written.
//! - **Sign, one convention**: each entry's DOC names the ISO 230-1 quantity its value is, with
//!   its sign, in mtcal's values: `X0C` holds +X0C, `-X0C` −X0C, and a COMPTAB entry `-EYX`
//!   holds −EYX to first order. The chain is read as the iTNC 530 description runs, from the
//!   tool reference point, with the B pivot at `Trans Z 250.051` from it: an entry is the pose
//!   of what follows in the current frame (`tool_T_table = T₁·T₂·…`), `Trans A/B/C`
//!   right-handed, so an axis' error enters inverted. C1–C6 at each row are that inverse
//!   exactly, written as `Trans X·Trans Y·Trans Z·Trans A·Trans B·Trans C`; the own column
//!   (C1 of X, C6 of C) is zero and not referenced, its content moved to the positioning column
//!   (the axis standing at `q + value` reproduces the model, so the control subtracts it, as for
//!   the `.COM` set above). The manual labels the columns by the errors (EYX …) and adds EBX
//!   and B0X in one column of its reduced scheme: its components may carry the opposite sign;
//!   the card says so.
//! - **Tables** `KC_<axis>.COM`: `NR AXISPOS <axis> C1 … C6`, AXISPOS in mm or degrees at the
//!   nodes of [`crate::error_parameters`], the axis column and C1–C3 in mm (degrees for a rotary
//!   axis' own column), C4–C6 in degrees, 7 decimals.
//! - **Limits** ([`KcLimits`]): COMPTAB + MachAxis ≤ 100, COORD ≤ 50 (p.686), plausible values.
//!   controllers.md says "≤ 100 COMPTAB entries"; the manual counts the MachAxis entries in.
//!
//! # Assumed, because the pages were not available (say so to the user; the cards do)
//! - The `.COM` layout of the TNC 4xx (its pages 152–155): the MANUALplus 620 layout is written.
//! - controllers.md's "spacing a power of two" is made precise by the manual's example: 2^k in
//!   units of 0.1 µm (2^16 = 6.5536 mm), not 2^k µm (that was the TNC 306/360's entry).
//! - The unit line `MM` on every table, including the `.CMA`; the reader accepts it missing.
//! - KinematicsComp: the chain's direction of composition (above), the COMPTAB reference syntax
//!   `FILE.COM:Cn` (the manual's text shows it only garbled), the `.COM` layout of its tables
//!   (AXISPOS, the axis column, C1–C6) and their activation by a `.CMA`, degrees in C4–C6 (as
//!   COORD rotations in description tables), and that the description's frames are parallel
//!   to mtcal's machine frame at the zero pose (the export refuses machines whose joint frames
//!   are turned there).
//!
//! # Cards
//! Heidenhain tables have no comment syntax, so each written set gets its
//! [`crate::ConventionCard`] as a text file beside it ([`card_path`]).

mod com;
mod kinematics_comp;
mod table;

pub use com::{
    COM_RESOLUTION_MM, ComLimits, ComSet, ComTable, SpacingRule, heidenhain_com_card,
    heidenhain_com_set, read_com_table, read_heidenhain_com, validate_heidenhain_com,
    write_heidenhain_com,
};
pub use kinematics_comp::{
    KcEntry, KcKey, KcLimits, KcTable, KcValue, KinematicsComp, kinematics_comp,
    kinematics_comp_card, kinematics_comp_cma, read_kinematics_comp, validate_kinematics_comp,
    write_kinematics_comp,
};

use std::path::{Path, PathBuf};

/// What a Heidenhain control would refuse or misread in a file mtcal made or read.
#[derive(Debug, thiserror::Error)]
pub enum HeidenhainLimit {
    #[error(
        "{table}: {entries} entries, the control holds at most {max} per table (TNC 4xx: error 3 \
         of PLC module 9095); choose a larger spacing"
    )]
    TooManyEntries {
        table: String,
        entries: usize,
        max: usize,
    },
    #[error(
        "{table}: rows {row} and {next} are {step_mm:.4} mm apart; the TNC 4xx needs 2^k × 0.1 µm \
         (… 3.2768, 6.5536, 13.1072 … mm)"
    )]
    SpacingNotPowerOfTwo {
        table: String,
        row: usize,
        next: usize,
        step_mm: f64,
    },
    #[error(
        "{table}: rows {row} and {next} are {step_mm:.4} mm apart, the first rows {expected_mm:.4} mm; \
         the table must be equidistant"
    )]
    NotEquidistant {
        table: String,
        row: usize,
        next: usize,
        step_mm: f64,
        expected_mm: f64,
    },
    #[error(
        "{table}: row {row} at {position} does not follow row {previous_row} at {previous}; positions must ascend"
    )]
    NotAscending {
        table: String,
        row: usize,
        position: f64,
        previous_row: usize,
        previous: f64,
    },
    #[error(
        "{points} compensation points in the active line, the control allows {max} in all \
         (TNC 4xx: error 4 of PLC module 9095)"
    )]
    TotalPoints { points: usize, max: usize },
    #[error(
        "{tables} compensation tables in the active line, the control allows {max} (TNC 4xx: \
         error 5 of PLC module 9095)"
    )]
    TooManyTables { tables: usize, max: usize },
    #[error(
        "{table}: column {column}, row {row}: {value} {unit} is larger than {max} {unit} (is it \
         in the wrong unit, µm or µrad for mm or degrees?)"
    )]
    ValueTooLarge {
        table: String,
        column: String,
        row: usize,
        value: f64,
        max: f64,
        unit: &'static str,
    },
    #[error("{table}: {what}")]
    Shape { table: String, what: String },
    #[error(
        "{comptab} COMPTAB entries and {machaxis} MachAxis entries: KinematicsComp allows {max} \
         together (iTNC 530 technical manual p.686)"
    )]
    TooManyComptab {
        comptab: usize,
        machaxis: usize,
        max: usize,
    },
    #[error(
        "{coord} COORD entries: KinematicsComp allows at most {max} (iTNC 530 technical manual p.686)"
    )]
    TooManyCoord { coord: usize, max: usize },
    #[error("entry {entry} ({doc}): {what}")]
    Entry {
        entry: usize,
        doc: String,
        what: String,
    },
}

/// Where the convention card of a Heidenhain file goes: Heidenhain tables have no comment
/// syntax, so the card is a text file beside it, `<file name>.card.txt`.
pub fn card_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".card.txt");
    path.with_file_name(name)
}

/// Writes the convention card of the set `name` (its assignment or listing file at `path`)
/// beside it ([`card_path`]), with the note of where the numbers came from; returns the path.
fn write_card(
    path: &Path,
    name: &str,
    card: &mtcal_machine::card::ConventionCard,
    note: &str,
) -> Result<PathBuf, crate::CompensateError> {
    let card_file = card_path(path);
    let text = format!(
        "Convention card of {name} and its tables (Heidenhain tables have no comments)\n{}\n\
         made from: {note}\n",
        card.file_lines("")
    );
    crate::write_file(&card_file, &text)?;
    Ok(card_file)
}
