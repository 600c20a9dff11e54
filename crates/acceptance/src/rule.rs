//! The decision rules: a measured value, its expanded uncertainty `U` and a tolerance to a
//! verdict.
//!
//! ISO 14253-1 (the default): conformance is proven only when the value lies inside the
//! tolerance zone reduced by `U` on each side, non-conformance only when it lies outside the zone
//! enlarged by `U`; in between no decision can be made. The uncertainty always counts against
//! whoever wants to prove something. The simple rule (`decision_rule = "simple"`) has no guard
//! band: inside the zone passes, outside fails.

use serde::Serialize;

/// Which rule turns a value and its uncertainty into a [`Verdict`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum DecisionRule {
    /// ISO 14253-1: guard bands of `U` on both sides of every tolerance limit.
    #[default]
    #[serde(rename = "iso14253-1")]
    Iso14253_1,
    /// Simple acceptance: the tolerance limit itself decides; `U` is shown, not used.
    #[serde(rename = "simple")]
    Simple,
}

impl DecisionRule {
    /// The file's and the JSON's name of the rule.
    pub fn name(self) -> &'static str {
        match self {
            DecisionRule::Iso14253_1 => "iso14253-1",
            DecisionRule::Simple => "simple",
        }
    }

    /// The rule named `name` in a file, if it is one.
    pub fn parse(name: &str) -> Option<Self> {
        [DecisionRule::Iso14253_1, DecisionRule::Simple]
            .into_iter()
            .find(|r| r.name() == name)
    }
}

/// The outcome of one check, or of all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Verdict {
    /// Conformance proven (with the simple rule: the value is within the tolerance).
    #[serde(rename = "pass")]
    Pass,
    /// Non-conformance proven (with the simple rule: the value is beyond the tolerance).
    #[serde(rename = "fail")]
    Fail,
    /// Neither can be proven: the value is within `U` of a tolerance limit, or there is no
    /// value (a parameter the data cannot separate, a quantity no run measured).
    #[serde(rename = "cannot decide")]
    CannotDecide,
}

impl Verdict {
    /// As the summary and the report write it.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::CannotDecide => "cannot decide",
        }
    }
}

/// The shape of a tolerance zone.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Zone {
    /// `value ≤ T`: an upper limit on a quantity that is never negative (the ISO 230-2 and
    /// ISO 230-4 values).
    #[serde(rename = "upper")]
    Upper,
    /// `−T ≤ value ≤ T`: a signed parameter (`max_abs_um`, `max_abs_urad`).
    #[serde(rename = "two-sided")]
    TwoSided,
}

/// A verdict and, when the rule had to fall back, why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decision {
    pub verdict: Verdict,
    /// `Some` when the ISO 14253-1 rule was asked for but the value has no uncertainty.
    pub note: Option<&'static str>,
}

/// What a decision without an uncertainty says.
pub const NO_UNCERTAINTY: &str = "no uncertainty: simple acceptance";

/// The verdict on `value` against the tolerance `limit` (≥ 0) of `zone` under `rule`, with
/// the expanded uncertainty `u` (`None`: the instrument gives none, and the simple rule decides
/// with [`NO_UNCERTAINTY`] as its note).
///
/// ISO 14253-1 on the magnitude the zone limits (`value` for [`Zone::Upper`], `|value|` for
/// [`Zone::TwoSided`], the same on both sides): `≤ T − U` passes, `> T + U` fails, anything
/// between cannot be decided. So a value exactly on the inner guard-band edge passes, one
/// exactly on the outer edge cannot be decided, `U = 0` is the simple rule, and `U > T` never
/// passes.
pub fn decide(value: f64, u: Option<f64>, limit: f64, zone: Zone, rule: DecisionRule) -> Decision {
    let magnitude = match zone {
        Zone::Upper => value,
        Zone::TwoSided => value.abs(),
    };
    let (guard, note) = match (rule, u) {
        (DecisionRule::Simple, _) => (0.0, None),
        (DecisionRule::Iso14253_1, Some(u)) => (u.abs(), None),
        (DecisionRule::Iso14253_1, None) => (0.0, Some(NO_UNCERTAINTY)),
    };
    let verdict = if magnitude <= limit - guard {
        Verdict::Pass
    } else if magnitude > limit + guard {
        Verdict::Fail
    } else {
        Verdict::CannotDecide
    };
    Decision { verdict, note }
}

