//! `cargo xtask plan`: measurement planning (crates/plan).

use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Plans from `planning`, writes the plan, programs and report into `out`, prints the summary.
pub fn run(planning: &Path, out: &Path, stdout: &mut dyn Write) -> Result<()> {
    let planned = mtcal_plan::plan(planning)?;
    let files = planned
        .write(out)
        .with_context(|| format!("writing the plan into {}", out.display()))?;
    write!(stdout, "{}", planned.report.summary())?;
    writeln!(
        stdout,
        "wrote {} files into {} (plan.toml, programs/, report.json, report.txt)",
        files.len(),
        out.display()
    )?;
    Ok(())
}
