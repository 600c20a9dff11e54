//! Writes the bundled example `examples/volumetric/session` (how it was made, so that it can be
//! made again): the independent simulator's volumetric thermal test on the trunnion under
//! Y-drive load (docs/VOLUMETRIC.md) — 36 cycles of 15 ball visits between ten-minute load
//! phases, the head turning about X and the Y scale growing with the drive's temperature,
//! realistic noise — without the 500 Hz stream (22 MB), with its truth in `truth/`.
//!
//! `cargo run -p mtcal-volumetric --example write_example -- examples/volumetric/session`
//!
//! With `rtest-sets` after the folder, `examples/volumetric/rtest-sets` instead: source 000's
//! R-test sets repeated between load cycles of the rotary drives (§5.5) — an XYC and a YZA set
//! of the trunnion in each of 36 cycles, the A cradle and the C table loaded in turn through 24
//! phases, A's and C's lines moving with their drives' temperatures.

use mtcal_indsim::{
    Campaign, Machine, Realism, Truth, VolumetricLoad, VolumetricSpec, shipped_machine,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .ok_or("usage: write_example DIR (a folder that does not exist yet)")?;
    let machine = Machine::from_urdf_file(&shipped_machine("mcu630-cafyxz.urdf"))?;
    let truth = Truth::zero(&machine);
    let load = match std::env::args().nth(2).as_deref() {
        None => VolumetricLoad::YDrive,
        Some("rtest-sets") => VolumetricLoad::RotaryDrives,
        Some(other) => return Err(format!("`{other}`: rtest-sets or nothing expected").into()),
    };
    let mut spec = VolumetricSpec::new(load);
    spec.stream = None;
    let written =
        Campaign::volumetric_trunnion(dir.as_ref(), &truth, &spec, &Realism::realistic(33))?;
    println!(
        "{dir}: {} visits in {} cycles",
        written.visits.len(),
        spec.cycles
    );
    Ok(())
}
