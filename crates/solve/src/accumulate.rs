//! Streaming accumulation of residual rows into an upper-triangular factor `R`, its rotated
//! right-hand side `z = Qᵀr` and the residual sum of squares that no column explains.
//!
//! Rows arrive in groups that share a set of active columns. A group is folded with the dense
//! kernel in [`crate::qr`] on the sub-block `R[E, E]`, where `E` is the active set closed under
//! fill-in: a reflector for column `j` mixes row `j` of `R` into the new rows, so every column in
//! which row `j` of `R` is non-zero becomes active too. With block-local ("nuisance") columns
//! ordered before the shared ones, `E` is exactly the active set and no fill-in occurs; the solver
//! chooses such an order (see `solver::column_order`). Rows outside `E` are untouched by the
//! reflectors, which is what makes the sub-block update exact.

use faer::MatMut;

use crate::qr::{self, Scratch};

/// Marks a parameter without a column (fixed) or a column outside the current group.
pub(crate) const NONE: usize = usize::MAX;

/// Rows buffered before they are folded into `R`. Larger blocks amortise the per-fold overhead
/// and keep the matrix products efficient; 512 × 112 doubles (450 kB) stay in L2.
const CHUNK: usize = 512;
/// Column stride of the column-major fold buffer. Not a power of two, so that the columns of one
/// row do not all map to the same cache set.
const LD: usize = CHUNK + 8;

/// A fault found while accepting rows; the solver turns it into a [`crate::SolveError`].
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Fault {
    NonFiniteResidual {
        block: usize,
        row: usize,
        value: f64,
    },
    NonFiniteJacobian {
        block: usize,
        row: usize,
        param: usize,
        value: f64,
    },
    Columns {
        block: usize,
        reason: String,
    },
    Row {
        block: usize,
        row: usize,
        reason: String,
    },
}

/// One thread's streaming factor.
#[derive(Debug, Clone)]
pub(crate) struct Accumulator {
    /// Parameter index → column of `R`, [`NONE`] for fixed parameters.
    to_col: Vec<usize>,
    /// Number of columns (free parameters).
    n: usize,
    /// `n × n`, column-major, upper triangular.
    pub(crate) r: Vec<f64>,
    pub(crate) z: Vec<f64>,
    /// Residual sum of squares not explained by the columns.
    pub(crate) rss: f64,
    /// Σ r² over all data rows, summed directly (the cost).
    pub(crate) sumsq: f64,
    pub(crate) n_rows: usize,
    /// Per parameter: in how many blocks it was active (for the column order).
    pub(crate) usage: Vec<u32>,
    stamp: Vec<usize>,
    // The current group.
    group_cols: Vec<usize>,
    group_valid: bool,
    in_group: bool,
    /// Active set closed under fill-in, sorted columns of `R`.
    e_cols: Vec<usize>,
    /// Column of `R` → position in `e_cols`, or [`NONE`].
    pos_of: Vec<usize>,
    /// (index into the caller's Jacobian row, position in `e_cols`).
    pairs: Vec<(usize, usize)>,
    /// `pairs` compressed into runs `(s, t, len)` of consecutive entries, copied as slices.
    runs: Vec<(usize, usize, usize)>,
    /// Positions in `e_cols` that rows never write (fill-in columns); written as zeros.
    fill: Vec<usize>,
    mask: Vec<bool>,
    // Fold buffers: rows are staged row-major (one contiguous write per row; writing them straight
    // into column-major storage touches a different page per entry) and transposed in blocks
    // into `bot` when folded.
    top: Vec<f64>,
    stage: Vec<f64>,
    bot: Vec<f64>,
    k: usize,
    scratch: Scratch,
    // Bookkeeping for messages.
    block: usize,
    row_in_block: usize,
    pub(crate) fault: Option<Fault>,
    /// Set: rows are not folded into `R` but summed into a gradient (see [`Gradient`]).
    pub(crate) gradient: Option<Gradient>,
}

