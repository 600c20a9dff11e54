//! Snapshots: every point's deformation vector at chosen instants (source 000's "phases").

use crate::VolumetricError;
use crate::points::Visits;
use crate::stats::Instant;
use crate::verdict::Homogeneity;

/// One point in a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct SnapshotPoint {
    pub name: String,
    /// Commanded X, Y, Z of the point, mm.
    pub position_mm: [f64; 3],
    pub deformation_um: [f64; 3],
    pub u95_um: [f64; 3],
}

/// The deformation field at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The time asked for, h (`None`: chosen by default).
    pub requested_h: Option<f64>,
    /// Index into the instants.
    pub instant: usize,
    pub t_s: f64,
    pub points: Vec<SnapshotPoint>,
}

/// A snapshot at the instant nearest each of `phases_h`; none asked: the verdict's instant
/// and the last one. A time more than one cycle's spacing before the first instant or after
/// the last is refused.
pub(crate) fn snapshots(
    visits: &Visits,
    instants: &[Instant],
    phases_h: &[f64],
    homogeneity: &Homogeneity,
) -> Result<Vec<Snapshot>, VolumetricError> {
    let chosen: Vec<(Option<f64>, usize)> = match phases_h.is_empty() {
        true => {
            let last = instants.len() - 1;
            let mut v = vec![(None, homogeneity.instant)];
            if last != homogeneity.instant {
                v.push((None, last));
            }
            v
        }
        false => phases_h
            .iter()
            .map(|&h| {
                let k = nearest(instants, h)
                    .map_err(|m| VolumetricError::Options(format!("--phase {m}")))?;
                Ok((Some(h), k))
            })
            .collect::<Result<_, VolumetricError>>()?,
    };
    Ok(chosen
        .into_iter()
        .map(|(requested_h, k)| snapshot(visits, &instants[k], requested_h, k))
        .collect())
}

/// The instant nearest `h` hours; a time more than one cycle's spacing outside them is refused
/// (the message says why).
pub(crate) fn nearest(instants: &[Instant], h: f64) -> Result<usize, String> {
    let t = h * 3600.0;
    let first = instants[0].t_s;
    let last = instants[instants.len() - 1].t_s;
    let spacing = match instants.len() > 1 {
        true => (last - first) / (instants.len() - 1) as f64,
        false => 0.0,
    };
    if t < first - spacing || t > last + spacing {
        return Err(format!(
            "{h} h: the session's instants run from {:.2} h to {:.2} h",
            first / 3600.0,
            last / 3600.0
        ));
    }
    Ok(instants
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1.t_s - t).abs().total_cmp(&(b.1.t_s - t).abs()))
        .map_or(0, |(k, _)| k))
}

fn snapshot(visits: &Visits, at: &Instant, requested_h: Option<f64>, k: usize) -> Snapshot {
    Snapshot {
        requested_h,
        instant: k,
        t_s: at.t_s,
        points: visits
            .points
            .iter()
            .enumerate()
            .map(|(j, p)| SnapshotPoint {
                name: p.name.clone(),
                position_mm: p.position_mm,
                deformation_um: at.points_um[j],
                u95_um: at.points_u95_um[j],
            })
            .collect(),
    }
}
