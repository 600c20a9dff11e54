//! The session manifest, `session.toml`: reading it with located errors, writing it back.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Component, Path, PathBuf};

use serde::Serialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use mtcal_located::toml::{Parsed, Problem, entries, problem, wrong_type};

use crate::error::{Location, SessionError, locate};

/// The manifest's file name inside a session folder.
pub const MANIFEST_NAME: &str = "session.toml";

/// The top-level keys a manifest may have.
pub const TOP_KEYS: &[&str] = &["machine", "setup", "run", "identify"];

/// The keys of a `[[run]]` that this crate interprets; any other key is kept in
/// [`RunSpec::extra`] for the instrument plugin, which documents it.
pub const RUN_KEYS: &[&str] = &["name", "instrument", "file", "use", "setup"];

/// A loaded measurement session.
#[derive(Debug, Clone, PartialEq)]
pub struct Session {
    /// The session folder (the manifest's folder).
    pub dir: PathBuf,
    /// The manifest, `dir/session.toml` unless another file was named.
    pub manifest: PathBuf,
    /// `machine` as written: a path relative to the manifest or a topology code.
    pub machine: String,
    /// Where `machine`'s value is written, for messages.
    pub machine_at: Location,
    /// `dir/machine` when that is an existing file or `machine` ends in `.urdf`; `None` means
    /// `machine` is meant as a topology code.
    pub machine_path: Option<PathBuf>,
    /// The shared set-ups, `[setup.<name>]`.
    pub setups: BTreeMap<String, toml::Table>,
    /// The runs in file order.
    pub runs: Vec<RunSpec>,
    /// `[identify]`: options of the identification (mtcal's addition; `mtcal-identify`
    /// documents its keys). Empty when absent.
    pub identify: toml::Table,
    /// Where each `[identify]` key's value is written, for messages.
    pub identify_at: BTreeMap<String, Location>,
    /// Where each key's value of each shared set-up `[setup.<name>]` is written, for messages.
    pub setup_at: BTreeMap<String, BTreeMap<String, Location>>,
}

impl Session {
    /// Where key `key` of the shared set-up `setup` is written (`None` for a run's own set-up
    /// or a key it lacks). A nested key (`sensors.s1.at`) is found by its first part.
    pub fn setup_location(&self, setup: &str, key: &str) -> Option<&Location> {
        let first = key.split('.').next().unwrap_or(key);
        self.setup_at.get(setup)?.get(first)
    }

    /// `manifest:line:column` of `[identify]` key `key` (the manifest alone for a key it lacks).
    pub fn identify_location(&self, key: &str) -> String {
        match self.identify_at.get(key) {
            Some(at) => at.to_string(),
            None => self.manifest.display().to_string(),
        }
    }
}

/// One `[[run]]` of a loaded session.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// Unique within the session.
    pub name: String,
    /// The instrument plugin's name (`rtest`, `ballbar`, …); not checked here.
    pub instrument: String,
    /// The run's CSV file: the session folder joined with [`file_as_written`](Self::file_as_written).
    pub file: PathBuf,
    /// `file` as the manifest writes it, relative to the session folder.
    pub file_as_written: String,
    /// Whether the run is fitted or only predicted.
    pub use_: RunUse,
    /// The run's set-up: shared by name or its own.
    pub setup: SetupRef,
    /// Every other key of the `[[run]]`, for the instrument plugin.
    pub extra: toml::Table,
    /// Where the `[[run]]` header is, for messages.
    pub location: Location,
}

/// `use = "fit"` (the default) or `use = "validate"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RunUse {
    /// Fitted: its readings enter the identification.
    #[default]
    Fit,
    /// Not fitted: the identified model predicts it; its readings may be absent.
    Validate,
}

impl RunUse {
    /// The manifest spelling, `"fit"` or `"validate"`.
    pub fn as_str(self) -> &'static str {
        match self {
            RunUse::Fit => "fit",
            RunUse::Validate => "validate",
        }
    }
}

/// Where a run's set-up comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum SetupRef {
    /// `setup = "<name>"`: the shared table `[setup.<name>]`; runs naming the same set-up share
    /// its nuisance parameters.
    Shared(String),
    /// The run's own `[run.setup]` table, empty when the run has none.
    Own(toml::Table),
}