/// Gradient-only accumulation: `g = Jᵀr` and, for a few probe directions `u_k`, `‖J·u_k‖²`,
/// in the column order of the layout. A row costs `O(n·k)` instead of the fold's `O(n²)`: this
/// is how the solver checks a step with a factor it already has (see `solver`). Rows are staged
/// in chunks as the caller gives them (the current group's column order: a plain copy) and
/// reduced with matrix products against the probes gathered into that order; the group's
/// sums are scattered into layout order when a chunk is reduced.
#[derive(Debug, Clone)]
pub(crate) struct Gradient {
    pub(crate) g: Vec<f64>,
    /// `n × k`, column-major (probe-major).
    probes: Vec<f64>,
    pub(crate) probe_sq: Vec<f64>,
    /// The current group: `(index in the caller's row, column of the layout)` and the row width.
    pairs: Vec<(usize, usize)>,
    width: usize,
    /// The probes in the group's order: `width × k`, column-major (zero for entries of fixed
    /// parameters).
    group_probes: Vec<f64>,
    /// Staged rows, row-major `CHUNK × (width + 1)`: the Jacobian row, then the residual.
    stage: Vec<f64>,
    /// `CHUNK × k` products of the staged rows with the probes.
    dots: Vec<f64>,
    /// A chunk's `Jᵀr` and `Jᵀ(J·u)` in the group's order, before the scatter.
    group_g: Vec<f64>,
    group_cross: Vec<f64>,
    rows: usize,
    /// The last `n_cross` probes also get `Jᵀ(J·u_k)`: `n × n_cross`, column-major.
    n_cross: usize,
    pub(crate) cross: Vec<f64>,
}

impl Gradient {
    /// `probes` holds whole probe vectors of `n` entries each; the last `n_cross` of them also
    /// get `Jᵀ(J·u)`.
    pub(crate) fn new(n: usize, probes: &[f64], n_cross: usize) -> Self {
        let k = probes.len().checked_div(n).unwrap_or(0);
        assert!(n_cross <= k, "cross products of more probes than given");
        Self {
            n_cross,
            cross: vec![0.0; n * n_cross],
            g: vec![0.0; n],
            probes: probes.to_vec(),
            probe_sq: vec![0.0; k],
            pairs: Vec::new(),
            width: 0,
            group_probes: Vec::new(),
            stage: Vec::new(),
            dots: vec![0.0; CHUNK * k],
            group_g: Vec::new(),
            group_cross: Vec::new(),
            rows: 0,
        }
    }

    fn reset(&mut self) {
        self.g.fill(0.0);
        self.probe_sq.fill(0.0);
        self.cross.fill(0.0);
        self.rows = 0;
        self.pairs.clear();
        self.width = 0;
    }

    /// Starts a group of rows of `width` entries, entry `s` belonging to layout column `c` for
    /// `(s, c)` in `pairs` (entries not in `pairs` belong to fixed parameters).
    fn set_group(&mut self, pairs: &[(usize, usize)], width: usize) {
        self.flush();
        let (n, k) = (self.g.len(), self.probe_sq.len());
        self.pairs.clear();
        self.pairs.extend_from_slice(pairs);
        self.width = width;
        self.group_probes.clear();
        self.group_probes.resize(width * k, 0.0);
        for j in 0..k {
            for &(s, c) in pairs {
                self.group_probes[j * width + s] = self.probes[j * n + c];
            }
        }
        self.stage.resize(CHUNK * (width + 1), 0.0);
        self.group_g.resize(width, 0.0);
        self.group_cross.resize(width * self.n_cross, 0.0);
    }

    /// Stages one row of the current group (a copy: no scatter per row).
    fn add_row(&mut self, r: f64, jac: &[f64]) {
        let w = self.width;
        let row = &mut self.stage[self.rows * (w + 1)..(self.rows + 1) * (w + 1)];
        row[..w].copy_from_slice(jac);
        row[w] = r;
        self.rows += 1;
        if self.rows == CHUNK {
            self.flush();
        }
    }