/// The verdict on many checks: any failure fails, otherwise any undecided check leaves it
/// undecided, otherwise it passes. No checks cannot be decided.
pub fn overall(verdicts: impl IntoIterator<Item = Verdict>) -> Verdict {
    let mut any = false;
    let mut undecided = false;
    for v in verdicts {
        any = true;
        match v {
            Verdict::Fail => return Verdict::Fail,
            Verdict::CannotDecide => undecided = true,
            Verdict::Pass => {}
        }
    }
    if undecided || !any {
        Verdict::CannotDecide
    } else {
        Verdict::Pass
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use DecisionRule::{Iso14253_1, Simple};
    use Verdict::{CannotDecide, Fail, Pass};
    use Zone::{TwoSided, Upper};

    fn iso(value: f64, u: f64, limit: f64, zone: Zone) -> Verdict {
        decide(value, Some(u), limit, zone, Iso14253_1).verdict
    }

    #[test]
    fn an_upper_limit_passes_only_inside_it_by_u_and_fails_only_beyond_it_by_u() {
        // T = 10, U = 2: the acceptance zone is [0, 8], the rejection zone (12, ∞).
        assert_eq!(iso(5.0, 2.0, 10.0, Upper), Pass);
        // Exactly on the inner guard-band edge: conformance is proven.
        assert_eq!(iso(8.0, 2.0, 10.0, Upper), Pass);
        // Inside the tolerance by less than U: nothing is proven.
        assert_eq!(iso(8.5, 2.0, 10.0, Upper), CannotDecide);
        assert_eq!(iso(10.0, 2.0, 10.0, Upper), CannotDecide);
        // Beyond it by less than U, and exactly on the outer edge: still nothing.
        assert_eq!(iso(11.5, 2.0, 10.0, Upper), CannotDecide);
        assert_eq!(iso(12.0, 2.0, 10.0, Upper), CannotDecide);
        // Beyond the outer edge: non-conformance is proven.
        assert_eq!(iso(12.5, 2.0, 10.0, Upper), Fail);
    }

    #[test]
    fn without_uncertainty_the_limit_itself_decides() {
        assert_eq!(iso(10.0, 0.0, 10.0, Upper), Pass);
        assert_eq!(iso(10.5, 0.0, 10.0, Upper), Fail);
        // No uncertainty at all: the simple rule, and the check says so.
        let d = decide(9.0, None, 10.0, Upper, Iso14253_1);
        assert_eq!(
            d,
            Decision {
                verdict: Pass,
                note: Some(NO_UNCERTAINTY)
            }
        );
        assert_eq!(decide(11.0, None, 10.0, Upper, Iso14253_1).verdict, Fail);
        // The simple rule ignores U and needs no note.
        let d = decide(9.9, Some(5.0), 10.0, Upper, Simple);
        assert_eq!(
            d,
            Decision {
                verdict: Pass,
                note: None
            }
        );
        assert_eq!(decide(10.1, Some(5.0), 10.0, Upper, Simple).verdict, Fail);
    }

    #[test]
    fn an_uncertainty_larger_than_the_tolerance_never_passes() {
        for value in [0.0, 0.5, 1.0, 2.9] {
            assert_eq!(iso(value, 3.0, 2.0, Upper), CannotDecide, "{value}");
            assert_eq!(iso(value, 3.0, 2.0, TwoSided), CannotDecide, "{value}");
            assert_eq!(iso(-value, 3.0, 2.0, TwoSided), CannotDecide, "{value}");
        }
        // It can still prove a failure.
        assert_eq!(iso(5.5, 3.0, 2.0, Upper), Fail);
        assert_eq!(iso(-5.5, 3.0, 2.0, TwoSided), Fail);
    }

    #[test]
    fn a_two_sided_zone_guards_both_limits_alike() {
        // [−20, 20], U = 4: pass within [−16, 16], fail beyond ±24.
        for sign in [1.0, -1.0] {
            assert_eq!(iso(sign * 16.0, 4.0, 20.0, TwoSided), Pass);
            assert_eq!(iso(sign * 17.0, 4.0, 20.0, TwoSided), CannotDecide);
            assert_eq!(iso(sign * 24.0, 4.0, 20.0, TwoSided), CannotDecide);
            assert_eq!(iso(sign * 24.5, 4.0, 20.0, TwoSided), Fail);
        }
        // An upper zone does not fold negative values: −30 is far inside [0, 20] by its rule.
        assert_eq!(iso(-30.0, 4.0, 20.0, Upper), Pass);
        // A negative U is a magnitude.
        assert_eq!(iso(17.0, -4.0, 20.0, TwoSided), CannotDecide);
    }

    #[test]
    fn the_overall_verdict_is_the_worst_one() {
        assert_eq!(overall([Pass, Pass]), Pass);
        assert_eq!(overall([Pass, CannotDecide, Pass]), CannotDecide);
        assert_eq!(overall([CannotDecide, Fail, Pass]), Fail);
        assert_eq!(overall([]), CannotDecide);
    }

    #[test]
    fn rules_have_their_file_names() {
        assert_eq!(DecisionRule::parse("iso14253-1"), Some(Iso14253_1));
        assert_eq!(DecisionRule::parse("simple"), Some(Simple));
        assert_eq!(DecisionRule::parse("ISO 14253-1"), None);
        assert_eq!(DecisionRule::default(), Iso14253_1);
    }
}
