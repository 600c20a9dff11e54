//! A study's runs: their samples as loaded (SI positions, prepared readings, label numbers),
//! read from the run files or taken from tables in memory, and checked.

use super::*;

/// One run's samples.
///
/// The samples are held once: `table` keeps the file's times, context and (for validation
/// runs, which [`crate::prediction_files`] writes back) the positions and labels as read,
/// while the positions and readings the fit uses are converted to SI in place (`q`,
/// `readings`): a fitted run's `table.positions` and every run's `table.values` are empty, a
/// fitted run's label columns are empty (their numbers are `labels`). What the mismatch
/// analysis needs from the positions in file units is summarised when the run is loaded.
#[derive(Debug)]
pub struct RunSlot {
    pub name: String,
    pub fit: bool,
    /// Index into [`Study::setups`].
    pub setup: usize,
    /// The run file: path, header, label texts.
    pub file: RunFile,
    /// Time of each sample, s.
    pub t: Column,
    /// Commanded positions, `samples × axes`: [`Columns::get`] gives SI (m, rad),
    /// [`Column::raw`] the file's mm and degrees.
    pub q: Columns,
    /// Readings, SI, `samples × channels`, as the set-up prepared them
    /// ([`SetupFormat::prepare_readings`]); `None` for a validation run without them.
    pub readings: Option<Columns>,
    /// Context columns (`T_<name>`, `P_<name>`, `H_<name>`, `S`, `F`), file units, file order.
    pub context: Vec<(String, Column)>,
    /// Each sample's label number ([`SetupFormat::resolve_label`]); empty when the instrument has no
    /// label columns.
    pub labels: Vec<u32>,
    /// Block means and directions of the commanded positions, file units (for the mismatch
    /// analysis).
    pub(crate) position_blocks: crate::blocks::PositionBlocks,
}

/// A run's samples as loaded, before they take their place in the study.
pub(super) struct LoadedRun {
    pub(super) file: RunFile,
    pub(super) t: Column,
    pub(super) q: Columns,
    pub(super) readings: Option<Columns>,
    pub(super) context: Vec<(String, Column)>,
    pub(super) labels: Vec<u32>,
    pub(super) position_blocks: crate::blocks::PositionBlocks,
}

/// Where [`Study::assemble`] gets each run's samples, in the manifest's run order.
pub(super) enum RunSource {
    /// The run files the manifest names ([`Study::load`]).
    Files,
    /// Tables held in memory, as reading the run files would give them
    /// ([`Study::from_parts`]).
    Tables(std::vec::IntoIter<RunTable>),
}

impl RunSource {
    /// Run `spec`'s samples, loaded for the study: `setup` is its set-up, `fit` whether it is
    /// fitted.
    pub(super) fn next_run(
        &mut self,
        spec: &RunSpec,
        model: &MachineModel,
        setup: &dyn Setup,
        fit: bool,
    ) -> Result<LoadedRun, IdentifyError> {
        match self {
            RunSource::Files => {
                let table = read_run_file(spec, model, setup, fit)?;
                load_run(model, setup, table, fit)
            }
            RunSource::Tables(tables) => {
                let table = tables
                    .next()
                    .expect("Study::from_parts checked: one table per run");
                // A file's table was checked by the reader; one from memory is checked here.
                crate::checks::check_table(model, setup, &table, fit)?;
                load_run(model, setup, table, fit)
            }
        }
    }
}

impl RunSlot {
    /// Sample `i`'s label number (0 without label columns).
    pub fn label(&self, i: usize) -> u32 {
        self.labels.get(i).copied().unwrap_or(0)
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The context column called `name`.
    pub fn context_column(&self, name: &str) -> Option<&Column> {
        self.context.iter().find(|(n, _)| n == name).map(|(_, c)| c)
    }

    /// The run's numbers as plain vectors, for an instrument's whole-run functions
    /// ([`mtcal_instrument::RunData`], [`mtcal_instrument::Evaluation`]): SI positions
    /// (row-major), times and context columns.
    pub fn expanded(&self) -> ExpandedRun {
        ExpandedRun {
            q: self.q.to_row_major(),
            t: self.t.to_vec(),
            context: self
                .context
                .iter()
                .map(|(n, c)| (n.clone(), c.to_vec()))
                .collect(),
        }
    }
}

/// A run file as the study remembers it; its numbers are in [`RunSlot`]'s columns.
#[derive(Clone, Debug)]
pub struct RunFile {
    pub path: PathBuf,
    /// The header, in file order.
    pub columns: Vec<String>,
    /// The machine's axis letters.
    pub axes: Vec<char>,
    /// The instrument's reading columns.
    pub readings: Vec<String>,
    /// The label columns; a fitted run's texts are dropped once resolved to numbers.
    pub labels: Vec<(String, Vec<String>)>,
}

/// A run's positions, times and context as vectors ([`RunSlot::expanded`]).
#[derive(Debug)]
pub struct ExpandedRun {
    pub q: Vec<f64>,
    pub t: Vec<f64>,
    pub context: Vec<(String, Vec<f64>)>,
}

impl ExpandedRun {
    pub fn data(&self) -> mtcal_instrument::RunData<'_> {
        mtcal_instrument::RunData {
            q: &self.q,
            t: &self.t,
            context: &self.context,
        }
    }
}