impl Session {
    /// The run called `name`.
    pub fn run(&self, name: &str) -> Option<&RunSpec> {
        self.runs.iter().find(|r| r.name == name)
    }

    /// The set-up keys of `run`: its shared set-up's table or its own.
    ///
    /// # Panics
    /// If `run` names a shared set-up this session does not have (impossible for a run of a
    /// session returned by [`load_session`]).
    pub fn setup_of<'a>(&'a self, run: &'a RunSpec) -> &'a toml::Table {
        match &run.setup {
            SetupRef::Own(t) => t,
            SetupRef::Shared(name) => &self.setups[name],
        }
    }

    /// The manifest that describes this session, for [`write_session`].
    pub fn to_manifest(&self) -> Manifest {
        Manifest {
            machine: self.machine.clone(),
            setups: self.setups.clone(),
            runs: self.runs.iter().map(ManifestRun::from).collect(),
            identify: self.identify.clone(),
        }
    }
}

/// The contents of a `session.toml` to write.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Manifest {
    /// A path relative to the session folder, or a topology code.
    pub machine: String,
    pub setups: BTreeMap<String, toml::Table>,
    pub runs: Vec<ManifestRun>,
    /// `[identify]` options; omitted from the file when empty.
    pub identify: toml::Table,
}

/// One `[[run]]` to write.
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestRun {
    pub name: String,
    pub instrument: String,
    /// Relative to the session folder.
    pub file: String,
    pub use_: RunUse,
    pub setup: SetupRef,
    /// Further keys for the instrument plugin; none may be one of [`RUN_KEYS`].
    pub extra: toml::Table,
}