    /// A row with the single entry `w` in layout column `c` (a prior), summed directly.
    fn add_diagonal_row(&mut self, c: usize, w: f64, r: f64) {
        let (n, k) = (self.g.len(), self.probe_sq.len());
        self.g[c] += w * r;
        for j in 0..k {
            let d = w * self.probes[j * n + c];
            self.probe_sq[j] += d * d;
            if j >= k - self.n_cross {
                self.cross[(j - (k - self.n_cross)) * n + c] += w * d;
            }
        }
    }

    fn flush(&mut self) {
        let (n, k, m, w) = (self.g.len(), self.probe_sq.len(), self.rows, self.width);
        if m == 0 {
            return;
        }
        self.rows = 0;
        let stage = &self.stage[..m * (w + 1)];
        let a = faer::MatRef::from_row_major_slice_with_stride(stage, m, w, w + 1);
        let r = faer::MatRef::from_row_major_slice_with_stride(&stage[w..], m, 1, w + 1);
        let g = faer::MatMut::from_column_major_slice_mut(&mut self.group_g, w, 1);
        faer::linalg::matmul::matmul(
            g,
            faer::Accum::Replace,
            a.transpose(),
            r,
            1.0,
            faer::Par::Seq,
        );
        for &(s, c) in &self.pairs {
            self.g[c] += self.group_g[s];
        }
        if k == 0 {
            return;
        }
        let p = faer::MatRef::from_column_major_slice(&self.group_probes, w, k);
        let d = faer::MatMut::from_column_major_slice_mut(&mut self.dots[..m * k], m, k);
        faer::linalg::matmul::matmul(d, faer::Accum::Replace, a, p, 1.0, faer::Par::Seq);
        for (q, col) in self
            .probe_sq
            .iter_mut()
            .zip(self.dots[..m * k].chunks_exact(m))
        {
            *q += crate::qr::dot(col, col);
        }
        if self.n_cross > 0 {
            let c = self.n_cross;
            let jw = faer::MatRef::from_column_major_slice(&self.dots[(k - c) * m..k * m], m, c);
            let cross = faer::MatMut::from_column_major_slice_mut(&mut self.group_cross, w, c);
            faer::linalg::matmul::matmul(
                cross,
                faer::Accum::Replace,
                a.transpose(),
                jw,
                1.0,
                faer::Par::Seq,
            );
            for j in 0..c {
                for &(s, col) in &self.pairs {
                    self.cross[j * n + col] += self.group_cross[j * w + s];
                }
            }
        }
    }

    fn merge(&mut self, other: &mut Gradient) {
        other.flush();
        self.flush();
        for (a, b) in self.g.iter_mut().zip(&other.g) {
            *a += b;
        }
        for (a, b) in self.probe_sq.iter_mut().zip(&other.probe_sq) {
            *a += b;
        }
        for (a, b) in self.cross.iter_mut().zip(&other.cross) {
            *a += b;
        }
    }
}

impl Accumulator {
    /// An empty factor for `to_col.len()` parameters of which `n` are free.
    pub(crate) fn new(to_col: Vec<usize>, n: usize) -> Self {
        let n_params = to_col.len();
        Self {
            to_col,
            n,
            r: vec![0.0; n * n],
            z: vec![0.0; n],
            rss: 0.0,
            sumsq: 0.0,
            n_rows: 0,
            usage: vec![0; n_params],
            stamp: vec![NONE; n_params],
            group_cols: Vec::new(),
            group_valid: false,
            in_group: false,
            e_cols: Vec::new(),
            pos_of: vec![NONE; n],
            pairs: Vec::new(),
            runs: Vec::new(),
            fill: Vec::new(),
            mask: vec![false; n],
            top: Vec::new(),
            stage: Vec::new(),
            bot: Vec::new(),
            k: 0,
            scratch: Scratch::new(n + 1),
            block: 0,
            row_in_block: 0,
            fault: None,
            gradient: None,
        }
    }

