//! An `Identification` for people: the verdict a person reads first, the plain-text summary
//! (its JSON is [`super::IdentifyJson`]).

use super::*;

impl Identification {
    /// The verdict a person reads first: did the fit converge, and does the model explain the
    /// recordings? `None` when both hold.
    pub fn verdict(&self) -> Option<String> {
        if !self.solver.converged {
            return Some(format!(
                "NOT CONVERGED ({:?}) after {} iterations: the numbers below are the last iterate, \
                 not a calibration",
                self.solver.termination, self.solver.iterations
            ));
        }
        if !chi2_within_noise(self.fit.chi2_reduced, self.fit.dof) {
            let worst = self
                .fit
                .runs
                .iter()
                .flat_map(|r| r.channels.iter().map(move |c| (r, c)))
                .max_by(|a, b| a.1.chi2.total_cmp(&b.1.chi2));
            let total: f64 = self
                .fit
                .runs
                .iter()
                .flat_map(|r| &r.channels)
                .map(|c| c.chi2)
                .sum();
            let at = worst.map_or(String::new(), |(r, c)| {
                most_of_it(&r.name, &c.name, c.rms, &c.unit, c.chi2 / total)
            });
            return Some(format!(
                "THE MODEL DOES NOT EXPLAIN THE RECORDINGS: chi2/dof {:.2} where the noise alone \
                 gives {:.2} ± {:.2}{at}. The parameters below are not a calibration: check the \
                 set-up (R-test `mount`, units, axis signs) or look for what the model leaves \
                 out (--search)",
                self.fit.chi2_reduced,
                1.0,
                chi2_spread(self.fit.dof)
            ));
        }
        if let Some((stated, chi2_reduced)) = self.beyond_stated_noise() {
            let at = stated.worst.as_ref().map_or(String::new(), |w| {
                most_of_it(&w.run, &w.channel, w.rms, &w.unit, w.chi2 / stated.chi2)
            });
            return Some(format!(
                "THE MODEL DOES NOT EXPLAIN THE RECORDINGS AT THE NOISE THEIR FILES STATE: chi2/dof \
                 {:.2} against the stated σ where the noise alone gives {:.2} ± {:.2}{at}. The fit \
                 weighs the runs by the noise their residuals show (up to {:.2} × the stated σ), \
                 and at that noise nothing is left over: either the instruments are that much \
                 noisier than stated, or the recordings hold what the model leaves out (a shape \
                 too short or too sparse to tell from noise). Check the stated σ; if it is right, \
                 the parameters below are not a calibration",
                chi2_reduced,
                1.0,
                chi2_spread(self.fit.dof),
                stated.largest_scale
            ));
        }
        None
    }

    /// Whether χ²/dof lies within what noise of the stated σ could give: below twice, and
    /// below 1 + 5 standard deviations of χ²/dof. A σ stated 20 % off or mildly coloured noise
    /// stays inside; readings in the wrong frame (χ²/dof of 50) do not. A fit that weighs the
    /// runs by the noise their residuals show is judged at the stated σ as well: residuals read
    /// as noise at several times the stated σ are not explained by calling them noise.
    pub fn model_explains_recordings(&self) -> bool {
        chi2_within_noise(self.fit.chi2_reduced, self.fit.dof)
            && self.beyond_stated_noise().is_none()
    }

    /// The fit against the stated σ and its χ²/dof, when the fit assumed another noise and at
    /// the stated σ it is beyond what noise could give.
    fn beyond_stated_noise(&self) -> Option<(&AgainstStated, f64)> {
        let stated = self.against_stated.as_ref()?;
        let chi2_reduced = stated.chi2 / self.fit.dof.max(1) as f64;
        (!chi2_within_noise(chi2_reduced, self.fit.dof)).then_some((stated, chi2_reduced))
    }

    /// A plain-text summary for the terminal (a long parameter table summarised).
    pub fn summary(&self) -> String {
        self.summary_with(false)
    }

    /// [`Self::summary`], every parameter and combination on its own line when `verbose`.
    pub fn summary_with(&self, verbose: bool) -> String {
        self.summary_beside(verbose, None)
    }