impl From<&RunSpec> for ManifestRun {
    fn from(r: &RunSpec) -> Self {
        ManifestRun {
            name: r.name.clone(),
            instrument: r.instrument.clone(),
            file: r.file_as_written.clone(),
            use_: r.use_,
            setup: r.setup.clone(),
            extra: r.extra.clone(),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Loading

/// Loads a session from its folder or from its manifest file.
///
/// Checks everything the manifest says, including that every run's file exists inside the
/// session folder; it does not read the run files (see [`crate::read_run`]) or the machine.
pub fn load_session(dir_or_manifest: &Path) -> Result<Session, SessionError> {
    load(dir_or_manifest, Runs::Required)
}

/// [`load_session`] for a session an import adds runs to: a manifest without `[[run]]` yet
/// (the machine and the set-ups declared, nothing recorded) is accepted, with no runs.
pub fn load_session_to_extend(dir_or_manifest: &Path) -> Result<Session, SessionError> {
    load(dir_or_manifest, Runs::MayBeNone)
}

/// Whether a manifest must hold a run: a session must; one an import is about to add its
/// first runs to need not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Runs {
    Required,
    MayBeNone,
}

fn load(dir_or_manifest: &Path, runs_rule: Runs) -> Result<Session, SessionError> {
    let (dir, manifest) = if dir_or_manifest.is_dir() {
        (
            dir_or_manifest.to_path_buf(),
            dir_or_manifest.join(MANIFEST_NAME),
        )
    } else {
        let dir = dir_or_manifest
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        (dir.to_path_buf(), dir_or_manifest.to_path_buf())
    };
    let bytes = std::fs::read(&manifest).map_err(|e| SessionError::read(&manifest, e))?;
    let text = crate::text_of(&manifest, bytes)?;
    let parsed = parse(&text, runs_rule)
        .map_err(|p| SessionError::invalid(locate(&manifest, &text, p.span.start), p.message))?;
    let canon_dir = dir
        .canonicalize()
        .map_err(|e| SessionError::read(&dir, e))?;
    let mut runs = Vec::with_capacity(parsed.runs.len());
    for r in parsed.runs {
        let file_at = locate(&manifest, &text, r.file_span.start);
        let file = resolve_run_file(&dir, &canon_dir, &r.run, file_at)?;
        runs.push(RunSpec {
            name: r.run.name,
            instrument: r.run.instrument,
            file,
            file_as_written: r.run.file,
            use_: r.run.use_,
            setup: r.run.setup,
            extra: r.run.extra,
            location: locate(&manifest, &text, r.header.start),
        });
    }
    let machine_file = dir.join(&parsed.machine);
    let machine_path =
        (machine_file.is_file() || parsed.machine.ends_with(".urdf")).then_some(machine_file);
    let machine_at = locate(&manifest, &text, parsed.machine_span.start);
    let identify_at = parsed
        .identify_spans
        .into_iter()
        .map(|(k, span)| (k, locate(&manifest, &text, span.start)))
        .collect();
    let setup_at = parsed
        .setup_spans
        .into_iter()
        .map(|(name, keys)| {
            let keys = keys
                .into_iter()
                .map(|(k, span)| (k, locate(&manifest, &text, span.start)))
                .collect();
            (name, keys)
        })
        .collect();
    Ok(Session {
        dir,
        manifest,
        machine: parsed.machine,
        machine_at,
        machine_path,
        setups: parsed.setups,
        runs,
        identify: parsed.identify,
        identify_at,
        setup_at,
    })
}

/// `dir/file` after checking that it exists and, with symbolic links resolved, lies inside the
/// session folder.
fn resolve_run_file(
    dir: &Path,
    canon_dir: &Path,
    run: &ManifestRun,
    at: Location,
) -> Result<PathBuf, SessionError> {
    let path = dir.join(&run.file);
    let (name, file) = (&run.name, &run.file);
    if !path.exists() {
        let msg = format!(
            "run \"{name}\": its file \"{file}\" does not exist (looked for {})",
            path.display()
        );
        return Err(SessionError::invalid(at, msg));
    }
    if !path.is_file() {
        let msg = format!("run \"{name}\": \"{file}\" is not a file: expected a CSV file");
        return Err(SessionError::invalid(at, msg));
    }
    let canon = path
        .canonicalize()
        .map_err(|e| SessionError::read(&path, e))?;
    if !canon.starts_with(canon_dir) {
        let msg = format!(
            "run \"{name}\": file \"{file}\" leads outside the session folder through a symbolic \
             link (it resolves to {}); run files must live inside the session folder",
            canon.display()
        );
        return Err(SessionError::invalid(at, msg));
    }
    Ok(path)
}

/// A run as parsed, with the spans that later messages point at.
struct ParsedRun {
    run: ManifestRun,
    header: Range<usize>,
    file_span: Range<usize>,
}

struct ParsedManifest {
    machine: String,
    machine_span: Range<usize>,
    identify_spans: BTreeMap<String, Range<usize>>,
    setup_spans: BTreeMap<String, BTreeMap<String, Range<usize>>>,
    setups: BTreeMap<String, toml::Table>,
    runs: Vec<ParsedRun>,
    identify: toml::Table,
}

/// Parses and checks a manifest's text; touches no files.
fn parse(text: &str, runs_rule: Runs) -> Parsed<ParsedManifest> {
    let de = DeTable::parse(text)
        .map(Spanned::into_inner)
        .map_err(|e| syntax_problem(text, &e))?;
    // The same text as plain values, for the tables handed on to plugins.
    let values: toml::Table =
        toml::from_str(text).map_err(|e| problem(e.span().unwrap_or(0..0), e.message()))?;
    check_top_keys(&de)?;
    let machine = read_machine(&de)?;
    let machine_span = de.get("machine").map_or(0..0, |item| item.span());
    let identify_spans = match de.get("identify").map(|item| item.get_ref()) {
        Some(DeValue::Table(t)) => t
            .iter()
            .map(|(k, v)| (k.get_ref().to_string(), v.span()))
            .collect(),
        _ => BTreeMap::new(),
    };
    let setup_spans = match de.get("setup").map(|item| item.get_ref()) {
        Some(DeValue::Table(t)) => t
            .iter()
            .filter_map(|(name, v)| match v.get_ref() {
                DeValue::Table(keys) => Some((
                    name.get_ref().to_string(),
                    keys.iter()
                        .map(|(k, v)| (k.get_ref().to_string(), v.span()))
                        .collect(),
                )),
                _ => None,
            })
            .collect(),
        _ => BTreeMap::new(),
    };
    let setups = read_setups(&de, &values)?;
    let runs = match (de.get("run"), runs_rule) {
        (None, Runs::MayBeNone) => Vec::new(),
        _ => read_runs(text, &de, &values, &setups)?,
    };
    let identify = match (de.get("identify"), values.get("identify")) {
        (None, _) => toml::Table::new(),
        (Some(_), Some(toml::Value::Table(t))) => t.clone(),
        (Some(item), _) => {
            return Err(wrong_type(item, "`identify`", "a table, `[identify]`"));
        }
    };
    Ok(ParsedManifest {
        machine,
        setups,
        runs,
        identify,
        machine_span,
        identify_spans,
        setup_spans,
    })
}

fn syntax_problem(text: &str, e: &toml::de::Error) -> Problem {
    let span = e.span().unwrap_or(0..0);
    let key = text.get(span.clone()).unwrap_or("");
    let line_start = text[..span.start.min(text.len())]
        .rfind('\n')
        .map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("").trim();
    let message = if e.message() == "duplicate key" && key == "setup" && line.starts_with("[run.") {
        "this run has both `setup = \"<name>\"` and a `[run.setup]` table: a run either names a \
         shared set-up or has its own, not both"
            .to_string()
    } else if e.message() == "duplicate key" {
        format!("this is not valid TOML: duplicate key `{key}`")
    } else {
        format!("this is not valid TOML: {}", e.message().trim_end())
    };
    problem(span, message)
}

fn check_top_keys(de: &DeTable) -> Parsed<()> {
    match entries(de)
        .into_iter()
        .find(|(k, _, _)| !TOP_KEYS.contains(k))
    {
        Some((key, span, _)) => Err(problem(
            span,
            format!(
                "unknown top-level key `{key}`; a session manifest has only: {}",
                TOP_KEYS.join(", ")
            ),
        )),
        None => Ok(()),
    }
}

fn read_machine(de: &DeTable) -> Parsed<String> {
    let Some(item) = de.get("machine") else {
        let msg = "missing `machine`: expected `machine = \"<file>.urdf\"` (relative to this \
                   file) or `machine = \"<topology code>\"` at the top of the manifest";
        return Err(problem(0..0, msg));
    };
    match item.get_ref().as_str() {
        Some("") => Err(problem(
            item.span(),
            "`machine` is empty: expected a URDF path or a topology code",
        )),
        Some(s) => Ok(s.to_string()),
        None => Err(wrong_type(item, "`machine`", "a string")),
    }
}

fn read_setups(de: &DeTable, values: &toml::Table) -> Parsed<BTreeMap<String, toml::Table>> {
    let mut out = BTreeMap::new();
    let Some(item) = de.get("setup") else {
        return Ok(out);
    };
    let Some(table) = item.get_ref().as_table() else {
        return Err(wrong_type(
            item,
            "`setup`",
            "a table of named set-ups, `[setup.<name>]`",
        ));
    };
    for (name, span, entry) in entries(table) {
        if !entry.get_ref().is_table() {
            let what = format!("`setup.{name}`");
            let mut p = wrong_type(entry, &what, "a table of set-up keys, `[setup.<name>]`");
            p.span = span;
            return Err(p);
        }
        let value = values["setup"][name]
            .as_table()
            .expect("the value parse agrees with the spanned parse")
            .clone();
        out.insert(name.to_string(), value);
    }
    Ok(out)
}

fn read_runs(
    text: &str,
    de: &DeTable,
    values: &toml::Table,
    setups: &BTreeMap<String, toml::Table>,
) -> Parsed<Vec<ParsedRun>> {
    let Some(item) = de.get("run") else {
        let msg = "no [[run]]: a session needs at least one run, e.g.\n  [[run]]\n  name = \
                   \"r1\"\n  instrument = \"rtest\"\n  file = \"r1.csv\"";
        return Err(problem(0..0, msg));
    };
    let Some(list) = item.get_ref().as_array() else {
        return Err(wrong_type(item, "`run`", "an array of tables, `[[run]]`"));
    };
    if list.is_empty() {
        return Err(problem(
            item.span(),
            "`run` is empty: a session needs at least one run",
        ));
    }
    let mut runs: Vec<ParsedRun> = Vec::with_capacity(list.len());
    let mut first_line: BTreeMap<String, usize> = BTreeMap::new();
    for (i, entry) in list.iter().enumerate() {
        let Some(table) = entry.get_ref().as_table() else {
            return Err(wrong_type(entry, "a run", "a table, `[[run]]`"));
        };
        let value = values["run"][i]
            .as_table()
            .expect("the value parse agrees with the spanned parse");
        let run = read_run_entry(table, value, entry.span(), i + 1, setups)?;
        if let Some(first) = first_line.get(&run.run.name) {
            let name_span = table["name"].span();
            return Err(problem(
                name_span,
                format!(
                    "run name \"{}\" is used twice: the first run with it starts at line {first}; \
                     run names must be unique in a session",
                    run.run.name
                ),
            ));
        }
        let line = text[..entry.span().start].matches('\n').count() + 1;
        first_line.insert(run.run.name.clone(), line);
        runs.push(run);
    }
    Ok(runs)
}

fn read_run_entry(
    de: &DeTable,
    values: &toml::Table,
    header: Range<usize>,
    number: usize,
    setups: &BTreeMap<String, toml::Table>,
) -> Parsed<ParsedRun> {
    let required = |key: &str, example: &str| -> Parsed<(String, Range<usize>)> {
        let Some(item) = de.get(key) else {
            let msg = format!("run #{number} has no `{key}`: expected e.g. `{key} = {example}`");
            return Err(problem(header.clone(), msg));
        };
        match item.get_ref().as_str() {
            Some("") => Err(problem(item.span(), format!("`{key}` is empty"))),
            Some(s) => Ok((s.to_string(), item.span())),
            None => Err(wrong_type(item, &format!("`{key}`"), "a string")),
        }
    };
    let (name, name_span) = required("name", "\"rtest-xyc-a0\"")?;
    check_run_name(&name, name_span)?;
    let (instrument, _) = required("instrument", "\"rtest\"")?;
    let (file, file_span) = required("file", "\"rtest-xyc-a0.csv\"")?;
    check_relative(&file, file_span.clone())?;
    let use_ = read_use(de)?;
    let setup = read_setup_ref(de, values, setups)?;
    let extra = values
        .iter()
        .filter(|(k, _)| !RUN_KEYS.contains(&k.as_str()))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    Ok(ParsedRun {
        run: ManifestRun {
            name,
            instrument,
            file,
            use_,
            setup,
            extra,
        },
        header,
        file_span,
    })
}

/// Run names become file names (`--predict DIR` writes `DIR/<name>.csv`).
fn check_run_name(name: &str, span: Range<usize>) -> Parsed<()> {
    let bad = name
        .chars()
        .find(|c| matches!(c, '/' | '\\') || c.is_control());
    if let Some(c) = bad {
        let msg = format!(
            "run name \"{}\" contains {c:?}: run names become file names (<name>.csv), so they \
             may not contain '/', '\\' or control characters",
            name.escape_debug()
        );
        return Err(problem(span, msg));
    }
    if name.starts_with('.') {
        let msg = format!("run name \"{name}\" starts with '.': run names become file names");
        return Err(problem(span, msg));
    }
    Ok(())
}

/// A run file must be a relative path that stays inside the session folder.
fn check_relative(file: &str, span: Range<usize>) -> Parsed<()> {
    let path = Path::new(file);
    let escapes = path.components().any(|c| {
        matches!(
            c,
            Component::ParentDir | Component::RootDir | Component::Prefix(_)
        )
    });
    if escapes || file.starts_with('/') || file.starts_with('\\') {
        let msg = format!(
            "`file` \"{file}\" is outside the session folder: expected a path relative to the \
             session folder without `..`, such as \"runs/r1.csv\""
        );
        return Err(problem(span, msg));
    }
    Ok(())
}

fn read_use(de: &DeTable) -> Parsed<RunUse> {
    let Some(item) = de.get("use") else {
        return Ok(RunUse::Fit);
    };
    match item.get_ref().as_str() {
        Some("fit") => Ok(RunUse::Fit),
        Some("validate") => Ok(RunUse::Validate),
        Some(other) => Err(problem(
            item.span(),
            format!("`use` must be \"fit\" or \"validate\", found \"{other}\""),
        )),
        None => Err(wrong_type(item, "`use`", "\"fit\" or \"validate\"")),
    }
}

fn read_setup_ref(
    de: &DeTable,
    values: &toml::Table,
    setups: &BTreeMap<String, toml::Table>,
) -> Parsed<SetupRef> {
    let Some(item) = de.get("setup") else {
        return Ok(SetupRef::Own(toml::Table::new()));
    };
    match item.get_ref() {
        DeValue::String(name) if setups.contains_key(name.as_ref()) => {
            Ok(SetupRef::Shared(name.to_string()))
        }
        DeValue::String(name) => {
            let defined = if setups.is_empty() {
                "this session defines none".to_string()
            } else {
                let names: Vec<_> = setups.keys().map(String::as_str).collect();
                format!("defined set-ups: {}", names.join(", "))
            };
            Err(problem(
                item.span(),
                format!("`setup = \"{name}\"` names no [setup.{name}] table; {defined}"),
            ))
        }
        DeValue::Table(_) => Ok(SetupRef::Own(
            values["setup"]
                .as_table()
                .expect("the value parse agrees with the spanned parse")
                .clone(),
        )),
        _ => Err(wrong_type(
            item,
            "`setup`",
            "the name of a shared set-up or a [run.setup] table",
        )),
    }
}

// ---------------------------------------------------------------------------------------------
// Writing

#[derive(Serialize)]
struct ManifestOut<'a> {
    machine: &'a str,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    setup: &'a BTreeMap<String, toml::Table>,
    run: Vec<RunOut<'a>>,
    #[serde(skip_serializing_if = "toml::Table::is_empty")]
    identify: &'a toml::Table,
}

#[derive(Serialize)]
struct RunOut<'a> {
    name: &'a str,
    instrument: &'a str,
    file: &'a str,
    #[serde(rename = "use")]
    use_: &'static str,
    #[serde(flatten)]
    rest: toml::Table,
}

