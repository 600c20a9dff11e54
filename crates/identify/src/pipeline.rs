//! The identification as `mtcal identify` runs it: the parameters the runs cannot determine
//! held ([`crate::base`]), the fit, and the report with the model applied.

use crate::IdentifyError;
use crate::base::{BaseModel, identifiable_study};
use crate::study::Study;
use mtcal_solve::Options;

/// What [`identify`] returns: the study fitted (the parameters the runs cannot determine
/// held), its solution, the report with [`BaseModel`] applied, and the model (`None` when the
/// session names its parameters).
#[derive(Debug)]
pub struct Identified {
    pub study: Study,
    pub solution: mtcal_solve::Solution,
    pub identification: crate::report::Identification,
    pub base: Option<BaseModel>,
}

/// [`identifiable_study`], then [`crate::identify_with_solution`], then the report with the
/// model applied: what `mtcal identify` does before its extras.
pub fn identify(
    study: Study,
    options: &Options,
    observer: &mut dyn mtcal_solve::Observer,
) -> Result<Identified, IdentifyError> {
    let (study, base) = identifiable_study(study, options)?;
    let (mut identification, solution) = crate::identify_with_solution(&study, options, observer)?;
    if let Some(base) = &base {
        identification.apply_base(base, &study, &solution);
    }
    Ok(Identified {
        study,
        solution,
        identification,
        base,
    })
}