    /// An accumulator that sums the gradient and the probes' squared norms instead of folding.
    pub(crate) fn new_gradient(
        to_col: Vec<usize>,
        n: usize,
        probes: &[f64],
        n_cross: usize,
    ) -> Self {
        let mut acc = Self::new(to_col, n);
        acc.gradient = Some(Gradient::new(n, probes, n_cross));
        acc
    }

    /// Whether this accumulator was built for the same column layout.
    pub(crate) fn has_layout(&self, to_col: &[usize]) -> bool {
        self.to_col == to_col
    }

    /// Empties the factor, keeping the buffers.
    pub(crate) fn reset(&mut self) {
        self.r.fill(0.0);
        self.z.fill(0.0);
        self.rss = 0.0;
        self.sumsq = 0.0;
        self.n_rows = 0;
        self.usage.fill(0);
        self.stamp.fill(NONE);
        self.clear_group();
        self.k = 0;
        self.fault = None;
        if let Some(grad) = &mut self.gradient {
            grad.reset();
        }
    }

    /// Starts from a diagonal factor: column `c` gets the row `(w, r)` (a prior `(x − μ)/σ` has
    /// `w = 1/σ`). Only valid on an empty factor; diagonal rows cause no fill-in.
    pub(crate) fn set_diagonal_rows(&mut self, rows: &[(usize, f64, f64)]) {
        if let Some(grad) = &mut self.gradient {
            for &(c, w, r) in rows {
                grad.add_diagonal_row(c, w, r);
            }
            return;
        }
        for &(c, w, r) in rows {
            debug_assert_eq!(self.r[c + c * self.n], 0.0);
            let (w, r) = if w < 0.0 { (-w, -r) } else { (w, r) };
            self.r[c + c * self.n] = w;
            self.z[c] = r;
        }
    }

    pub(crate) fn start_block(&mut self, block: usize) {
        self.block = block;
        self.row_in_block = 0;
        self.in_group = false;
    }

    fn clear_group(&mut self) {
        for &c in &self.e_cols {
            self.pos_of[c] = NONE;
        }
        self.e_cols.clear();
        self.pairs.clear();
        self.runs.clear();
        self.fill.clear();
        self.group_cols.clear();
        self.group_valid = false;
        self.in_group = false;
    }

    /// Starts a group of rows whose Jacobian entries lie in the parameter columns `cols`.
    pub(crate) fn columns(&mut self, cols: &[usize]) {
        if self.fault.is_some() {
            return;
        }
        let n_params = self.to_col.len();
        if let Some(reason) = check_columns(cols, n_params) {
            self.fault = Some(Fault::Columns {
                block: self.block,
                reason,
            });
            return;
        }
        for &c in cols {
            if self.stamp[c] != self.block {
                self.stamp[c] = self.block;
                self.usage[c] += 1;
            }
        }
        self.in_group = true;
        if self.group_valid && self.group_cols == cols {
            return;
        }
        self.flush();
        self.clear_group();
        self.group_cols.extend_from_slice(cols);
        for (s, &p) in cols.iter().enumerate() {
            let c = self.to_col[p];
            if c != NONE {
                self.pairs.push((s, c));
            }
        }
        match &mut self.gradient {
            None => self.begin_group(),
            Some(grad) => grad.set_group(&self.pairs, cols.len()),
        }
        self.group_valid = true;
        self.in_group = true;
    }