impl Manifest {
    /// The text [`write_session`] writes (unchecked); `Err` names a run key in `extra` that
    /// the manifest's own keys would clash with.
    pub fn render(&self) -> Result<String, String> {
        let mut runs = Vec::with_capacity(self.runs.len());
        for r in self.runs.iter() {
            if let Some(key) = r.extra.keys().find(|k| RUN_KEYS.contains(&k.as_str())) {
                return Err(format!(
                    "run \"{}\": `extra` holds `{key}`, which is one of the run's own keys",
                    r.name
                ));
            }
            let mut rest = r.extra.clone();
            match &r.setup {
                SetupRef::Shared(name) => {
                    rest.insert("setup".into(), toml::Value::String(name.clone()));
                }
                SetupRef::Own(t) if !t.is_empty() => {
                    rest.insert("setup".into(), toml::Value::Table(t.clone()));
                }
                SetupRef::Own(_) => {}
            }
            runs.push(RunOut {
                name: &r.name,
                instrument: &r.instrument,
                file: &r.file,
                use_: r.use_.as_str(),
                rest,
            });
        }
        let out = ManifestOut {
            machine: &self.machine,
            setup: &self.setups,
            run: runs,
            identify: &self.identify,
        };
        toml::to_string(&out).map_err(|e| e.to_string())
    }
}

