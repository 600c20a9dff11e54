//! The points of the test and their visits, as read ([`crate::read_session`]) or built in
//! memory ([`Visits::new`]).

use std::path::PathBuf;

use crate::VolumetricError;

/// One visit of a point: the head on its ball once.
#[derive(Debug, Clone, PartialEq)]
pub struct Visit {
    /// s on the session's clock.
    pub t_s: f64,
    /// `dx, dy, dz`, µm.
    pub reading_um: [f64; 3],
    /// The run it is a row of, and the row (0-based, data rows).
    pub run: String,
    pub row: usize,
}

/// A ball set-up at one commanded position of the rotary axes.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// `<set-up>@<axis><degrees>…` (`ball1@C120`), or the set-up's name when no rotary axis
    /// varies in the session.
    pub name: String,
    pub setup: String,
    /// The rotary axes that vary in the session and where this point has them, degrees.
    pub rotary_deg: Vec<(char, f64)>,
    /// Where the point is: the commanded X, Y, Z of its visits (their mean), mm; an axis the
    /// machine lacks is 0.
    pub position_mm: [f64; 3],
    /// In time order, at least two.
    pub visits: Vec<Visit>,
}

/// The visits of a session, by point.
#[derive(Debug, Clone, PartialEq)]
pub struct Visits {
    /// The session folder (empty in memory).
    pub session: PathBuf,
    /// The machine as the manifest writes it.
    pub machine: String,
    /// In the order of first visit.
    pub points: Vec<Point>,
    /// The σ the set-ups state (`sigma_um`), if any do: (smallest, largest), µm.
    pub stated_sigma_um: Option<(f64, f64)>,
    /// What was left out, and why.
    pub notes: Vec<String>,
}

impl Visits {
    /// Visits built in memory: checks what [`crate::read_session`] checks (at least one point,
    /// two visits or more per point, finite values, strictly increasing times) and orders the
    /// points by their first visit.
    pub fn new(machine: &str, mut points: Vec<Point>) -> Result<Visits, VolumetricError> {
        if points.is_empty() {
            return Err(VolumetricError::invalid(
                machine,
                "no point: a volumetric thermal test visits balls (rtest runs)",
            ));
        }
        for p in &points {
            check_point(p)?;
        }
        points.sort_by(|a, b| a.visits[0].t_s.total_cmp(&b.visits[0].t_s));
        Ok(Visits {
            session: PathBuf::new(),
            machine: machine.to_string(),
            points,
            stated_sigma_um: None,
            notes: Vec::new(),
        })
    }

    /// Visits in total.
    pub fn len(&self) -> usize {
        self.points.iter().map(|p| p.visits.len()).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every visit as `(point, visit index)` in time order.
    pub fn in_time_order(&self) -> Vec<(usize, usize)> {
        let mut all: Vec<(usize, usize)> = self
            .points
            .iter()
            .enumerate()
            .flat_map(|(j, p)| (0..p.visits.len()).map(move |v| (j, v)))
            .collect();
        all.sort_by(|a, b| {
            let (ta, tb) = (self.visit(*a).t_s, self.visit(*b).t_s);
            ta.total_cmp(&tb).then(a.cmp(b))
        });
        all
    }

    pub fn visit(&self, (j, v): (usize, usize)) -> &Visit {
        &self.points[j].visits[v]
    }
}

/// Two visits or more, finite, strictly increasing in time.
pub(crate) fn check_point(p: &Point) -> Result<(), VolumetricError> {
    let at = |v: &Visit| format!("run `{}` row {}", v.run, v.row + 1);
    if let Some(v) = p
        .visits
        .iter()
        .find(|v| !v.t_s.is_finite() || v.reading_um.iter().any(|r| !r.is_finite()))
    {
        return Err(VolumetricError::invalid(
            at(v),
            format!("point `{}`: a time or reading that is not a number", p.name),
        ));
    }
    match p.visits.as_slice() {
        [] => Err(VolumetricError::invalid(
            &p.name,
            "a point without visits".to_string(),
        )),
        [only] => Err(VolumetricError::invalid(
            at(only),
            format!(
                "point `{}` is visited once (t = {} s): its deformation needs a second visit",
                p.name, only.t_s
            ),
        )),
        visits => {
            for pair in visits.windows(2) {
                if pair[1].t_s <= pair[0].t_s {
                    return Err(VolumetricError::invalid(
                        at(&pair[1]),
                        format!(
                            "point `{}`: visited at t = {} s after a visit at t = {} s ({}); \
                             its visits must come at increasing times",
                            p.name,
                            pair[1].t_s,
                            pair[0].t_s,
                            at(&pair[0])
                        ),
                    ));
                }
            }
            Ok(())
        }
    }
}

/// The set-ups' visit sequences: per point, per visit, its index among all visits of its
/// set-up in time order (the noise's AR(1) runs along them: the head seating on one ball);
/// and per set-up, its points.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SetupSequence {
    pub index: Vec<Vec<usize>>,
    pub groups: Vec<Vec<usize>>,
}

impl SetupSequence {
    pub(crate) fn of(visits: &Visits) -> SetupSequence {
        let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
        for (j, p) in visits.points.iter().enumerate() {
            match groups.iter_mut().find(|(s, _)| *s == p.setup) {
                Some((_, g)) => g.push(j),
                None => groups.push((p.setup.clone(), vec![j])),
            }
        }
        let mut index: Vec<Vec<usize>> = visits
            .points
            .iter()
            .map(|p| vec![0; p.visits.len()])
            .collect();
        for (_, g) in &groups {
            let mut all: Vec<(f64, usize, usize)> = g
                .iter()
                .flat_map(|&j| {
                    let p = &visits.points[j];
                    (0..p.visits.len()).map(move |v| (p.visits[v].t_s, j, v))
                })
                .collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
            for (k, &(_, j, v)) in all.iter().enumerate() {
                index[j][v] = k;
            }
        }
        SetupSequence {
            index,
            groups: groups.into_iter().map(|(_, g)| g).collect(),
        }
    }
}