    /// [`Self::summary_with`] with the verdicts against a tolerance file after what the runs
    /// determine.
    pub fn summary_beside(
        &self,
        verbose: bool,
        acceptance: Option<&mtcal_acceptance::Acceptance>,
    ) -> String {
        let mut s = String::new();
        if let Some(v) = self.verdict() {
            let _ = writeln!(s, "{v}\n");
        }
        let _ = writeln!(
            s,
            "fit: rms {:.3} um, chi2/dof {:.3} ({} dof), {} iterations{}, rank {}/{}, condition {:.3e}",
            self.fit.rms_um,
            self.fit.chi2_reduced,
            self.fit.dof,
            self.solver.iterations,
            if self.solver.converged {
                ""
            } else {
                " (NOT converged)"
            },
            self.solver.rank,
            self.solver.parameters,
            self.solver.condition_number
        );
        for line in &self.noise {
            let _ = writeln!(
                s,
                "noise (from the residuals; the fit weighs by it): {line}"
            );
        }
        let _ = if self.solver.converged && self.model_explains_recordings() {
            writeln!(s, "\nidentified parameters (95 % intervals):")
        } else {
            writeln!(
                s,
                "\nfitted values (NOT a calibration: see the first line; 95 % intervals):"
            )
        };
        // A long table (a rich model) is summarised on the screen: single-valued errors in
        // full, a component error's coefficients on one line, set-up parameters counted; every
        // number is in the JSON and with `--verbose`.
        let concise =
            !verbose && self.parameters.len() + self.combinations.len() > SCREEN_PARAMETERS;
        let mut components: Vec<(String, Vec<&ParameterValue>)> = Vec::new();
        let mut setup = 0;
        for p in &self.parameters {
            if concise && p.kind != "machine" && p.kind != "effect" {
                setup += 1;
                continue;
            }
            if concise && let Some((component, _)) = p.name.split_once('.') {
                match components.iter_mut().find(|(c, _)| c == component) {
                    Some((_, list)) => list.push(p),
                    None => components.push((component.to_string(), vec![p])),
                }
                continue;
            }
            let _ = writeln!(
                s,
                "  {:<24} {:>12.4} ± {:<10.4} {:<5} {}{}",
                p.name,
                unsigned_zero(p.value, 4),
                p.u95,
                p.unit,
                if p.kind == "machine" { "" } else { &p.kind },
                given_held(p.u95_given_held, p.u95)
            );
        }
        for (component, list) in &components {
            if list.len() > SCREEN_TERMS {
                // A joint model's gains: dozens, each meaningful only with the others.
                let _ = writeln!(
                    s,
                    "  {component:<6} {} coefficients (in the JSON, or --verbose)",
                    list.len()
                );
                continue;
            }
            let terms: Vec<String> = list
                .iter()
                .map(|p| {
                    let term = p.name.split_once('.').map_or("", |(_, t)| t);
                    format!("{term} {:.2} ± {:.2}", unsigned_zero(p.value, 2), p.u95)
                })
                .collect();
            let _ = writeln!(s, "  {component:<6} {} {}", terms.join(", "), list[0].unit);
        }
        if setup > 0 {
            let _ = writeln!(
                s,
                "  and {setup} set-up parameters (ball, pivot, tool…; in the JSON, or --verbose)"
            );
        }
        if !self.combinations.is_empty() {
            let _ = writeln!(
                s,
                "\nidentified combinations (these runs cannot separate their members; 95 % intervals):"
            );
            let mut hidden = 0;
            for c in &self.combinations {
                if concise && (c.name.contains('.') || c.kind != "machine") {
                    hidden += 1;
                    continue;
                }
                // The four largest terms on the screen; all of them in the JSON.
                let shown = crate::base::expression(&c.name, &c.terms[..c.terms.len().min(4)]);
                let more = if c.terms.len() > 4 { " + …" } else { "" };
                let _ = writeln!(
                    s,
                    "  {:<40} {:>12.4} ± {:<10.4} {}{}",
                    format!("{shown}{more}"),
                    unsigned_zero(c.value, 4),
                    c.u95,
                    c.unit,
                    given_held(c.u95_given_held, c.u95)
                );
            }
            if hidden > 0 {
                let _ = writeln!(
                    s,
                    "  and {hidden} of component coefficients and set-up parameters (in the JSON, \
                     or --verbose)"
                );
            }
        }
        self.write_unidentifiable(&mut s);
        if !self.weakly_determined.is_empty() {
            let _ = writeln!(
                s,
                "\nweakly determined by these runs (the numbers above are given, but mean little):"
            );
            for w in &self.weakly_determined {
                let _ = writeln!(s, "  {}: {}", w.parameters.join(", "), w.why);
            }
        }
        if let Some(acceptance) = acceptance {
            s.push_str(&acceptance.summary());
        }
        if self.mismatch.detected {
            let _ = writeln!(
                s,
                "\nmismatch: the residuals are not noise (family-wise α = 5 %):"
            );
            // Where the excess lies on the screen; every test with its p-value in the JSON
            // (`mismatch_tests`).
            let located: Vec<&String> = self
                .mismatch_detail
                .iter()
                .filter(|l| l.contains("of the excess"))
                .collect();
            let shown: Vec<&String> = if located.is_empty() {
                self.mismatch_detail.iter().take(SCREEN_MISMATCH).collect()
            } else {
                located.into_iter().take(SCREEN_MISMATCH).collect()
            };
            for line in &shown {
                let _ = writeln!(s, "  {line}");
            }
            let rejected = self
                .mismatch_detail
                .iter()
                .filter(|l| !l.contains("of the excess"))
                .count();
            let _ = writeln!(
                s,
                "  ({rejected} structure tests reject the noise; each with its p-value in the JSON, \
                 `mismatch_tests`)"
            );
        } else {
            let _ = writeln!(
                s,
                "\nmismatch: none found (every fitted run's residuals pass the structure tests, \
                 family-wise α = 5 %)"
            );
        }
        let _ = writeln!(s, "\nruns:");
        for r in self.fit.runs.iter().chain(&self.validation) {
            let role = if self.validation.contains(r) {
                "validate"
            } else {
                "fit"
            };
            let chans: Vec<String> = r
                .channels
                .iter()
                .map(|c| format!("{} {:.3}", c.name, c.rms))
                .collect();
            let _ = writeln!(
                s,
                "  {:<22} {:<8} {:<8} rms {:.3} um  ({})",
                r.name,
                r.instrument,
                role,
                r.rms_um,
                chans.join(", ")
            );
            for m in &r.metrics {
                let value = unsigned_zero(m.value, 3);
                let _ = writeln!(s, "  {:<22}   {}: {value:.3} {}", "", m.name, m.unit);
            }
        }
        if !self.diagnostics.is_empty() {
            let _ = writeln!(
                s,
                "\ndiagnostics in the instruments' terms (ranked by their contribution; 95 % intervals):"
            );
            for d in &self.diagnostics {
                s.push_str(&d.summary(verbose));
            }
        }
        if !self.location_series.is_empty() {
            s.push_str(&crate::series::summary(&self.location_series, verbose));
        }
        for (run, terms) in &self.undetermined_validation {
            let named: Vec<String> = terms
                .iter()
                .map(|t| format!("{} ({:.2} per unit)", t.name, t.coefficient))
                .collect();
            let _ = writeln!(
                s,
                "  {run}: its prediction depends on what the fitted runs do not determine: {}; \
                 a fitted run that moves them (another angle or position) would",
                named.join(", ")
            );
        }
        s
    }
}