/// Writes `manifest` as `dir/session.toml` (atomically: a temporary file, then a rename) and
/// returns its path.
///
/// Refuses, writing nothing, a manifest that [`load_session`] would reject for its contents
/// (the run files themselves are not checked: they may be written afterwards).
pub fn write_session(dir: &Path, manifest: &Manifest) -> Result<PathBuf, SessionError> {
    let (path, text) = session_text(dir, manifest)?;
    mtcal_located::write_atomically(&path, text.as_bytes()).map_err(|source| {
        SessionError::Write {
            path: path.clone(),
            cause: source,
        }
    })?;
    Ok(path)
}

/// What [`write_session`] writes: `dir/session.toml` and its text, checked to load again (to
/// be written with other outputs at once).
pub fn session_text(dir: &Path, manifest: &Manifest) -> Result<(PathBuf, String), SessionError> {
    let path = dir.join(MANIFEST_NAME);
    let refuse = |message: String| SessionError::NotWritten {
        path: path.clone(),
        message,
    };
    let text = manifest.render().map_err(refuse)?;
    if let Err(p) = parse(&text, Runs::Required) {
        let at = locate(&path, &text, p.span.start);
        return Err(refuse(format!(
            "it would not load (line {} of the output: {})",
            at.line, p.message
        )));
    }
    Ok((path, text))
}
