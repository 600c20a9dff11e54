//! Every sample's time in timeline order, and the median of positive values without a copy.

use super::*;

/// Every sample's time in timeline order (runs in time order; [`SessionView::timeline_index`]),
/// read from the runs' columns.
#[derive(Clone, Copy, Debug)]
pub struct Timeline<'v> {
    pub(super) view: &'v SessionView,
}

impl<'v> Timeline<'v> {
    pub fn len(&self) -> usize {
        self.view.samples
    }

    pub fn is_empty(&self) -> bool {
        self.view.samples == 0
    }

    /// The time of timeline sample `k` (s).
    pub fn get(&self, k: usize) -> f64 {
        let v = self.view;
        // The last run (in time order) starting at or before `k`: an empty run starts where
        // the next one does, so this is the one that holds `k`.
        let j = v.starts_in_order.partition_point(|&s| s <= k) - 1;
        v.runs[v.order[j]].t.get(k - v.starts_in_order[j])
    }

    /// The times in timeline order.
    pub fn iter(&self) -> impl Iterator<Item = f64> + 'v {
        let v = self.view;
        v.order.iter().flat_map(move |&r| {
            let t = &v.runs[r].t;
            (0..t.len()).map(move |i| t.get(i))
        })
    }

    /// The intervals between consecutive samples (s), in timeline order.
    pub(super) fn intervals(&self) -> impl Iterator<Item = f64> + 'v {
        let mut times = self.iter();
        let mut prev = times.next().unwrap_or(0.0);
        times.map(move |t| {
            let d = t - prev;
            prev = t;
            d
        })
    }
}

/// The median of the positive values `values()` yields (the upper one of an even count, as
/// `sorted[n / 2]`), without keeping them: positive floats order as their bit patterns, so the
/// median's bits are found 16 at a time, one counting pass each (five passes in all).
pub(super) fn median_of_positive<I: Iterator<Item = f64>>(values: impl Fn() -> I) -> Option<f64> {
    let n = values().filter(|v| *v > 0.0).count();
    if n == 0 {
        return None;
    }
    let mut rank = n / 2;
    let mut bits: u64 = 0;
    let mut counts = vec![0usize; 1 << 16];
    for shift in [48u32, 32, 16, 0] {
        // The values whose higher bits are the median's so far, by their next 16 bits.
        let known = if shift == 48 {
            0
        } else {
            u64::MAX << (shift + 16)
        };
        counts.fill(0);
        for v in values().filter(|v| *v > 0.0) {
            let b = v.to_bits();
            if b & known == bits {
                counts[((b >> shift) & 0xffff) as usize] += 1;
            }
        }
        for (digit, &c) in counts.iter().enumerate() {
            if rank < c {
                bits |= (digit as u64) << shift;
                break;
            }
            rank -= c;
        }
    }
    Some(f64::from_bits(bits))
}
