//! Seeded generators without a dependency: reproducible numbers for tests whose values must not
//! change when a crate's generator does.

/// SplitMix64 (Steele, Lea and Flood): a small generator of good quality.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), 53 random bits.
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }

    /// Uniform in [−1, 1), the same bits as `2 · unit − 1`.
    pub fn signed(&mut self) -> f64 {
        signed_of(self.next_u64())
    }
}

/// Knuth's 64-bit linear congruential generator (MMIX constants); uses its upper 53 bits.
#[derive(Debug, Clone)]
pub struct Lcg64(pub u64);

impl Lcg64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        unit_of(self.next_u64())
    }

    /// Uniform in [−1, 1), the same bits as `2 · unit − 1`.
    pub fn signed(&mut self) -> f64 {
        signed_of(self.next_u64())
    }
}

/// `n` numbers uniform in [−1, 1) from [`Lcg64`] seeded with `seed`.
pub fn uniform(seed: u64, n: usize) -> Vec<f64> {
    let mut lcg = Lcg64(seed);
    (0..n).map(|_| lcg.signed()).collect()
}

fn unit_of(bits: u64) -> f64 {
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

fn signed_of(bits: u64) -> f64 {
    // Scaling by a power of two is exact: this equals 2 · unit − 1 bit for bit.
    (bits >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_is_twice_unit_less_one_bit_for_bit() {
        let (mut a, mut b) = (Lcg64(7), Lcg64(7));
        let (mut c, mut d) = (SplitMix64(7), SplitMix64(7));
        for _ in 0..1000 {
            assert_eq!(a.signed().to_bits(), (b.unit() * 2.0 - 1.0).to_bits());
            assert_eq!(c.signed().to_bits(), (d.unit() * 2.0 - 1.0).to_bits());
        }
    }

    #[test]
    fn the_generators_give_their_reference_values() {
        // SplitMix64's published first output for seed 0.
        assert_eq!(SplitMix64(0).next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(Lcg64(0).next_u64(), 1442695040888963407);
        assert!(uniform(3, 100).iter().all(|u| (-1.0..1.0).contains(u)));
    }
}
