//! Run data kept compactly, bit for bit.
//!
//! A session of 10⁷ samples with 8 columns is 640 MB as `f64`. Most of it need not be: an axis
//! a run holds still is one number, and what instruments and controllers write has few digits
//! (`100.0001` mm, `-3.7462` µm, `11.001` s), which an `i32` holds exactly. A [`Column`] stores
//! each column in the smallest of three forms that gives back **exactly the same `f64`** for
//! every value — a constant, decimal mantissas (`i32`, with one power of ten for the column), or
//! plain `f64` — and applies the column's unit conversion ([`Scale`]) as it reads, the same
//! arithmetic a conversion in place would have done. Nothing is lost and nothing rounds
//! differently: identification gives the same bits as with plain vectors.
//!
//! Why a decimal reads back exactly: a file's `12.3456` is parsed to the `f64` nearest to
//! 123456 / 10⁴. Both 123456 and 10⁴ are exact in `f64` (below 2⁵³ and 10²²), and IEEE division
//! rounds the exact quotient to the nearest `f64`: the same number. Each value is still checked
//! when the column is built (`decode(encode(v)) == v`, bit for bit); one value that does not
//! come back, and the column is kept as `f64`.
//!
//! Storage is shared (`Arc`): cloning a column (a study rebuilt with other parameters keeps its
//! runs) costs nothing.

use std::sync::Arc;

/// The conversion a column applies as it reads (file units → SI).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// As stored.
    One,
    /// `value * factor` (mm → m: `1e-3`; degrees → rad: `π/180`, what `f64::to_radians` does).
    Mul(f64),
    /// `value / divisor` (µm → m: `/ 1e6`).
    Div(f64),
}

impl Scale {
    #[inline]
    pub fn apply(self, v: f64) -> f64 {
        match self {
            Scale::One => v,
            Scale::Mul(f) => v * f,
            Scale::Div(d) => v / d,
        }
    }
}

/// Powers of ten that are exact in `f64`; a decimal column uses at most 9 decimals.
const POW10: [f64; 10] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// The mantissa that stands for `-0.0` (never a real mantissa: those stay within ±`i32::MAX`).
const NEGATIVE_ZERO: i32 = i32::MIN;

#[derive(Clone, Debug)]
enum Store {
    Constant(f64),
    Decimal { pow10: f64, ints: Arc<[i32]> },
    Float(Arc<[f64]>),
}

/// A column of numbers, stored as compactly as its values allow without changing one bit.
#[derive(Clone, Debug)]
pub struct Column {
    len: usize,
    scale: Scale,
    store: Store,
}

/// How a column is stored (for tests and memory accounts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    Constant,
    /// Mantissas of this many decimals.
    Decimal(u32),
    Float,
}

impl Column {
    /// `values` as they are ([`Scale::One`]).
    pub fn new(values: &[f64]) -> Column {
        Column::with_scale(values, Scale::One)
    }

