//! Where every parameter sits in a study's parameter vector `x`, and how the machine
//! coefficients map between the full error model and the reduced one the fit evaluates.
//!
//! One value owns these index maps so that they cannot disagree: a study builds it once
//! ([`crate::Study`]), and the fit, the search, the bands and the report only ask it.

use std::ops::Range;

/// The layout of a parameter vector: the estimated machine coefficients first, then every
/// set-up's free nuisance parameters (set-up by set-up, in the study's order), then the
/// effects' parameters (effect by effect).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParamLayout {
    /// `x[i]` for `i < estimated.len()` is machine coefficient `estimated[i]` (sorted).
    estimated: Vec<usize>,
    /// Per coefficient of the reduced model: its index in the full model.
    fit_coeffs: Vec<usize>,
    /// Per estimated coefficient (`estimated[i]`): its index in the reduced model.
    estimated_in_fit: Vec<usize>,
    /// Per set-up: where its free nuisance parameters start in `x`, and which they are.
    setups: Vec<SetupParams>,
    /// The effects' parameters in `x`; it ends the vector.
    effects: Range<usize>,
    /// Per effect, where its parameters start in `x` (effect by effect, in the study's order).
    effect_starts: Vec<usize>,
}

/// A set-up's free nuisance parameters in the parameter vector.
#[derive(Debug, Clone, PartialEq, Eq)]
struct SetupParams {
    offset: usize,
    /// Indices into the set-up's nuisance list, in `x` order.
    free: Vec<usize>,
}

/// What parameter `i` of the vector is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamSlot {
    /// Machine coefficient `coeff` of the full model.
    Machine { coeff: usize },
    /// Nuisance parameter `nuisance` (an index into the set-up's list) of set-up `setup`.
    Nuisance { setup: usize, nuisance: usize },
    /// The `index`-th of the effects' parameters (counted over every effect): parameter
    /// `param` of effect `effect`.
    Effect {
        index: usize,
        effect: usize,
        param: usize,
    },
}

impl ParamLayout {
    /// The layout of `estimated` machine coefficients (of the full model), `free_nuisance`
    /// parameters per set-up and the effects' parameters (`effect_params`: how many each
    /// effect has, in order). `fit_coeffs` lists, per
    /// coefficient of the reduced model, its index in the full one.
    ///
    /// # Panics
    /// If an estimated coefficient is not in the reduced model (the reduced model keeps every
    /// estimated coefficient by construction).
    pub fn new(
        estimated: Vec<usize>,
        fit_coeffs: Vec<usize>,
        free_nuisance: Vec<Vec<usize>>,
        effect_params: &[usize],
    ) -> ParamLayout {
        let estimated_in_fit = estimated
            .iter()
            .map(|k| {
                fit_coeffs
                    .iter()
                    .position(|f| f == k)
                    .expect("the reduced model keeps every estimated coefficient")
            })
            .collect();
        let mut offset = estimated.len();
        let setups = free_nuisance
            .into_iter()
            .map(|free| {
                let s = SetupParams { offset, free };
                offset += s.free.len();
                s
            })
            .collect();
        let mut effect_starts = Vec::with_capacity(effect_params.len());
        let mut end = offset;
        for n in effect_params {
            effect_starts.push(end);
            end += n;
        }
        ParamLayout {
            estimated,
            fit_coeffs,
            estimated_in_fit,
            setups,
            effects: offset..end,
            effect_starts,
        }
    }

    /// The length of the parameter vector.
    pub fn n_x(&self) -> usize {
        self.effects.end
    }

    /// The number of estimated machine coefficients (the first entries of `x`).
    pub fn n_machine(&self) -> usize {
        self.estimated.len()
    }

    /// Per estimated machine coefficient (`x[i]`): its index in the full model, ascending.
    pub fn estimated(&self) -> &[usize] {
        &self.estimated
    }

    /// Per coefficient of the reduced model: its index in the full model.
    pub fn fit_coeffs(&self) -> &[usize] {
        &self.fit_coeffs
    }

    /// Per estimated machine coefficient (`x[i]`): its index in the reduced model.
    pub fn estimated_in_fit(&self) -> &[usize] {
        &self.estimated_in_fit
    }

    /// Whether the reduced model is exactly the estimated coefficients, in `x` order (its
    /// Jacobian columns are then `x`'s first columns as they are).
    pub fn estimated_in_order(&self) -> bool {
        self.estimated_in_fit.len() == self.fit_coeffs.len()
            && self
                .estimated_in_fit
                .iter()
                .enumerate()
                .all(|(i, &k)| i == k)
    }

    /// Set-up `s`'s free nuisance parameters: indices into its nuisance list, in `x` order.
    pub fn free(&self, s: usize) -> &[usize] {
        &self.setups[s].free
    }

    /// Where set-up `s`'s free nuisance parameters sit in `x`.
    pub fn setup_range(&self, s: usize) -> Range<usize> {
        let p = &self.setups[s];
        p.offset..p.offset + p.free.len()
    }