    /// Computes the fill-closed active set from `pairs` (which hold columns of `R` on entry and
    /// positions in `e_cols` on return) and prepares the buffers.
    fn begin_group(&mut self) {
        let n = self.n;
        for &(_, c) in &self.pairs {
            self.mask[c] = true;
        }
        // Close under fill-in: row j of R (j active) makes every column where it is non-zero active.
        for j in 0..n {
            if !self.mask[j] {
                continue;
            }
            for k in j + 1..n {
                if !self.mask[k] && self.r[j + k * n] != 0.0 {
                    self.mask[k] = true;
                }
            }
            self.e_cols.push(j);
        }
        for (t, &c) in self.e_cols.iter().enumerate() {
            self.mask[c] = false;
            self.pos_of[c] = t;
        }
        for pair in &mut self.pairs {
            pair.1 = self.pos_of[pair.1];
        }
        let e = self.e_cols.len();
        for &(_, t) in &self.pairs {
            self.mask[t] = true;
        }
        self.runs.clear();
        for &(src, t) in &self.pairs {
            match self.runs.last_mut() {
                Some((s0, t0, len)) if *s0 + *len == src && *t0 + *len == t => *len += 1,
                _ => self.runs.push((src, t, 1)),
            }
        }
        for t in 0..e {
            if !self.mask[t] {
                self.fill.push(t);
            }
            self.mask[t] = false;
        }
        if self.bot.len() < LD * (e + 1) {
            self.bot.resize(LD * (e + 1), 0.0);
        }
        if self.stage.len() < CHUNK * (e + 1) {
            self.stage.resize(CHUNK * (e + 1), 0.0);
        }
        if self.top.len() < e * (e + 1) {
            self.top.resize(e * (e + 1), 0.0);
        }
        self.k = 0;
    }

    /// One row of the current group: residual `r` and Jacobian entries for the group's columns.
    pub(crate) fn row(&mut self, r: f64, jac: &[f64]) {
        if self.fault.is_some() {
            return;
        }
        if !self.in_group {
            self.fault = Some(Fault::Row {
                block: self.block,
                row: self.row_in_block,
                reason: "a row was pushed before `columns` started a group in this block".into(),
            });
            return;
        }
        if jac.len() != self.group_cols.len() {
            self.fault = Some(Fault::Row {
                block: self.block,
                row: self.row_in_block,
                reason: format!(
                    "the Jacobian row has {} entries but the group has {} columns",
                    jac.len(),
                    self.group_cols.len()
                ),
            });
            return;
        }
        if !all_finite(r, jac) {
            self.fault = Some(self.non_finite(r, jac));
            return;
        }
        if let Some(grad) = &mut self.gradient {
            grad.add_row(r, jac);
            self.sumsq += r * r;
            self.n_rows += 1;
            self.row_in_block += 1;
            return;
        }
        let w = self.e_cols.len() + 1;
        let row = &mut self.stage[self.k * w..(self.k + 1) * w];
        for &(src, t, len) in self.runs.iter() {
            row[t..t + len].copy_from_slice(&jac[src..src + len]);
        }
        for &t in &self.fill {
            row[t] = 0.0;
        }
        row[w - 1] = r;
        self.sumsq += r * r;
        self.k += 1;
        self.n_rows += 1;
        self.row_in_block += 1;
        if self.k == CHUNK {
            self.flush();
        }
    }

    #[cold]
    fn non_finite(&self, r: f64, jac: &[f64]) -> Fault {
        let (block, row) = (self.block, self.row_in_block);
        if !r.is_finite() {
            return Fault::NonFiniteResidual {
                block,
                row,
                value: r,
            };
        }
        let s = jac.iter().position(|v| !v.is_finite()).unwrap_or(0);
        Fault::NonFiniteJacobian {
            block,
            row,
            param: self.group_cols[s],
            value: jac[s],
        }
    }

    /// Folds the buffered rows into `R`.
    pub(crate) fn flush(&mut self) {
        if let Some(grad) = &mut self.gradient {
            grad.flush();
            return;
        }
        let k = self.k;
        if k == 0 {
            return;
        }
        self.k = 0;
        let (n, e) = (self.n, self.e_cols.len());
        let top = &mut self.top[..e * (e + 1)];
        for (t, &ct) in self.e_cols.iter().enumerate() {
            let col = &mut top[t * e..(t + 1) * e];
            for (u, &cu) in self.e_cols[..=t].iter().enumerate() {
                col[u] = self.r[cu + ct * n];
            }
            col[t + 1..].fill(0.0);
        }
        for (u, &cu) in self.e_cols.iter().enumerate() {
            top[e * e + u] = self.z[cu];
        }
        transpose(&self.stage[..k * (e + 1)], k, e + 1, &mut self.bot);
        {
            let topm = MatMut::from_column_major_slice_mut(top, e, e + 1);
            let botm = MatMut::from_column_major_slice_with_stride_mut(&mut self.bot, k, e + 1, LD);
            qr::fold(topm, botm, &mut self.scratch);
        }
        let rhs = &self.bot[e * LD..e * LD + k];
        self.rss += qr::dot(rhs, rhs);
        for (t, &ct) in self.e_cols.iter().enumerate() {
            for (u, &cu) in self.e_cols[..=t].iter().enumerate() {
                self.r[cu + ct * n] = top[u + t * e];
            }
        }
        for (u, &cu) in self.e_cols.iter().enumerate() {
            self.z[cu] = top[e * e + u];
        }
    }

