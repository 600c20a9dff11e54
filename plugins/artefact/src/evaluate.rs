//! The plate's own evaluation of one run: per placement, the best-fit comparison of the measured
//! centres with the calibrated positions that a plate report gives without any machine model.

use crate::plate::{Term, machine_fit, similarity};
use crate::setup::{ArtefactSetup, frame_of};
use mtcal_instrument::{Evaluation, Metric, Unit};

/// Per placement probed at three features or more (names suffixed ` (<placement>)` when the
/// set-up has several): the similarity fit's RMS and largest deviation of the measured centres
/// from the calibrated ones after the best offset, rotation and scale (`similarity-fit RMS
/// deviation`, `largest deviation after similarity fit`, µm) and its scale (ppm); with four
/// features or more the apparent X/Y scale difference (`EXX − EYY slope`, ppm) and
/// squareness (`apparent EC0Y`, µrad) of the affine fit. All in the plane of the plate (x, y).
///
/// The values mix the machine's errors and the plate's own: they are what a plate report
/// states, for comparison; the identification separates the two across placements.
pub fn evaluate(ev: &Evaluation<'_>) -> Vec<Metric> {
    let Some(setup) = ev.setup_as::<ArtefactSetup>() else {
        return Vec::new();
    };
    let Ok((xyz, _)) = frame_of(ev.machine) else {
        return Vec::new();
    };
    let (na, nc, nf) = (ev.machine.n_axes(), setup.dim(), setup.features().len());
    let n = ev.t.len();
    if ev.labels.len() != n || ev.readings.len() != n * nc || nf == 0 {
        return Vec::new();
    }
    let several = setup.placements().len() > 1;
    let mut out = Vec::new();
    for (j, placement) in setup.placements().iter().enumerate() {
        let (mut nominal, mut measured) = (Vec::new(), Vec::new());
        for i in 0..n {
            let label = ev.labels[i] as usize;
            if label / nf != j {
                continue;
            }
            let at = setup.nominal_xyz(j, label % nf) * 1e3;
            let q = &ev.q[i * na..(i + 1) * na];
            let r = &ev.readings[i * nc..(i + 1) * nc];
            // Prepared readings are the measured centre minus the probed position.
            let m = [(q[xyz[0]] + r[0]) * 1e3, (q[xyz[1]] + r[1]) * 1e3];
            nominal.push([at.x, at.y]);
            measured.push(m);
        }
        if nominal.len() < 3 {
            continue;
        }
        let name = |what: &str| {
            if several {
                format!("{what} ({})", placement.name)
            } else {
                what.to_string()
            }
        };
        let sim = similarity(&nominal, &measured);
        let largest = sim
            .fit
            .residuals
            .iter()
            .map(|r| r[0].hypot(r[1]))
            .fold(0.0, f64::max);
        let metric = |what: &str, value: f64, unit: Unit| Metric::new(name(what), value, unit);
        out.push(metric(
            "similarity-fit RMS deviation",
            sim.fit.radial_rms(None, 0) * 1e-3,
            Unit::Um,
        ));
        out.push(metric(
            "largest deviation after similarity fit",
            largest * 1e-3,
            Unit::Um,
        ));
        out.push(metric("scale (similarity fit)", sim.scale - 1.0, Unit::Ppm));
        if nominal.len() >= 4 {
            let affine = machine_fit(&nominal, &measured, &[]);
            let get = |t: Term| affine.get(t).map_or(0.0, |(v, _)| v);
            out.push(metric(
                "EXX − EYY slope (affine fit)",
                get(Term::Exx1) - get(Term::Eyy1),
                Unit::Ppm,
            ));
            out.push(metric(
                "apparent EC0Y (affine fit)",
                get(Term::Ec0y),
                Unit::Urad,
            ));
        }
    }
    out
}