    /// `values` in their file units; [`get`](Self::get) returns `scale` applied to them.
    pub fn with_scale(values: &[f64], scale: Scale) -> Column {
        Column {
            len: values.len(),
            scale,
            store: store_of(values),
        }
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Value `i` as stored (file units).
    #[inline]
    pub fn raw(&self, i: usize) -> f64 {
        debug_assert!(i < self.len);
        match &self.store {
            Store::Constant(v) => *v,
            Store::Decimal { pow10, ints } => decode(ints[i], *pow10),
            Store::Float(v) => v[i],
        }
    }

    /// Value `i` converted ([`Scale`]).
    #[inline]
    pub fn get(&self, i: usize) -> f64 {
        self.scale.apply(self.raw(i))
    }

    /// Every value, converted.
    pub fn to_vec(&self) -> Vec<f64> {
        (0..self.len).map(|i| self.get(i)).collect()
    }

    /// Every value as stored (file units).
    pub fn raw_vec(&self) -> Vec<f64> {
        (0..self.len).map(|i| self.raw(i)).collect()
    }

    pub fn scale(&self) -> Scale {
        self.scale
    }

    pub fn storage(&self) -> Storage {
        match &self.store {
            Store::Constant(_) => Storage::Constant,
            Store::Decimal { pow10, .. } => {
                Storage::Decimal(POW10.iter().position(|p| p == pow10).unwrap_or(0) as u32)
            }
            Store::Float(_) => Storage::Float,
        }
    }

    /// Bytes of the values' storage.
    pub fn heap_bytes(&self) -> usize {
        match &self.store {
            Store::Constant(_) => 0,
            Store::Decimal { ints, .. } => ints.len() * 4,
            Store::Float(v) => v.len() * 8,
        }
    }
}

#[inline]
fn decode(m: i32, pow10: f64) -> f64 {
    if m == NEGATIVE_ZERO {
        -0.0
    } else {
        m as f64 / pow10
    }
}

/// The mantissa of `v` with `k` decimals, if it gives `v` back exactly.
fn encode(v: f64, k: usize) -> Option<i32> {
    if v == 0.0 && v.is_sign_negative() {
        return Some(NEGATIVE_ZERO);
    }
    let m = (v * POW10[k]).round();
    if m.is_nan() || m.abs() > i32::MAX as f64 {
        return None;
    }
    let m = m as i32;
    (decode(m, POW10[k]).to_bits() == v.to_bits()).then_some(m)
}

fn store_of(values: &[f64]) -> Store {
    let Some(&first) = values.first() else {
        return Store::Float(Arc::from(Vec::new()));
    };
    if values.iter().all(|v| v.to_bits() == first.to_bits()) {
        return Store::Constant(first);
    }
    // The fewest decimals that every value needs; a value that no decimal gives back (or one
    // too large) leaves the column as f64.
    let mut k = 0;
    for &v in values {
        match (k..POW10.len()).find(|&j| encode(v, j).is_some()) {
            Some(j) => k = j,
            None => return Store::Float(Arc::from(values)),
        }
    }
    // A value exact with fewer decimals is exact with more (the same quotient), unless its
    // mantissa no longer fits: then the column stays f64.
    let ints: Option<Vec<i32>> = values.iter().map(|&v| encode(v, k)).collect();
    match ints {
        Some(ints) => Store::Decimal {
            pow10: POW10[k],
            ints: Arc::from(ints),
        },
        None => Store::Float(Arc::from(values)),
    }
}

/// A table of samples: `rows × width`, each column a [`Column`].
#[derive(Clone, Debug, Default)]
pub struct Columns {
    rows: usize,
    columns: Vec<Column>,
}

impl Columns {
    /// From row-major `values` (`rows × scales.len()`), column `c` converted by `scales[c]`.
    pub fn from_row_major(values: &[f64], scales: &[Scale]) -> Columns {
        let width = scales.len();
        let rows = values.len().checked_div(width).unwrap_or(0);
        assert_eq!(rows * width, values.len(), "values are rows × columns");
        let mut column = Vec::with_capacity(rows);
        let columns = scales
            .iter()
            .enumerate()
            .map(|(c, &scale)| {
                column.clear();
                column.extend(values.iter().skip(c).step_by(width));
                Column::with_scale(&column, scale)
            })
            .collect();
        Columns { rows, columns }
    }

    /// From columns of equal length.
    pub fn from_columns(columns: Vec<Column>) -> Columns {
        let rows = columns.first().map_or(0, Column::len);
        assert!(
            columns.iter().all(|c| c.len() == rows),
            "columns of one length"
        );
        Columns { rows, columns }
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn width(&self) -> usize {
        self.columns.len()
    }

    pub fn column(&self, c: usize) -> &Column {
        &self.columns[c]
    }

    pub fn columns(&self) -> &[Column] {
        &self.columns
    }

    /// Row `i`, column `c`, converted.
    #[inline]
    pub fn get(&self, i: usize, c: usize) -> f64 {
        self.columns[c].get(i)
    }

    /// Row `i`, converted, into `out` (`width()` long).
    #[inline]
    pub fn row_into(&self, i: usize, out: &mut [f64]) {
        for (o, c) in out.iter_mut().zip(&self.columns) {
            *o = c.get(i);
        }
    }

    /// Row `i` as stored, into `out`.
    pub fn raw_row_into(&self, i: usize, out: &mut [f64]) {
        for (o, c) in out.iter_mut().zip(&self.columns) {
            *o = c.raw(i);
        }
    }

    /// Every row, converted, row-major.
    pub fn to_row_major(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.rows * self.width()];
        for (i, row) in out.chunks_exact_mut(self.width().max(1)).enumerate() {
            self.row_into(i, row);
        }
        out
    }

    /// Every row as stored (file units), row-major.
    pub fn raw_row_major(&self) -> Vec<f64> {
        let mut out = vec![0.0; self.rows * self.width()];
        for (i, row) in out.chunks_exact_mut(self.width().max(1)).enumerate() {
            self.raw_row_into(i, row);
        }
        out
    }

    /// Bytes of the values' storage.
    pub fn heap_bytes(&self) -> usize {
        self.columns.iter().map(Column::heap_bytes).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits()
    }

