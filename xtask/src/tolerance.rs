//! `cargo xtask tolerance`: source 001's tolerance analysis (crates/tolerance): random machines
//! within the tolerances of a specification, the P90 of their maximum volumetric error and each
//! tolerance's sensitivity.

use anyhow::{Context, Result, bail};
use mtcal_tolerance::{Analysis, DEFAULT_GRID, DEFAULT_SAMPLES, Options, load_spec};
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub(crate) struct ToleranceArgs {
    #[command(flatten)]
    machine: crate::MachineArg,
    /// The tolerance specification (TOML; docs/TOLERANCE.md).
    #[arg(long)]
    spec: PathBuf,
    /// Sampled machines (default: the specification's, else 5000).
    #[arg(long)]
    samples: Option<usize>,
    /// Random seed (default: the specification's, else 1).
    #[arg(long)]
    seed: Option<u64>,
    /// Grid points on X, Y, Z, e.g. 11x11x11 (default: the specification's, else 11x11x11).
    #[arg(long)]
    grid: Option<String>,
    /// Write the report as JSON (schema mtcal.tolerance/1) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Worker threads (default: all cores; the result does not depend on it).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Bootstrap resamples for the sensitivities' standard errors (0: none).
    #[arg(long, default_value_t = 100)]
    bootstrap: usize,
}

pub(crate) fn run(args: ToleranceArgs, out: &mut impl Write) -> Result<()> {
    let loaded = args.machine.load()?;
    let spec = load_spec(&args.spec, &loaded.machine)?;
    let counts = match (&args.grid, &spec.grid) {
        (Some(text), _) => mtcal_tolerance::parse_grid(text)?,
        (None, Some(g)) => g.clone(),
        (None, None) => DEFAULT_GRID.to_vec(),
    };
    let opts = Options {
        samples: args.samples.or(spec.samples).unwrap_or(DEFAULT_SAMPLES),
        seed: args.seed.or(spec.seed).unwrap_or(1),
        threads: args.threads,
        bootstrap: args.bootstrap,
        ..Options::default()
    };
    if opts.samples == 0 {
        bail!("--samples must be at least 1");
    }
    let analysis = Analysis::new(&loaded.machine, &spec, &counts)
        .with_context(|| format!("cannot set up the analysis of {}", args.spec.display()))?;
    let report = analysis.run(&opts)?;
    writeln!(out, "machine     {}", loaded.source)?;
    writeln!(out, "spec        {}", args.spec.display())?;
    write!(out, "{report}")?;
    if let Some(path) = &args.json {
        mtcal_machine::write_atomically(path, report.to_json().as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        writeln!(out, "wrote {}", path.display())?;
    }
    Ok(())
}