/// Run `spec`'s file, read with the columns its set-up and the machine give.
pub(super) fn read_run_file(
    spec: &RunSpec,
    model: &MachineModel,
    setup: &dyn Setup,
    fit: bool,
) -> Result<RunTable, IdentifyError> {
    let channels: Vec<&str> = setup.channels().iter().map(|c| c.name.as_str()).collect();
    let letters: Vec<char> = model
        .machine()
        .axes()
        .iter()
        .map(|a| a.letter().as_char())
        .collect();
    let columns = RunColumns {
        axes: &letters,
        readings: &channels,
        readings_optional: !fit,
        labels: setup.label_columns(),
    };
    Ok(read_run(&spec.file, &columns)?)
}

/// A run file's table → the run as the study keeps it (checked first): times, positions,
/// readings and context in compact columns ([`mtcal_session::Column`]: bit for bit the values
/// read) that convert positions to SI as they are read, readings prepared by the set-up, labels
/// resolved to numbers (a fitted run's label texts dropped), the positions' summary for the
/// mismatch analysis.
pub(super) fn load_run(
    model: &MachineModel,
    setup: &dyn Setup,
    mut table: RunTable,
    fit: bool,
) -> Result<LoadedRun, IdentifyError> {
    crate::checks::check_run(model, setup, &table)?;
    let labels = run_labels(setup, &table)?;
    let position_blocks = crate::blocks::PositionBlocks::of(&table);
    let scales: Vec<Scale> = model
        .machine()
        .axes()
        .iter()
        .map(|a| match a.kind() {
            // What `v * 1e-3` and `v.to_radians()` compute.
            AxisKind::Linear => Scale::Mul(1e-3),
            AxisKind::Rotary => Scale::Mul(std::f64::consts::PI / 180.0),
        })
        .collect();
    let q = Columns::from_row_major(&table.positions, &scales);
    let t = Column::new(&table.t);
    let context: Vec<(String, Column)> = table
        .context
        .iter()
        .map(|(n, v)| (n.clone(), Column::new(v)))
        .collect();
    let readings = match table.values.take() {
        Some(raw) => {
            let q_si = positions_si(model, std::mem::take(&mut table.positions));
            Some(prepared_readings(setup, &table, &q_si, raw)?)
        }
        None => None,
    };
    if fit {
        for (_, column) in &mut table.labels {
            *column = Vec::new();
        }
    }
    let file = RunFile {
        path: table.path,
        columns: table.columns,
        axes: table.axes,
        readings: table.readings,
        labels: table.labels,
    };
    Ok(LoadedRun {
        file,
        t,
        q,
        readings,
        context,
        labels,
        position_blocks,
    })
}

/// Commanded positions in SI, converted in place: mm → m on linear axes, degrees → rad on
/// rotary ones.
pub(super) fn positions_si(model: &MachineModel, mut positions: Vec<f64>) -> Vec<f64> {
    let kinds: Vec<AxisKind> = model.machine().axes().iter().map(|a| a.kind()).collect();
    for row in positions.chunks_exact_mut(kinds.len()) {
        for (v, k) in row.iter_mut().zip(&kinds) {
            *v = k.from_file(*v);
        }
    }
    positions
}

/// Every sample's label number, or an error naming the cell that does not resolve.
pub(super) fn run_labels(setup: &dyn Setup, table: &RunTable) -> Result<Vec<u32>, IdentifyError> {
    if setup.label_columns().is_empty() {
        return Ok(Vec::new());
    }
    (0..table.len())
        .map(|i| {
            setup.resolve_label(&table.label_row(i)).map_err(|e| {
                let first = &table.labels[0].0;
                IdentifyError::RunData {
                    at: cell(table, i, first),
                    message: format!("column \"{first}\": {e}"),
                }
            })
        })
        .collect()
}

/// The run's readings in SI, prepared by the set-up (environmental compensation), or an error
/// naming the cell at fault. A channel the set-up leaves as it is (the file's value divided by
/// its unit) is kept as the file's numbers with that division; one it changes, as computed.
pub(super) fn prepared_readings(
    setup: &dyn Setup,
    table: &RunTable,
    q: &[f64],
    raw: Vec<f64>,
) -> Result<Columns, IdentifyError> {
    let ch = setup.channels();
    let scales: Vec<Scale> = ch.iter().map(|c| Scale::Div(c.unit.per_si())).collect();
    // The file's numbers, read as `value / unit` (µm → m); the vector is then reused for the
    // set-up's preparation, which starts from exactly these values.
    let as_read = Columns::from_row_major(&raw, &scales);
    let mut readings = raw;
    for (i, row) in readings.chunks_exact_mut(ch.len()).enumerate() {
        as_read.row_into(i, row);
    }
    let data = mtcal_instrument::RunData {
        q,
        t: &table.t,
        context: &table.context,
    };
    setup
        .prepare_readings(&data, &mut readings)
        .map_err(|e| IdentifyError::RunData {
            at: match e.row {
                Some(i) => cell(table, i, &e.column),
                None => table.path.display().to_string(),
            },
            message: e.to_string(),
        })?;
    if let Some(k) = readings.iter().position(|x| !x.is_finite()) {
        let c = &ch[k % ch.len()].name;
        return Err(IdentifyError::RunData {
            at: cell(table, k / ch.len(), c),
            message: format!("column \"{c}\": the prepared reading is not a finite number"),
        });
    }
    let nch = ch.len();
    let mut column = Vec::new();
    let columns = (0..nch)
        .map(|c| {
            let prepared = readings.iter().skip(c).step_by(nch);
            let as_read_c = as_read.column(c);
            if prepared
                .clone()
                .enumerate()
                .all(|(i, p)| as_read_c.get(i).to_bits() == p.to_bits())
            {
                as_read_c.clone()
            } else {
                column.clear();
                column.extend(prepared);
                Column::new(&column)
            }
        })
        .collect();
    Ok(Columns::from_columns(columns))
}