    /// Where the effects' parameters sit in `x` (the end of the vector).
    pub fn effects(&self) -> Range<usize> {
        self.effects.clone()
    }

    /// Where the effects' parameters start in `x`.
    pub fn effect_offset(&self) -> usize {
        self.effects.start
    }

    /// Where effect `k`'s parameters sit in `x`.
    pub fn effect_range(&self, k: usize) -> Range<usize> {
        let end = self
            .effect_starts
            .get(k + 1)
            .copied()
            .unwrap_or(self.effects.end);
        self.effect_starts[k]..end
    }

    /// The parameters a sample of set-up `s` can depend on, in `x`: the machine coefficients,
    /// the set-up's own nuisance parameters, the effects' parameters.
    pub fn columns_of_setup(&self, s: usize) -> impl Iterator<Item = usize> + '_ {
        (0..self.n_machine())
            .chain(self.setup_range(s))
            .chain(self.effects())
    }

    /// What parameter `i` is.
    ///
    /// # Panics
    /// If `i` is past the vector.
    pub fn slot(&self, i: usize) -> ParamSlot {
        assert!(
            i < self.n_x(),
            "parameter {i} is past the parameter vector ({})",
            self.n_x()
        );
        if i < self.n_machine() {
            return ParamSlot::Machine {
                coeff: self.estimated[i],
            };
        }
        if i >= self.effects.start {
            let effect = self.effect_starts.partition_point(|&start| start <= i) - 1;
            return ParamSlot::Effect {
                index: i - self.effects.start,
                effect,
                param: i - self.effect_starts[effect],
            };
        }
        let setup = self
            .setups
            .iter()
            .rposition(|p| p.offset <= i && i < p.offset + p.free.len())
            .expect("an index between the machine's and the effects' belongs to a set-up");
        let p = &self.setups[setup];
        ParamSlot::Nuisance {
            setup,
            nuisance: p.free[i - p.offset],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Machine coefficients 2, 5, 7 of a model whose reduced form keeps 1, 2, 5, 7; set-ups
    /// with nuisance parameters {0, 2}, none, {1}; two effects of one and two parameters.
    fn example() -> ParamLayout {
        ParamLayout::new(
            vec![2, 5, 7],
            vec![1, 2, 5, 7],
            vec![vec![0, 2], vec![], vec![1]],
            &[1, 2],
        )
    }

    #[test]
    fn slots_follow_the_documented_order() {
        let l = example();
        // three machine coefficients, 2 + 0 + 1 nuisance parameters, three effect parameters
        assert_eq!(l.n_x(), 9);
        let slots: Vec<ParamSlot> = (0..l.n_x()).map(|i| l.slot(i)).collect();
        use ParamSlot::*;
        assert_eq!(
            slots,
            [
                Machine { coeff: 2 },
                Machine { coeff: 5 },
                Machine { coeff: 7 },
                Nuisance {
                    setup: 0,
                    nuisance: 0
                },
                Nuisance {
                    setup: 0,
                    nuisance: 2
                },
                Nuisance {
                    setup: 2,
                    nuisance: 1
                },
                Effect {
                    index: 0,
                    effect: 0,
                    param: 0
                },
                Effect {
                    index: 1,
                    effect: 1,
                    param: 0
                },
                Effect {
                    index: 2,
                    effect: 1,
                    param: 1
                },
            ]
        );
    }

    #[test]
    fn ranges_partition_the_vector() {
        let l = example();
        let mut seen: Vec<usize> = (0..l.n_machine()).collect();
        for s in 0..3 {
            assert_eq!(l.setup_range(s).len(), l.free(s).len());
            seen.extend(l.setup_range(s));
        }
        seen.extend(l.effects());
        assert_eq!(seen, (0..l.n_x()).collect::<Vec<_>>());
        assert_eq!(l.effect_offset(), 6);
        assert_eq!((l.effect_range(0), l.effect_range(1)), (6..7, 7..9));
        let cols: Vec<usize> = l.columns_of_setup(2).collect();
        assert_eq!(cols, [0, 1, 2, 5, 6, 7, 8]);
    }

    #[test]
    fn estimated_coefficients_map_into_the_reduced_model() {
        let l = example();
        assert_eq!(l.estimated_in_fit(), [1, 2, 3]);
        for (i, &k) in l.estimated().iter().enumerate() {
            assert_eq!(l.fit_coeffs()[l.estimated_in_fit()[i]], k);
        }
        assert!(!l.estimated_in_order());
        let plain = ParamLayout::new(vec![0, 1], vec![0, 1], vec![], &[]);
        assert!(plain.estimated_in_order());
    }

    #[test]
    #[should_panic(expected = "reduced model keeps every estimated coefficient")]
    fn an_estimated_coefficient_outside_the_reduced_model_is_refused() {
        ParamLayout::new(vec![3], vec![1, 2], vec![], &[]);
    }

    #[test]
    #[should_panic(expected = "past the parameter vector")]
    fn a_slot_past_the_vector_panics() {
        example().slot(9);
    }
}