/// `(± u if the undetermined are at their start)` where that interval is clearly narrower than
/// the full one: the runs alone say more than the held parameters' prior lets them.
pub(super) fn given_held(u95: Option<f64>, full: f64) -> String {
    match u95 {
        Some(u) if u < 0.8 * full => format!("  (± {u:.4} if the undetermined are zero)"),
        _ => String::new(),
    }
}

/// Where a verdict's χ² lies: "; most of it in run `r`, channel c (rms …, N % of the χ²)";
/// `share` of the total (a total of zero gives no share).
fn most_of_it(run: &str, channel: &str, rms: f64, unit: &str, share: f64) -> String {
    let percent = if share.is_finite() {
        100.0 * share
    } else {
        0.0
    };
    format!(
        "; most of it in run `{run}`, channel {channel} (rms {rms:.3} {unit}, {percent:.0} % of the χ²)"
    )
}

/// Whether χ²/dof (against the stated σ) lies within what noise could give, a σ stated 20 %
/// off or mildly coloured included: below twice, and below 1 + 5 standard deviations of χ²/dof
/// ([`Identification::model_explains_recordings`]).
pub fn chi2_within_noise(chi2_reduced: f64, dof: usize) -> bool {
    chi2_reduced <= (1.0 + 5.0 * chi2_spread(dof)).max(2.0)
}

/// One standard deviation of χ²/dof for pure noise: `√(2/dof)`.
pub(super) fn chi2_spread(dof: usize) -> f64 {
    (2.0 / dof.max(1) as f64).sqrt()
}

