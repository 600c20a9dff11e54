//! The machine model a study fits: loaded from the session's machine, with raised orders,
//! reduced to the estimated coefficients (and those with a start value).

use super::*;

pub(super) fn load_session_machine(session: &Session) -> Result<LoadedMachine, IdentifyError> {
    let arg: PathBuf = match &session.machine_path {
        Some(p) => p.clone(),
        None => PathBuf::from(&session.machine),
    };
    load_machine(&arg.to_string_lossy(), Reading::default()).map_err(|e| IdentifyError::Machine {
        at: session.machine_at.to_string(),
        message: e.to_string(),
    })
}

/// Raises the order of component error `name` in `config` by `extra` (Legendre degree or
/// Fourier harmonics).
pub(crate) fn raise_order(
    config: &mut [mtcal_kinematics::ParamConfig],
    name: &ParamName,
    extra: usize,
) -> Result<(), String> {
    let entry = config
        .iter_mut()
        .find(|c| &c.name == name)
        .ok_or_else(|| format!("{name} is not in the error model: its order cannot be raised"))?;
    entry.basis = match entry.basis.take() {
        Some(Basis::Legendre {
            lo,
            hi,
            min_degree,
            max_degree,
        }) => Some(
            Basis::legendre(lo, hi, min_degree, max_degree + extra).map_err(|e| e.to_string())?,
        ),
        Some(Basis::Fourier {
            min_harmonic,
            max_harmonic,
        }) => Some(Basis::fourier(min_harmonic, max_harmonic + extra).map_err(|e| e.to_string())?),
        other => {
            entry.basis = other;
            return Err(format!(
                "{name}: only Legendre and Fourier bases have an order to raise"
            ));
        }
    };
    Ok(())
}

/// The model restricted to the parameters that are estimated or have a nonzero base value, and
/// per coefficient of it the index in the full model. The kept parameters keep their bases, so
/// the restricted model gives the same poses for the same values.
pub(super) fn reduced_model(
    machine: &LoadedMachine,
    config: &[mtcal_kinematics::ParamConfig],
    model: &MachineModel,
    estimated: &[usize],
    base: &[f64],
) -> Result<(MachineModel, Vec<usize>), IdentifyError> {
    let kept_params = kept_params(model, estimated, base);
    // `ErrorModel::new` lays the parameters out in configuration order.
    let kept: Vec<_> = config
        .iter()
        .zip(&kept_params)
        .filter(|(_, k)| **k)
        .map(|(entry, _)| entry.clone())
        .collect();
    let index = coefficients_of(model, &kept_params);
    let reduced =
        MachineModel::new(machine.machine.clone(), &kept).map_err(|e| IdentifyError::Model {
            source_name: machine.config_source.clone(),
            message: e.to_string(),
        })?;
    debug_assert_eq!(reduced.n_coeffs(), index.len());
    Ok((reduced, index))
}

/// Per parameter of `model`, whether the reduced model keeps it: estimated, or with a
/// nonzero base value.
pub(super) fn kept_params(model: &MachineModel, estimated: &[usize], base: &[f64]) -> Vec<bool> {
    let mut used = vec![false; model.n_coeffs()];
    for &k in estimated {
        used[k] = true;
    }
    model
        .errors()
        .params()
        .iter()
        .map(|p| (p.offset..p.offset + p.len).any(|k| used[k] || base[k] != 0.0))
        .collect()
}

/// The coefficients of `model` the reduced model keeps, in order ([`kept_params`]).
pub(super) fn kept_coefficients(
    model: &MachineModel,
    estimated: &[usize],
    base: &[f64],
) -> Vec<usize> {
    coefficients_of(model, &kept_params(model, estimated, base))
}

/// The coefficients of `model`'s parameters that `kept` marks, in order.
fn coefficients_of(model: &MachineModel, kept: &[bool]) -> Vec<usize> {
    model
        .errors()
        .params()
        .iter()
        .zip(kept)
        .filter(|(_, k)| **k)
        .flat_map(|(p, _)| p.offset..p.offset + p.len)
        .collect()
}

/// `[identify] parameters = ["EC0Y", …]`: the machine parameters to estimate (all of a
/// component error's coefficients); default: every parameter of the error model.
pub(super) fn estimated_coefficients(
    session: &Session,
    names: Option<&[String]>,
    model: &MachineModel,
) -> Result<Vec<usize>, IdentifyError> {
    let Some(names) = names else {
        return Ok((0..model.n_coeffs()).collect());
    };
    let bad = |m: String| identify_key(session, "parameters", &m);
    let mut out = Vec::new();
    for s in names {
        let name: ParamName = s
            .parse()
            .map_err(|e| bad(format!("`{s}` is not an ISO 230-1 parameter name: {e}")))?;
        let p = model.errors().find(&name).ok_or_else(|| {
            bad(format!(
                "`{s}` is not in this machine's error model ({} parameters; see its .errors.toml)",
                model.errors().params().len()
            ))
        })?;
        out.extend(p.offset..p.offset + p.len);
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}