    /// Folds another factor (built for the same layout) into this one: the rows of its `R`, with
    /// its `z` as right-hand side, are rows like any other. Rows are grouped by their support so
    /// that block-local structure causes no fill-in.
    pub(crate) fn merge(&mut self, other: &mut Accumulator) {
        debug_assert_eq!(self.n, other.n);
        if let (Some(mine), Some(theirs)) = (&mut self.gradient, &mut other.gradient) {
            mine.merge(theirs);
            self.sumsq += other.sumsq;
            self.n_rows += other.n_rows;
            for (u, o) in self.usage.iter_mut().zip(&other.usage) {
                *u += o;
            }
            return;
        }
        other.flush();
        self.flush();
        self.clear_group();
        let n = self.n;
        self.rss += other.rss;
        self.sumsq += other.sumsq;
        self.n_rows += other.n_rows;
        for (u, o) in self.usage.iter_mut().zip(&other.usage) {
            *u += o;
        }
        for i in 0..n {
            let support = (i..n).filter(|&c| other.r[i + c * n] != 0.0);
            let fits = self.group_valid && support.clone().all(|c| self.pos_of[c] != NONE);
            if !fits {
                if support.clone().next().is_none() {
                    self.rss += other.z[i] * other.z[i];
                    continue;
                }
                self.flush();
                self.clear_group();
                self.pairs.extend(support.map(|c| (0, c)));
                self.begin_group();
                self.group_valid = true;
            }
            let w = self.e_cols.len() + 1;
            let row = &mut self.stage[self.k * w..(self.k + 1) * w];
            for (t, &c) in self.e_cols.iter().enumerate() {
                row[t] = if c >= i { other.r[i + c * n] } else { 0.0 };
            }
            row[w - 1] = other.z[i];
            self.k += 1;
            if self.k == CHUNK {
                self.flush();
            }
        }
        self.flush();
        // The merge group writes every position; the next `columns` call must start afresh.
        self.clear_group();
    }
}

/// Whether `r` and every entry of `jac` are finite. `v * 0.0` is 0 for finite `v` and NaN
/// otherwise; eight independent partial sums keep the loop vectorised (a single running sum
/// would serialise on the add latency).
fn all_finite(r: f64, jac: &[f64]) -> bool {
    let mut acc = [0.0_f64; 8];
    let chunks = jac.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..8 {
            acc[l] += c[l] * 0.0;
        }
    }
    let mut s = r * 0.0;
    for v in rest {
        s += v * 0.0;
    }
    s + acc.iter().sum::<f64>() == 0.0
}

/// Copies the row-major `k × w` block `src` into the column-major `dst` (stride [`LD`]), eight
/// rows (one cache line of each destination column) at a time.
fn transpose(src: &[f64], k: usize, w: usize, dst: &mut [f64]) {
    let full = k - k % 8;
    for i0 in (0..full).step_by(8) {
        let rows: [&[f64]; 8] = std::array::from_fn(|i| &src[(i0 + i) * w..(i0 + i + 1) * w]);
        for (t, col) in dst.chunks_mut(LD).take(w).enumerate() {
            let d: &mut [f64; 8] = (&mut col[i0..i0 + 8]).try_into().expect("eight rows");
            for (di, row) in d.iter_mut().zip(&rows) {
                *di = row[t];
            }
        }
    }
    for i in full..k {
        let row = &src[i * w..(i + 1) * w];
        for (t, &v) in row.iter().enumerate() {
            dst[t * LD + i] = v;
        }
    }
}

