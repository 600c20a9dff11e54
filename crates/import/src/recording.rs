//! What every reader gives: one axis' deviations in file units, in the order they were
//! recorded, ready to become a laser `linear` run.

/// A positioning recording of one linear axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The axis the file names, if it names one (`TestAxis: (X)`, `Axis: X`).
    pub axis: Option<char>,
    /// Commanded positions along the axis, mm; `None` when the file has none (a dynamic
    /// capture at a held position: the axis' `--hold` value is used).
    pub positions_mm: Option<Vec<f64>>,
    /// Deviations, measured − commanded (or the change since the first sample of a capture),
    /// µm, one per sample.
    pub deviations_um: Vec<f64>,
    /// Seconds since the recording started, when the file says (a sample rate); else the
    /// samples are one second apart.
    pub t_s: Option<Vec<f64>>,
    /// Context columns (`T_air` °C, `P_air` hPa, `T_material` °C), one value per sample.
    pub context: Vec<(String, Vec<f64>)>,
    /// Distinct target positions (0 for a capture at one position).
    pub targets: usize,
    /// Cycles (ISO 230-2 bidirectional cycles, or runs of the file); 1 for a capture.
    pub cycles: usize,
    /// The file's unit of length as it names it (`mm`, `inch`).
    pub unit: String,
}

impl Recording {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.deviations_um.len()
    }

    /// Whether there are no samples (no reader returns such a recording).
    pub fn is_empty(&self) -> bool {
        self.deviations_um.is_empty()
    }
}