    #[test]
    fn file_decimals_are_kept_as_integers() {
        let text = [
            "100.0001",
            "-3.7462",
            "0",
            "-0.0000",
            "2147.483647",
            "11.001",
        ];
        let v: Vec<f64> = text.iter().map(|s| s.parse().unwrap()).collect();
        let c = Column::new(&v);
        assert_eq!(c.storage(), Storage::Decimal(6));
        assert_eq!(c.heap_bytes(), 4 * v.len());
        for (i, x) in v.iter().enumerate() {
            assert!(same(c.get(i), *x), "{i}: {} vs {x}", c.get(i));
        }
        // The sign of a written "-0.0000" survives.
        assert!(c.get(3).is_sign_negative());
    }

    #[test]
    fn a_held_axis_is_one_number_and_full_precision_stays_f64() {
        let held = Column::new(&[29.999999999999996; 1000]);
        assert_eq!(held.storage(), Storage::Constant);
        assert_eq!(held.heap_bytes(), 0);
        assert!(same(held.get(999), 29.999999999999996));
        let v = [37.49999999999993, 36.955319097287656, 1.0];
        let c = Column::new(&v);
        assert_eq!(c.storage(), Storage::Float);
        assert!(v.iter().enumerate().all(|(i, x)| same(c.get(i), *x)));
        // Too many digits for an i32 mantissa.
        let c = Column::new(&[2147.4836471, 0.5]);
        assert_eq!(c.storage(), Storage::Float);
        // One value too large.
        let c = Column::new(&[3e9, 0.5]);
        assert_eq!(c.storage(), Storage::Float);
    }

    #[test]
    fn the_scale_is_the_arithmetic_of_a_conversion_in_place() {
        let v: Vec<f64> = ["12.3456", "-0.0013", "179.82"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        for scale in [
            Scale::Mul(1e-3),
            Scale::Mul(std::f64::consts::PI / 180.0),
            Scale::Div(1e6),
        ] {
            let c = Column::with_scale(&v, scale);
            assert!(matches!(c.storage(), Storage::Decimal(4)));
            for (i, &x) in v.iter().enumerate() {
                let in_place = match scale {
                    Scale::Mul(1e-3) => x * 1e-3,
                    Scale::Mul(_) => x.to_radians(),
                    Scale::Div(d) => x / d,
                    Scale::One => x,
                };
                assert!(same(c.get(i), in_place));
                assert!(same(c.raw(i), x));
            }
        }
    }

    #[test]
    fn columns_give_back_rows() {
        let rows = [
            [1.5, 30.0, 0.1],
            [2.5, 30.0, 0.2],
            [3.25, 30.0, 0.30000000000000004],
        ];
        let flat: Vec<f64> = rows.concat();
        let t = Columns::from_row_major(&flat, &[Scale::Mul(1e-3), Scale::One, Scale::One]);
        assert_eq!((t.rows(), t.width()), (3, 3));
        assert_eq!(t.column(0).storage(), Storage::Decimal(2));
        assert_eq!(t.column(1).storage(), Storage::Constant);
        assert_eq!(t.column(2).storage(), Storage::Float);
        assert_eq!(t.raw_row_major(), flat);
        let mut row = [0.0; 3];
        t.row_into(1, &mut row);
        assert!(same(row[0], 2.5 * 1e-3));
        assert_eq!(&row[1..], &[30.0, 0.2]);
        assert_eq!(t.to_row_major().len(), 9);
        let empty = Columns::from_row_major(&[], &[Scale::One, Scale::One]);
        assert_eq!(empty.rows(), 0);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Whatever the values — printed decimals, full-precision floats, huge, tiny, signed
        /// zeros, repeated — every one comes back bit for bit, and a column of printed decimals
        /// takes 4 bytes a value.
        #[test]
        fn every_value_comes_back_bit_for_bit(
            ints in proptest::collection::vec(-2_000_000_000i64..2_000_000_000, 1..60),
            decimals in 0usize..8,
            floats in proptest::collection::vec(proptest::num::f64::NORMAL | proptest::num::f64::ZERO, 0..4),
            scale_kind in 0usize..3,
        ) {
            let scale = [Scale::One, Scale::Mul(1e-3), Scale::Div(1e6)][scale_kind];
            let printed: Vec<f64> = ints
                .iter()
                .map(|&m| format!("{:.*}", decimals, m as f64 / 10f64.powi(decimals as i32)).parse().unwrap())
                .collect();
            let c = Column::with_scale(&printed, scale);
            prop_assert!(c.storage() != Storage::Float, "{:?}", c.storage());
            for (i, &x) in printed.iter().enumerate() {
                prop_assert!(same(c.raw(i), x));
                prop_assert!(same(c.get(i), scale.apply(x)));
            }
            let mut mixed = printed.clone();
            mixed.extend(&floats);
            let c = Column::with_scale(&mixed, scale);
            for (i, &x) in mixed.iter().enumerate() {
                prop_assert!(same(c.raw(i), x), "{} vs {}", c.raw(i), x);
            }
        }
    }
}