fn check_columns(cols: &[usize], n_params: usize) -> Option<String> {
    if let Some(&last) = cols.last()
        && last >= n_params
    {
        return Some(format!(
            "column {last} is out of range (the problem has {n_params} parameters)"
        ));
    }
    if let Some(w) = cols.windows(2).find(|w| w[0] >= w[1]) {
        return Some(format!(
            "columns must be sorted and unique, found {} before {}",
            w[0], w[1]
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    fn gram_of(acc: &Accumulator) -> Mat<f64> {
        let n = acc.n;
        let rz = Mat::<f64>::from_fn(
            n,
            n + 1,
            |i, j| if j < n { acc.r[i + j * n] } else { acc.z[i] },
        );
        let mut g = rz.transpose() * &rz;
        g[(n, n)] += acc.rss;
        g
    }

    /// Gradient mode: `Jᵀr`, `‖J·u‖²` and `Jᵀ(J·u)` over rows in several groups (more rows than
    /// a chunk), split over two accumulators and merged, and a diagonal prior row, against
    /// sums formed row by row.
    #[test]
    fn gradient_mode_matches_dense_sums() {
        let n_params = 6;
        let to_col: Vec<usize> = vec![2, 0, NONE, 1, 3, 4];
        let n = 5;
        let mut s = 11;
        let probes: Vec<f64> = (0..3 * n).map(|_| lcg(&mut s)).collect();
        let mut a = Accumulator::new_gradient(to_col.clone(), n, &probes, 2);
        let mut b = Accumulator::new_gradient(to_col.clone(), n, &probes, 2);
        let (mut g, mut sq, mut cross) = (vec![0.0; n], [0.0; 3], vec![0.0; 2 * n]);
        let mut add = |row: &[f64], r: f64| {
            let dots: Vec<f64> = probes
                .chunks_exact(n)
                .map(|u| row.iter().zip(u).map(|(x, y)| x * y).sum())
                .collect();
            for c in 0..n {
                g[c] += r * row[c];
                cross[c] += row[c] * dots[1];
                cross[n + c] += row[c] * dots[2];
            }
            for k in 0..3 {
                sq[k] += dots[k] * dots[k];
            }
        };
        a.set_diagonal_rows(&[(1, 4.0, 0.5)]);
        let mut prior = vec![0.0; n];
        prior[1] = 4.0;
        add(&prior, 0.5);
        let groups: [&[usize]; 3] = [&[0, 1, 2, 3], &[3, 4, 5], &[1, 2, 5]];
        for (blk, cols) in groups.iter().enumerate() {
            let acc = if blk == 1 { &mut b } else { &mut a };
            acc.start_block(blk);
            acc.columns(cols);
            for _ in 0..(CHUNK + 37) {
                let jac: Vec<f64> = cols.iter().map(|_| lcg(&mut s)).collect();
                let r = lcg(&mut s);
                acc.row(r, &jac);
                let mut row = vec![0.0; n];
                for (&p, &v) in cols.iter().zip(&jac) {
                    if to_col[p] != NONE {
                        row[to_col[p]] = v;
                    }
                }
                add(&row, r);
            }
        }
        a.merge(&mut b);
        a.flush();
        let grad = a.gradient.as_ref().unwrap();
        let close = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .all(|(p, q)| (p - q).abs() < 1e-10 * (1.0 + q.abs()))
        };
        assert!(close(&grad.g, &g), "{:?} vs {g:?}", grad.g);
        assert!(close(&grad.probe_sq, &sq), "{:?} vs {sq:?}", grad.probe_sq);
        assert!(close(&grad.cross, &cross), "{:?} vs {cross:?}", grad.cross);
        assert_eq!(a.n_rows, 3 * (CHUNK + 37));
        let _ = n_params;
    }

    /// Blocks with shared columns and per-block columns in varying orders, including fill-in
    /// (shared columns first) and fixed parameters, against the dense Gram matrix.
    #[test]
    fn groups_with_fill_match_dense() {
        let n_params = 12;
        // Parameter 5 fixed; columns are a permutation that puts shared params first (fill-in).
        let mut to_col = vec![NONE; n_params];
        let order = [0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11];
        for (c, &p) in order.iter().enumerate() {
            to_col[p] = c;
        }
        let n = order.len();
        let mut acc = Accumulator::new(to_col.clone(), n);
        let mut dense = Mat::<f64>::zeros(0, n + 1);
        let mut s = 3;
        let groups: [&[usize]; 5] = [
            &[0, 1, 2, 5, 6],
            &[0, 1, 2, 7, 8],
            &[3, 9],
            &[0, 1, 2, 5, 6],
            &[4, 10, 11],
        ];
        for (b, cols) in groups.iter().enumerate() {
            acc.start_block(b);
            acc.columns(cols);
            for _ in 0..(7 + 3 * b) {
                let jac: Vec<f64> = cols.iter().map(|_| lcg(&mut s)).collect();
                let r = lcg(&mut s);
                acc.row(r, &jac);
                let mut row = Mat::<f64>::zeros(1, n + 1);
                for (&p, &v) in cols.iter().zip(&jac) {
                    if to_col[p] != NONE {
                        row[(0, to_col[p])] = v;
                    }
                }
                row[(0, n)] = r;
                let mut d2 = Mat::<f64>::zeros(dense.nrows() + 1, n + 1);
                d2.get_mut(..dense.nrows(), ..).copy_from(&dense);
                d2.get_mut(dense.nrows().., ..).copy_from(&row);
                dense = d2;
            }
        }
        acc.flush();
        assert!(acc.fault.is_none());
        let want = dense.transpose() * &dense;
        let err = (&gram_of(&acc) - &want).norm_max() / want.norm_max();
        assert!(err < 1e-13, "gram error {err:e}");

        // Split the same rows over two accumulators and merge.
        let mut a = Accumulator::new(to_col.clone(), n);
        let mut b = Accumulator::new(to_col, n);
        let mut s = 3;
        for (blk, cols) in groups.iter().enumerate() {
            let acc = if blk % 2 == 0 { &mut a } else { &mut b };
            acc.start_block(blk);
            acc.columns(cols);
            for _ in 0..(7 + 3 * blk) {
                let jac: Vec<f64> = cols.iter().map(|_| lcg(&mut s)).collect();
                acc.row(lcg(&mut s), &jac);
            }
        }
        a.merge(&mut b);
        let err = (&gram_of(&a) - &want).norm_max() / want.norm_max();
        assert!(err < 1e-13, "merged gram error {err:e}");
        assert_eq!(a.n_rows, dense.nrows());
    }

    #[test]
    fn faults_name_block_and_row() {
        let mut acc = Accumulator::new(vec![0, 1, 2], 3);
        acc.start_block(4);
        acc.columns(&[0, 2]);
        acc.row(1.0, &[1.0, 2.0]);
        acc.row(1.0, &[1.0, f64::INFINITY]);
        assert_eq!(
            acc.fault,
            Some(Fault::NonFiniteJacobian {
                block: 4,
                row: 1,
                param: 2,
                value: f64::INFINITY
            })
        );
        let mut acc = Accumulator::new(vec![0, 1, 2], 3);
        acc.start_block(0);
        acc.columns(&[2, 1]);
        assert!(matches!(acc.fault, Some(Fault::Columns { block: 0, .. })));
        let mut acc = Accumulator::new(vec![0, 1, 2], 3);
        acc.start_block(1);
        acc.row(0.0, &[]);
        assert!(matches!(
            acc.fault,
            Some(Fault::Row {
                block: 1,
                row: 0,
                ..
            })
        ));
    }
}
