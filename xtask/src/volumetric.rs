//! `cargo xtask volumetric`: a volumetric thermal test evaluated (crates/volumetric,
//! docs/VOLUMETRIC.md): the verdict on the screen, every number in the JSON, the plots in the
//! page.

use anyhow::Result;
use mtcal_located::Outputs;
use mtcal_report::{VectorField, VectorPoint, VolumetricPage, VolumetricRow, VolumetricSeries};
use mtcal_volumetric::{Evaluation, Options, TimeBase, Verdict};
use std::io::Write;
use std::path::PathBuf;

/// The arguments of `volumetric`.
#[derive(clap::Args)]
pub(crate) struct VolumetricArgs {
    /// The session folder (or its session.toml): rtest runs, ball on the table, one row per
    /// ball visit.
    session: PathBuf,
    /// Write every number as JSON (schema mtcal.volumetric/1) to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Snapshots of every point's deformation vector at these times (h on the session's
    /// clock, the nearest cycle), e.g. --phase 1.5,2.9 (default: the verdict's instant and the
    /// last).
    #[arg(long = "phase", value_name = "HOURS", value_delimiter = ',')]
    phases: Vec<f64>,
    /// The spread between points may be this share of the mean deformation (0.2: 20 %).
    #[arg(long, default_value_t = mtcal_volumetric::DEFAULT_TOLERANCE_SHARE)]
    tolerance_share: f64,
    /// How each point's deformation is brought to the cycles' instants: interpolated
    /// (linear in time between the point's visits) or cycle (the point's visit in that cycle,
    /// the cycle taken as one instant).
    #[arg(
        long,
        default_value = "interpolated",
        value_name = "interpolated|cycle"
    )]
    time_base: String,
    /// Write an HTML page (self-contained, SVG plots): the verdict, the deformation vectors
    /// at each phase, the mean and the spread over time.
    #[arg(long, value_name = "FILE.html")]
    report: Option<PathBuf>,
    /// Exit 1 unless the deformation is uniform (the outputs are written either way).
    #[arg(long)]
    require_uniform: bool,
}

/// `volumetric`: the outputs checked, the session read and evaluated, the summary printed,
/// the files written together.
pub(crate) fn run(args: VolumetricArgs, out: &mut impl Write) -> Result<()> {
    let outputs: Vec<&PathBuf> = [&args.json, &args.report].into_iter().flatten().collect();
    let paths: Vec<&std::path::Path> = outputs.iter().map(|p| p.as_path()).collect();
    crate::check_paths(&paths, &[])?;
    let options = Options {
        tolerance_share: args.tolerance_share,
        phases_h: args.phases.clone(),
        time_base: TimeBase::parse(&args.time_base)?,
    };
    let visits = mtcal_volumetric::read_session(&args.session)?;
    let evaluation = mtcal_volumetric::evaluate(&visits, &options)?;
    write!(out, "{}", evaluation.summary())?;
    // Every output built first, then written together: an error in any leaves none behind.
    let mut files = Outputs::new();
    if let Some(path) = &args.json {
        files.file(path, evaluation.to_json());
    }
    if let Some(path) = &args.report {
        files.file(path, mtcal_report::render_volumetric(&page(&evaluation))?);
    }
    crate::commit(out, files)?;
    match (args.require_uniform, evaluation.homogeneity.verdict) {
        (true, v) if v != Verdict::Uniform => Err(crate::ChecksFailed(format!(
            "--require-uniform: the deformation is {}",
            v.as_str()
        ))
        .into()),
        _ => Ok(()),
    }
}

/// The report page's data from the evaluation.
fn page(e: &Evaluation) -> VolumetricPage {
    let h = &e.homogeneity;
    let points = e.visits.points.len();
    let mut facts = vec![
        e.cycles.describe(points),
        format!("time base: {}", e.time_base.why),
        format!("noise: {}", e.noise.how()),
    ];
    facts.extend(e.notes.iter().cloned());
    VolumetricPage {
        title: format!("mtcal volumetric — {}", session_name(e)),
        session: e.visits.session.display().to_string(),
        verdict: h.verdict.as_str().to_string(),
        sentence: h.sentence.clone(),
        verdict_t_h: h.t_s / 3600.0,
        tolerance_share: h.tolerance_share,
        rows: h
            .axes
            .iter()
            .map(|a| {
                let s = &a.spread;
                VolumetricRow {
                    axis: a.axis,
                    mean_um: s.mean_um,
                    mean_u95_um: s.mean_u95_um,
                    range_um: s.range_um,
                    range_interval_um: s.range_interval_um,
                    range_floor_um: s.range_floor_um,
                    share: s.range_share,
                    share_interval: s.range_share_interval,
                    std_um: s.std_um,
                    std_interval_um: s.std_interval_um,
                    std_floor_um: s.std_floor_um,
                    verdict: a.verdict.as_str().to_string(),
                }
            })
            .collect(),
        facts,
        series: series(e),
        phases: e
            .snapshots
            .iter()
            .map(|s| VectorField {
                title: format!("{:.2} h (cycle {})", s.t_s / 3600.0, s.instant + 1),
                points: s
                    .points
                    .iter()
                    .map(|p| VectorPoint {
                        name: p.name.clone(),
                        position_mm: p.position_mm,
                        deformation_um: p.deformation_um,
                    })
                    .collect(),
            })
            .collect(),
    }
}

fn session_name(e: &Evaluation) -> String {
    e.visits.session.file_name().map_or_else(
        || e.visits.session.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

fn series(e: &Evaluation) -> VolumetricSeries {
    let per_axis = |f: &dyn Fn(&mtcal_volumetric::AxisSpread) -> f64| {
        [0, 1, 2].map(|i| e.instants.iter().map(|k| f(&k.axes[i])).collect())
    };
    VolumetricSeries {
        t_h: e.instants.iter().map(|k| k.t_s / 3600.0).collect(),
        mean_um: per_axis(&|a| a.mean_um),
        mean_u95_um: per_axis(&|a| a.mean_u95_um),
        range_um: per_axis(&|a| a.range_um),
        range_floor_um: per_axis(&|a| a.range_floor_um),
        std_um: per_axis(&|a| a.std_um),
        std_floor_um: per_axis(&|a| a.std_floor_um),
    }
}