/// Parameters and combinations beyond this make the screen summary concise.
pub(super) const SCREEN_PARAMETERS: usize = 30;

/// Coefficients of one component or effect shown on one line of the concise table; more are
/// counted.
pub(super) const SCREEN_TERMS: usize = 8;

/// At most this many lines of where the residuals are not noise on the screen.
pub(super) const SCREEN_MISMATCH: usize = 6;

/// Null-space directions longer than this are named by their largest members on the screen.
pub(super) const SCREEN_MEMBERS: usize = 6;
/// At most this many null-space directions on the screen; all of them are in the JSON.
pub(super) const SCREEN_DIRECTIONS: usize = 8;

impl Identification {
    /// What the runs cannot determine, readable on a screen: held parameters grouped by why,
    /// short null directions as they are, long ones by their size; the full list is in the
    /// JSON.
    pub(super) fn write_unidentifiable(&self, s: &mut String) {
        let held_names: Vec<&str> = self.held.iter().map(|h| h.name.as_str()).collect();
        let directions: Vec<&Unidentifiable> = self
            .unidentifiable
            .iter()
            .filter(|u| {
                !(u.parameters.len() == 1 && held_names.contains(&u.parameters[0].as_str()))
            })
            .filter(|u| !self.combinations.iter().any(|c| c.name == u.parameters[0]))
            .collect();
        if directions.is_empty() && self.held.is_empty() {
            return;
        }
        let _ = writeln!(s, "\nnot identifiable from these runs (no values given):");
        for u in directions.iter().take(SCREEN_DIRECTIONS) {
            if u.parameters.len() <= SCREEN_MEMBERS {
                let _ = writeln!(s, "  {}: {}", u.parameters.join(", "), u.why);
            } else {
                let _ = writeln!(
                    s,
                    "  a combination of {} parameters ({}, …) is not observed",
                    u.parameters.len(),
                    u.parameters[..3].join(", ")
                );
            }
        }
        if directions.len() > SCREEN_DIRECTIONS {
            let _ = writeln!(
                s,
                "  … and {} more directions (all in the JSON, `unidentifiable`)",
                directions.len() - SCREEN_DIRECTIONS
            );
        }
        let group = |f: &dyn Fn(&crate::base::HeldWhy) -> bool| -> Vec<&str> {
            self.held
                .iter()
                .filter(|h| f(&h.why))
                .map(|h| h.name.as_str())
                .collect()
        };
        use crate::base::HeldWhy;
        for (names, what) in [
            (
                group(&|w| matches!(w, HeldWhy::Aliased)),
                "seen only within the combinations above",
            ),
            (
                group(&|w| matches!(w, HeldWhy::TooWeak { .. })),
                "seen too weakly to determine (intervals in the JSON)",
            ),
            (
                group(&|w| matches!(w, HeldWhy::NotObserved)),
                "not observed at all",
            ),
        ] {
            if names.is_empty() {
                continue;
            }
            let shown: Vec<&str> = names.iter().take(10).copied().collect();
            let more = if names.len() > shown.len() {
                format!(", … ({} in all)", names.len())
            } else {
                String::new()
            };
            let _ = writeln!(s, "  {what}: {}{more}", shown.join(", "));
        }
        if !self.held.is_empty() {
            let _ = writeln!(
                s,
                "  (these {} are not given values: set-up parameters are held at their start, \
                 machine coefficients kept near it by a prior; `--suggest-model FILE` writes the \
                 model these runs identify)",
                self.held.len()
            );
        }
    }
}

/// `x`, or +0 when it prints as zero with `decimals` decimals (no `-0.0000` in a summary).
pub(super) fn unsigned_zero(x: f64, decimals: i32) -> f64 {
    if (x * 10f64.powi(decimals)).round() == 0.0 {
        0.0
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::unsigned_zero;

    #[test]
    fn a_value_that_prints_as_zero_prints_without_a_sign() {
        assert_eq!(format!("{:.4}", unsigned_zero(-0.00004, 4)), "0.0000");
        assert_eq!(format!("{:.4}", unsigned_zero(-0.0, 4)), "0.0000");
        assert_eq!(format!("{:.4}", unsigned_zero(-0.00006, 4)), "-0.0001");
        assert_eq!(format!("{:.3}", unsigned_zero(2.5, 3)), "2.500");
    }
}
