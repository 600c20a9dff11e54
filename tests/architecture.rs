//! The architecture's two rules (ARCHITECTURE.md, "Layers"), checked on the sources:
//!
//! - **Crates depend downwards.** Every workspace crate sits in one layer; a normal dependency
//!   on another workspace crate must point to a lower layer (tests and benches may use anything
//!   through dev-dependencies). The independent simulator depends on no mtcal crate at all: it
//!   checks them and must share no code with them. The test kit is only ever a dev-dependency.
//! - **No import cycle between the modules of a crate.** A module is a file or folder directly
//!   under `src/`; it may use modules below it and items of the crate root (`lib.rs`/`main.rs`
//!   holds shared types and the entry points), never a module that uses it back. References are
//!   found as `crate::m`, `crate::{m, …}` and (from a top-level module) `super::m`, outside
//!   comments, strings and `#[cfg(test)]` modules; an item the root re-exports
//!   (`pub use m::Item`) counts as a use of `m`. The same holds inside every module folder
//!   (`src/m/`): its children may not use each other in a circle (`super::x`, `crate::m::x`,
//!   or an item `m` re-exports).
//! - **The identification core links no database** (`DATABASE_FREE`): the history that stores
//!   campaigns is the command line's.
//! - **An error tells its cause once.** A `thiserror` message that shows a field (`{cause}`,
//!   `{0}`) must not also make it the error's `source` (`#[source]`, `#[from]` or a field named
//!   `source`): a reader walking the chain would see the cause twice.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first. A crate may depend on crates of lower layers only.
const LAYERS: &[&[&str]] = &[
    // Numerics, the serial chain, located file reading, history trends: no mtcal dependency.
    // The test kit too: it is lowest so that every crate's tests can use it (a kit above a crate
    // would be a cycle through its tests), and `DEV_ONLY` keeps it out of every library and
    // binary.
    &[
        "mtcal-kinematics",
        "mtcal-solve",
        "mtcal-mismatch",
        "mtcal-located",
        "mtcal-testkit",
        "mtcal-trend",
    ],
    // The machine and the instrument contract.
    // The machine history (storage of identified campaigns, read from identify's JSON, and
    // what their series say through mtcal-trend) sits here so the command line and anything
    // above can use it.
    &["mtcal-machine", "mtcal-instrument", "mtcal-history"],
    // Session files and the instrument plugins (one crate each), their conformance kit.
    &[
        "mtcal-session",
        "mtcal-conformance",
        "mtcal-rtest",
        "mtcal-ballbar",
        "mtcal-laser",
        "mtcal-tracer",
        "mtcal-displacement",
        "mtcal-artefact",
    ],
    // What works on a session or an identified machine, each on its own.
    &[
        "mtcal-plugins",
        "mtcal-effects",
        "mtcal-compensate",
        "mtcal-ncprog",
        "mtcal-tolerance",
        "mtcal-report",
        "mtcal-acceptance",
    ],
    // What needs the plugins (or the effects) linked, each on its own: the identification,
    // the simulator, the importers and the volumetric test, which find the instrument whose
    // runs they write or read by the capability its plugin declares.
    &[
        "mtcal-identify",
        "mtcal-simulate",
        "mtcal-import",
        "mtcal-volumetric",
    ],
    &["mtcal-plan"],
    // The command line and the facade.
    &["mtcal-xtask", "mtcal"],
];

/// Crates that must depend on no workspace crate (dev-dependencies aside).
const INDEPENDENT: &[&str] = &["mtcal-indsim"];

/// Crates that may only be dev-dependencies: fixtures for tests, never in what ships.
const DEV_ONLY: &[&str] = &["mtcal-testkit"];

/// A crate and its workspace dependencies, each with its kind (`None` normal, `"dev"`, `"build"`).
type CrateDeps = (String, Vec<(String, Option<String>)>);

fn workspace() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `(crate, [(dependency, kind)])` for every workspace member, from `cargo metadata`.
fn dependencies() -> Vec<CrateDeps> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(workspace())
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = meta["packages"].as_array().unwrap();
    let members: BTreeSet<&str> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    packages
        .iter()
        .map(|p| {
            let deps = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| members.contains(d["name"].as_str().unwrap()))
                .map(|d| {
                    (
                        d["name"].as_str().unwrap().to_string(),
                        d["kind"].as_str().map(str::to_string),
                    )
                })
                .collect();
            (p["name"].as_str().unwrap().to_string(), deps)
        })
        .collect()
}

fn layer_of(name: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&name))
}

/// The faults of the layering rule in `deps`.
fn layering_faults(deps: &[CrateDeps]) -> Vec<String> {
    let mut faults = Vec::new();
    for (name, uses) in deps {
        let normal = uses
            .iter()
            .filter(|(_, kind)| kind.as_deref() != Some("dev"));
        faults.extend(
            normal
                .clone()
                .filter(|(d, _)| DEV_ONLY.contains(&d.as_str()))
                .map(|(d, _)| {
                    format!("{name} uses {d} outside its tests: only as a dev-dependency")
                }),
        );
        if INDEPENDENT.contains(&name.as_str()) {
            faults.extend(normal.map(|(d, _)| {
                format!("{name} must depend on no mtcal crate (it checks them), but uses {d}")
            }));
            continue;
        }
        let Some(own) = layer_of(name) else {
            faults.push(format!(
                "{name} is in no layer: add it to LAYERS here and ARCHITECTURE.md"
            ));
            continue;
        };
        for (d, _) in normal {
            match layer_of(d) {
                Some(l) if l < own => {}
                Some(l) => faults.push(format!(
                    "{name} (layer {own}) depends on {d} (layer {l}): only lower layers"
                )),
                None => faults.push(format!("{name} depends on {d}, which is in no layer")),
            }
        }
    }
    faults
}

#[test]
fn crates_depend_only_on_lower_layers() {
    let faults = layering_faults(&dependencies());
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

#[test]
fn the_layering_check_finds_an_upward_dependency() {
    let deps = vec![
        (
            "mtcal-kinematics".to_string(),
            vec![("mtcal-identify".to_string(), None)],
        ),
        (
            "mtcal-indsim".to_string(),
            vec![("mtcal-identify".to_string(), Some("dev".into()))],
        ),
    ];
    assert_eq!(layering_faults(&deps).len(), 1);
    let deps = vec![(
        "mtcal-indsim".to_string(),
        vec![("mtcal-kinematics".to_string(), None)],
    )];
    assert_eq!(layering_faults(&deps).len(), 1);
}

#[test]
fn the_layering_check_finds_the_test_kit_outside_tests() {
    let deps = |kind: Option<&str>| {
        vec![(
            "mtcal-identify".to_string(),
            vec![("mtcal-testkit".to_string(), kind.map(str::to_string))],
        )]
    };
    assert!(layering_faults(&deps(Some("dev"))).is_empty());
    assert_eq!(layering_faults(&deps(None)).len(), 1);
    assert_eq!(layering_faults(&deps(Some("build"))).len(), 1);
}

/// Database clients. The identification core reads and writes files; the machine history,
/// which stores campaigns in a database, is the command line's to link.
const DATABASE_CLIENTS: &[&str] = &[
    "rusqlite",
    "libsqlite3-sys",
    "postgres",
    "tokio-postgres",
    "sqlx",
    "diesel",
];

/// Crates that must link no database client, not even through another crate.
const DATABASE_FREE: &[&str] = &[
    "mtcal-identify",
    "mtcal-report",
    "mtcal-session",
    "mtcal-effects",
];

/// Every crate `krate` links (normal dependencies, transitively), from `cargo tree`.
fn linked_crates(krate: &str) -> BTreeSet<String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = std::process::Command::new(cargo)
        .args([
            "tree",
            "-p",
            krate,
            "-e",
            "normal",
            "--prefix",
            "none",
            "-f",
            "{p}",
            "--offline",
        ])
        .current_dir(workspace())
        .output()
        .expect("cargo tree runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

/// The database clients `krate` links.
fn databases_linked(krate: &str) -> Vec<String> {
    linked_crates(krate)
        .into_iter()
        .filter(|c| DATABASE_CLIENTS.contains(&c.as_str()))
        .collect()
}

#[test]
fn the_identification_links_no_database() {
    let faults: Vec<String> = DATABASE_FREE
        .iter()
        .filter_map(|k| {
            let linked = databases_linked(k);
            (!linked.is_empty()).then(|| format!("{k} links {}", linked.join(", ")))
        })
        .collect();
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

#[test]
fn the_database_check_finds_the_history_s_databases() {
    let linked = databases_linked("mtcal-history");
    for db in ["rusqlite", "postgres"] {
        assert!(linked.iter().any(|c| c == db), "{linked:?}");
    }
    // And through another crate: the command line links the history.
    assert!(!databases_linked("mtcal-xtask").is_empty());
}

/// Rust source without comments, string and character literals (their text could name a
/// module) and `#[cfg(test)]` modules.
fn code_of(source: &str) -> String {
    scrubbed(source, &mut |_| "\"\"".to_string())
}

/// The string literals of `source` (their text between the quotes, escapes as written)
/// outside comments and `#[cfg(test)]` modules.
fn string_literals(source: &str) -> Vec<String> {
    let mut all = Vec::new();
    let code = scrubbed(source, &mut |text| {
        all.push(text.to_string());
        format!("\"{}\"", all.len() - 1)
    });
    code.split('"')
        .skip(1)
        .step_by(2)
        .filter_map(|k| k.parse::<usize>().ok())
        .map(|k| all[k].clone())
        .collect()
}

/// `source` without comments, its string literals replaced by what `literal` makes of their
/// text, character literals blanked, and without `#[cfg(test)]` modules.
fn scrubbed(source: &str, literal: &mut dyn FnMut(&str) -> String) -> String {
    let b = source.as_bytes();
    let mut out = String::with_capacity(source.len());
    let mut i = 0;
    while i < b.len() {
        let rest = &source[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
        } else if rest.starts_with("/*") {
            // Block comments nest.
            let mut depth = 0;
            while i < b.len() {
                if source[i..].starts_with("/*") {
                    depth += 1;
                    i += 2;
                } else if source[i..].starts_with("*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if let Some(len) = raw_string_len(rest) {
            let raw = &rest[..len];
            let open = raw.find('"').unwrap();
            let close = raw.rfind('"').unwrap();
            out.push_str(&literal(&raw[open + 1..close]));
            i += len;
        } else if b[i] == b'"' {
            let start = i + 1;
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            out.push_str(&literal(&source[start..i.min(b.len())]));
            i += 1;
        } else if b[i] == b'\'' && char_literal_len(rest).is_some() {
            i += char_literal_len(rest).unwrap();
            out.push_str("' '");
        } else {
            let c = rest.chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    without_test_modules(&out)
}

/// The length of a raw string literal (`r"…"`, `r#"…"#`, `br"…"`) at the start of `s`.
fn raw_string_len(s: &str) -> Option<usize> {
    let body = s.strip_prefix("br").or_else(|| s.strip_prefix('r'))?;
    let hashes = body.len() - body.trim_start_matches('#').len();
    let open = &body[hashes..];
    if !open.starts_with('"') {
        return None;
    }
    let close = format!("\"{}", "#".repeat(hashes));
    let end = open[1..].find(&close)?;
    Some(s.len() - open.len() + 1 + end + close.len())
}

/// The length of a character literal (`'a'`, `'\n'`, `'\''`, `'\u{..}'`) at the start of `s`,
/// `None` for a lifetime.
fn char_literal_len(s: &str) -> Option<usize> {
    let mut chars = s[1..].char_indices();
    let (_, c) = chars.next()?;
    if c == '\\' {
        let close = s[2..].find('\'')?;
        return Some(2 + close + 1);
    }
    let (j, next) = chars.next()?;
    (next == '\'').then_some(1 + j + 1)
}

/// `code` without the `#[cfg(test)] mod … { … }` blocks.
fn without_test_modules(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let after = rest[at + "#[cfg(test)]".len()..].trim_start();
        let is_module = after.starts_with("mod ") || after.starts_with("pub mod ");
        match (is_module, after.find(['{', ';'])) {
            (true, Some(open)) if after.as_bytes()[open] == b'{' => {
                let mut depth = 0;
                let mut end = after.len();
                for (k, ch) in after[open..].char_indices() {
                    match ch {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = open + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                rest = &after[end..];
            }
            _ => rest = after,
        }
    }
    out.push_str(rest);
    out
}

fn identifier_at(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// The first path segments `code` reaches through `prefix` (`crate::` or `super::`): `m` in
/// `crate::m::x` and every name at the top of `crate::{m::x, n, o::{p, q}}`.
fn names_after(code: &str, prefix: &str) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for (at, _) in code.match_indices(prefix) {
        // `crate::` inside a longer path (`$crate::`, `my_crate::`) is not this crate.
        let before = code[..at].chars().next_back();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let rest = &code[at + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0;
            let mut start = true;
            for (k, ch) in group.char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && !c.is_whitespace() => {
                        start = false;
                        let name = identifier_at(&group[k..]);
                        if !name.is_empty() {
                            names.insert(name.to_string());
                        }
                    }
                    _ => {}
                }
            }
        } else {
            let name = identifier_at(rest);
            if !name.is_empty() {
                names.insert(name.to_string());
            }
        }
    }
    names
}

/// The modules directly inside a module folder `dir` (`src/`, or `src/m/` of module `m`; name →
/// the code of its files) and the code of the folder's own module (`lib.rs`/`main.rs`, or
/// `m/mod.rs` / `m.rs`).
fn modules(dir: &Path) -> (BTreeMap<String, String>, String) {
    let mut modules = BTreeMap::new();
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    // A module folder `m/` beside `m.rs`: that file is the folder's own module.
    let mut root = match std::fs::read_to_string(dir.with_extension("rs")) {
        Ok(text) => code_of(&text),
        Err(_) => String::new(),
    };
    let tests_only = test_module_files(&files);
    for path in files
        .iter()
        .filter(|p| !tests_only.iter().any(|t| p.starts_with(t)))
    {
        let rel = path.strip_prefix(dir).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let name = top.trim_end_matches(".rs").to_string();
        let code = code_of(&std::fs::read_to_string(path).unwrap());
        if rel.components().count() == 1 && matches!(name.as_str(), "lib" | "main" | "mod") {
            root.push_str(&code);
        } else {
            let entry: &mut String = modules.entry(name).or_default();
            // `super::` from a file in a module's folder is that module, not its parent.
            let own = if rel.components().count() == 1 || rel.ends_with("mod.rs") {
                code
            } else {
                code.replace("super::", "self::")
            };
            entry.push_str(&own);
        }
    }
    (modules, root)
}

/// The files (or folders) of modules declared for tests only (`#[cfg(test)] mod tests;`): not
/// part of the crate.
fn test_module_files(files: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(file).unwrap();
        let stem = file.file_stem().unwrap().to_string_lossy();
        // A module's children live beside `lib.rs`, `main.rs` and `mod.rs`, else in the
        // folder named after the file.
        let dir = match stem.as_ref() {
            "lib" | "main" | "mod" => file.parent().unwrap().to_path_buf(),
            _ => file.with_extension(""),
        };
        for (at, _) in text.match_indices("#[cfg(test)]") {
            let after = text[at + "#[cfg(test)]".len()..].trim_start();
            let Some(decl) = after.strip_prefix("mod ") else {
                continue;
            };
            let name = identifier_at(decl);
            if decl[name.len()..].trim_start().starts_with(';') {
                out.push(dir.join(format!("{name}.rs")));
                out.push(dir.join(name));
            }
        }
    }
    out
}

/// Module → the modules it uses, among the modules directly inside module folder `dir` of the
/// crate whose sources are in `src` (`dir` = `src` for the crate's top-level modules).
fn module_graph_in(src: &Path, dir: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let (modules, root) = modules(dir);
    // How a module names its siblings from anywhere in the crate: `crate::m::` for the
    // children of module `m` (`crate::` at the top), and `super::` from beside them.
    let path: Vec<String> = dir
        .strip_prefix(src)
        .unwrap()
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let absolute: String = std::iter::once("crate".to_string())
        .chain(path)
        .map(|p| p + "::")
        .collect();
    // Items the folder's module re-exports from a child: `pub use m::{A, b::C};` → A, C → m.
    let mut reexports: BTreeMap<String, String> = BTreeMap::new();
    for (at, _) in root.match_indices("pub use ") {
        let stmt = &root[at + 8..];
        let stmt = &stmt[..stmt.find(';').unwrap_or(stmt.len())];
        let stmt = stmt
            .trim_start_matches(absolute.as_str())
            .trim_start_matches("self::");
        let m = identifier_at(stmt);
        if modules.contains_key(m) {
            for item in stmt[m.len()..]
                .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .filter(|w| !w.is_empty() && *w != "as" && *w != "self")
            {
                reexports.insert(item.to_string(), m.to_string());
            }
        }
    }
    modules
        .iter()
        .map(|(name, code)| {
            let mut names = names_after(code, &absolute);
            names.extend(names_after(code, "super::"));
            let uses = names
                .into_iter()
                .filter_map(|n| {
                    if modules.contains_key(&n) {
                        Some(n)
                    } else {
                        reexports.get(&n).cloned()
                    }
                })
                .filter(|n| n != name)
                .collect();
            (name.clone(), uses)
        })
        .collect()
}

/// The crate's top-level modules → the modules each uses.
fn module_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    module_graph_in(src, src)
}

/// Every module folder of a crate (`src/` itself first, then each `src/…/m/`), except the
/// folders of test-only modules.
fn module_folders(src: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut folders = vec![src.to_path_buf()];
    let mut stack = vec![src.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path.clone());
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    let tests_only = test_module_files(&files);
    folders.retain(|f| !tests_only.iter().any(|t| f.starts_with(t)));
    folders
}

/// Every cycle's modules (strongly connected components of more than one module), each as
/// `a → b → … → a` along one closed path.
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<String> {
    let reach = |from: &str| -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut stack = vec![from.to_string()];
        while let Some(m) = stack.pop() {
            for n in graph.get(&m).into_iter().flatten() {
                if seen.insert(n.clone()) {
                    stack.push(n.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, BTreeSet<String>> =
        graph.keys().map(|m| (m, reach(m))).collect();
    let mut done = BTreeSet::new();
    let mut out = Vec::new();
    for m in graph.keys() {
        if done.contains(m) || !reached[m].contains(m) {
            continue;
        }
        let component: BTreeSet<String> = reached[m]
            .iter()
            .filter(|n| reached[*n].contains(m))
            .cloned()
            .collect();
        done.extend(component.iter().cloned());
        out.push(
            component
                .iter()
                .map(|n| {
                    let inside: Vec<&String> =
                        graph[n].iter().filter(|d| component.contains(*d)).collect();
                    format!("{n} → {inside:?}")
                })
                .collect::<Vec<_>>()
                .join("; "),
        );
    }
    out
}

fn crate_sources() -> Vec<PathBuf> {
    let ws = workspace();
    let mut dirs = vec![
        ws.join("src"),
        ws.join("kinematics/src"),
        ws.join("xtask/src"),
    ];
    for group in ["crates", "plugins"] {
        let mut found: Vec<PathBuf> = std::fs::read_dir(ws.join(group))
            .unwrap()
            .map(|e| e.unwrap().path().join("src"))
            .filter(|p| p.is_dir())
            .collect();
        found.sort();
        dirs.extend(found);
    }
    dirs
}

#[test]
fn no_crate_has_an_import_cycle_between_its_modules() {
    let mut faults = Vec::new();
    for src in crate_sources() {
        for dir in module_folders(&src) {
            for cycle in cycles(&module_graph_in(&src, &dir)) {
                let at = dir.strip_prefix(workspace()).unwrap();
                faults.push(format!("{}: {cycle}", at.display()));
            }
        }
    }
    assert!(
        faults.is_empty(),
        "modules that use each other:\n{}",
        faults.join("\n")
    );
}

#[test]
fn the_cycle_check_reads_paths_groups_and_reexports() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    let write = |f: &str, s: &str| std::fs::write(src.join(f), s).unwrap();
    write(
        "lib.rs",
        "mod a; mod b; mod c; pub use c::Thing;\n#[cfg(test)]\nmod tests;\n",
    );
    // `a` uses `b` through a group, `b` uses `c` through the root's re-export; comments,
    // strings and test modules do not count.
    write(
        "a.rs",
        "use crate::{x, b::{One, Two}};\n// crate::c\nfn f() { let s = \"crate::c\"; }",
    );
    write(
        "b.rs",
        "use crate::Thing;\n#[cfg(test)]\nmod tests { use crate::a; }",
    );
    write("c.rs", "fn g() -> char { '\"' }\nfn h<'a>(x: &'a str) {}");
    write("tests.rs", "use crate::a;");
    let graph = module_graph(src);
    assert_eq!(graph["a"], ["b".to_string()].into());
    assert_eq!(graph["b"], ["c".to_string()].into());
    assert!(graph["c"].is_empty() && !graph.contains_key("tests"));
    assert!(cycles(&graph).is_empty());
    // `c` using `a` back closes the cycle; `super::` from a top-level module is the root.
    write("c.rs", "fn g() { super::a::f(); }");
    let found = cycles(&module_graph(src));
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with("a → [\"b\"]"), "{found:?}");
}

#[test]
fn the_cycle_check_looks_inside_module_folders() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    let write = |f: &str, s: &str| {
        let path = src.join(f);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, s).unwrap();
    };
    write("lib.rs", "mod m;");
    write("m/mod.rs", "mod a; mod b; mod c; pub use c::Shared;");
    // `a` uses its sibling `b` through `super::`, `b` uses `c` through the folder module's
    // re-export; `c/inner.rs`'s `super::` is `c` itself.
    write("m/a.rs", "use super::b::f;");
    write("m/b.rs", "use super::Shared;");
    write("m/c.rs", "mod inner; pub struct Shared;");
    write("m/c/inner.rs", "use super::Shared;");
    let folders = module_folders(src);
    assert!(folders.contains(&src.join("m")) && folders.contains(&src.join("m/c")));
    let graph = module_graph_in(src, &src.join("m"));
    assert_eq!(graph["a"], ["b".to_string()].into());
    assert_eq!(graph["b"], ["c".to_string()].into());
    assert!(graph["c"].is_empty(), "{graph:?}");
    assert!(cycles(&graph).is_empty());
    // `c` naming `a` by its absolute path closes a cycle inside `m`.
    write("m/c/inner.rs", "use crate::m::a::g;");
    let found = cycles(&module_graph_in(src, &src.join("m")));
    assert_eq!(found.len(), 1, "{found:?}");
}

// ---------------------------------------------------------------------------------------------
// Errors tell their cause once

/// The names a `#[error(...)]` attribute's text shows: `{name}`, `{0}`, `{name:?}`, and bare
/// arguments after the format string.
fn shown_fields(attr: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = attr;
    while let Some(i) = rest.find('{') {
        rest = &rest[i + 1..];
        if rest.starts_with('{') {
            rest = &rest[1..];
            continue;
        }
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if !name.is_empty() {
            out.insert(name);
        }
    }
    if let Some(args) = attr.rsplit_once('"').map(|(_, a)| a) {
        for arg in args.split(',') {
            let arg = arg.trim();
            let name = arg.split('.').next().unwrap_or("");
            if !name.is_empty() && name.chars().all(|c| c.is_alphanumeric() || c == '_') {
                out.insert(name.to_string());
            }
        }
    }
    out
}

/// The text between the bracket at the start of `s` and its match.
fn bracketed(s: &str) -> &str {
    let mut depth = 0;
    for (i, c) in s.char_indices() {
        match c {
            '(' | '{' | '[' | '<' => depth += 1,
            ')' | '}' | ']' | '>' => {
                depth -= 1;
                if depth == 0 {
                    return &s[1..i];
                }
            }
            _ => {}
        }
    }
    s
}

/// Splits at the commas outside brackets.
fn top_level_fields(body: &str) -> Vec<&str> {
    let (mut out, mut depth, mut start) = (Vec::new(), 0i32, 0);
    for (i, c) in body.char_indices() {
        match c {
            '(' | '{' | '[' | '<' => depth += 1,
            ')' | '}' | ']' | '>' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&body[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&body[start..]);
    out.into_iter().filter(|f| !f.trim().is_empty()).collect()
}

/// A field's declaration without its attributes and comments.
fn without_attributes(field: &str) -> String {
    let mut out = String::new();
    for line in field
        .lines()
        .map(str::trim)
        .filter(|l| !l.starts_with("//"))
    {
        let mut rest = line;
        while let Some(i) = rest.find("#[") {
            out.push_str(&rest[..i]);
            let end = rest[i..].find(']').map_or(rest.len(), |e| i + e + 1);
            rest = &rest[end..];
        }
        out.push_str(rest);
        out.push(' ');
    }
    out.trim().to_string()
}

/// The fields of the variant or struct an `#[error]` attribute stands on that it both shows
/// and makes its source.
fn causes_told_twice(code: &str) -> Vec<String> {
    let mut faults = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("#[error(") {
        rest = &rest[i + "#[error(".len()..];
        let Some(end) = rest.find(")]") else { break };
        let attr = &rest[..end];
        if attr.trim_start().starts_with("transparent") {
            continue;
        }
        let shown = shown_fields(attr);
        let after = &rest[end + 2..];
        // The item's fields: the first bracket after the name, unless the item ends first.
        let open = after.find(['{', '(']);
        let close = after.find([',', ';']);
        let Some(open) = open.filter(|o| close.is_none_or(|c| *o < c)) else {
            continue;
        };
        let name = after[..open].split_whitespace().last().unwrap_or("?");
        for (index, field) in top_level_fields(bracketed(&after[open..]))
            .into_iter()
            .enumerate()
        {
            let field = field.trim();
            let declared = without_attributes(field);
            // `name: Type` (not a path's `::`) is a named field; anything else a tuple field.
            let named = declared
                .split_once(':')
                .filter(|(_, ty)| !ty.starts_with(':'))
                .map(|(n, _)| n.trim().trim_start_matches("pub ").trim())
                .filter(|n| n.chars().all(|c| c.is_alphanumeric() || c == '_'));
            let field_name = named.map_or_else(|| index.to_string(), str::to_string);
            let is_source =
                field.contains("#[source]") || field.contains("#[from]") || field_name == "source";
            if is_source && shown.contains(&field_name) {
                faults.push(format!(
                    "{name}: `{field_name}` is in the message and the source"
                ));
            }
        }
    }
    faults
}

#[test]
fn errors_tell_their_cause_once() {
    let mut faults = Vec::new();
    for src in crate_sources() {
        for f in rust_files(&src) {
            let code = std::fs::read_to_string(&f).unwrap();
            let at = f.strip_prefix(workspace()).unwrap().display().to_string();
            faults.extend(
                causes_told_twice(&code)
                    .into_iter()
                    .map(|x| format!("{at}: {x}")),
            );
        }
    }
    assert!(
        faults.is_empty(),
        "errors that tell their cause twice:\n{}",
        faults.join("\n")
    );
}

#[test]
fn the_cause_check_finds_a_cause_told_twice() {
    let code = r#"
        enum E {
            #[error("{}: cannot read: {source}", path.display())]
            Read { path: PathBuf, #[source] source: io::Error },
            #[error("{}: cannot write: {cause}", path.display())]
            Write { path: PathBuf, cause: io::Error },
            #[error("model: {0}")]
            Model(#[from] ModelError),
            #[error(transparent)]
            Other(#[from] OtherError),
            #[error("at {at}")]
            Unit,
            #[error("{at}: {message}")]
            Invalid { at: Location, message: String },
            #[error("mismatch: {0}")]
            Mismatch(#[from] mtcal_mismatch::MismatchError),
        }
    "#;
    assert_eq!(
        causes_told_twice(code),
        [
            "Read: `source` is in the message and the source",
            "Model: `0` is in the message and the source",
            "Mismatch: `0` is in the message and the source"
        ]
    );
}

/// The `name: "…"` of every `inventory::submit!` registration of an instrument plugin or an
/// effect family in the sources under `dirs`: the instruments' names (plugins/) or the effect
/// families' (crates/effects). Other registrations (a plugin's capabilities) name no one new.
fn registered_names(dirs: &[PathBuf]) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    for dir in dirs {
        for file in rust_files(dir) {
            let source = std::fs::read_to_string(&file).unwrap();
            for block in source.split("inventory::submit!").skip(1) {
                let registered = block.split('{').nth(1).unwrap_or_default();
                if !["InstrumentPlugin", "EffectFamily"]
                    .iter()
                    .any(|ty| registered.trim_end().ends_with(ty))
                {
                    continue;
                }
                let Some(at) = block.find("name: \"") else {
                    continue;
                };
                let rest = &block[at + "name: \"".len()..];
                names.insert(rest[..rest.find('"').unwrap()].to_string());
            }
        }
    }
    names
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// Libraries that may name instruments or effect families: their homes (the plugins, the
/// registry, the effects), the independent simulator (it writes its own sessions and shares
/// no code) and the test kit (fixtures). The command line is not a library.
const NAME_HOMES: &[&str] = &[
    "crates/effects",
    "crates/plugins",
    "crates/indsim",
    "crates/testkit",
];

/// `(file, name)` for every string literal in a library outside [`NAME_HOMES`] that is
/// exactly the name of an instrument or an effect family.
fn names_outside_homes(root: &Path) -> BTreeSet<(String, String)> {
    let plugins: Vec<PathBuf> = std::fs::read_dir(root.join("plugins"))
        .unwrap()
        .map(|e| e.unwrap().path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    let mut names = registered_names(&plugins);
    names.extend(registered_names(&[root.join("crates/effects/src")]));
    let mut libraries = vec![root.join("kinematics/src")];
    let mut crates: Vec<PathBuf> = std::fs::read_dir(root.join("crates"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().to_string();
            !NAME_HOMES.contains(&rel.as_str())
        })
        .map(|p| p.join("src"))
        .filter(|p| p.is_dir())
        .collect();
    crates.sort();
    libraries.extend(crates);
    let mut found = BTreeSet::new();
    for dir in libraries {
        let files = rust_files(&dir);
        let tests = test_module_files(&files);
        for file in files {
            if tests.iter().any(|t| file.starts_with(t)) {
                continue;
            }
            let source = std::fs::read_to_string(&file).unwrap();
            for text in string_literals(&source) {
                if names.contains(&text) {
                    let rel = file
                        .strip_prefix(root)
                        .unwrap()
                        .to_string_lossy()
                        .to_string();
                    found.insert((rel, text));
                }
            }
        }
    }
    found
}

/// A tool that needs to know something of an instrument or a family asks its plugin or
/// family (a registration, a capability it declares) instead of naming it.
#[test]
fn no_library_names_an_instrument_or_an_effect_family_outside_its_home() {
    let found: Vec<String> = names_outside_homes(&workspace())
        .into_iter()
        .map(|(f, n)| format!("{f} names \"{n}\": put what it knows of it in the plugin or family"))
        .collect();
    assert!(found.is_empty(), "{}", found.join("\n"));
}

#[test]
fn the_name_check_reads_literals_outside_comments_and_tests() {
    let source = r#"
        // "rtest" in a comment
        fn f() -> &'static str { if x == "ballbar" { "the rtest head" } else { r"cyclic" } }
        #[cfg(test)]
        mod tests { fn g() { let _ = "laser"; } }
    "#;
    assert_eq!(
        string_literals(source),
        ["ballbar", "the rtest head", "cyclic"]
    );
    // On the real tree: the instruments and the families are found where they are
    // registered, and the homes are what keeps them from being reported.
    let root = workspace();
    let names = registered_names(&[
        root.join("plugins/rtest/src"),
        root.join("crates/effects/src"),
    ]);
    for name in ["rtest", "thermal-model", "reversal"] {
        assert!(names.contains(name), "{names:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// ARCHITECTURE.md stays true and short

/// Words a newcomer reads in about ten minutes with time left to look at the code.
const ARCHITECTURE_WORDS: usize = 2_200;

/// The layer table of ARCHITECTURE.md: per line that starts with a layer number, the crate
/// names on it (`mtcal-…`; a plugin folder list counts as the plugins' crates).
fn documented_layers(text: &str) -> Vec<(usize, BTreeSet<String>)> {
    let table = text
        .split("## Layers")
        .nth(1)
        .and_then(|t| t.split("```").nth(1))
        .unwrap_or("");
    let mut layers: Vec<(usize, BTreeSet<String>)> = Vec::new();
    for line in table.lines() {
        let mut words = line.split_whitespace().peekable();
        if let Some(n) = words.peek().and_then(|w| w.parse::<usize>().ok()) {
            words.next();
            layers.push((n, BTreeSet::new()));
        }
        let Some((_, names)) = layers.last_mut() else {
            continue;
        };
        for word in line.split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '/' || c == '*'))
        {
            if word.starts_with("mtcal-") || word == "mtcal" {
                names.insert(word.to_string());
            }
        }
        // `plugins/* (rtest ballbar …)`: the plugin crates by their folders.
        if let Some(listed) = line.split("plugins/* (").nth(1) {
            let listed = listed.split(')').next().unwrap_or("");
            names.extend(listed.split_whitespace().map(|p| format!("mtcal-{p}")));
        }
    }
    layers
}

/// Repository paths ARCHITECTURE.md names in backticks (`a/b.rs`, `crates/x/`) that do not
/// exist.
fn missing_paths(text: &str, root: &Path) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|s| s.contains('/') && !s.contains(' ') && !s.contains("::"))
        .filter(|s| {
            let first = s.split('/').next().unwrap_or("");
            [
                "crates",
                "kinematics",
                "plugins",
                "tests",
                "xtask",
                "python",
                "benches",
            ]
            .contains(&first)
        })
        .filter(|s| !root.join(s.trim_end_matches('/')).exists())
        .map(str::to_string)
        .collect()
}

#[test]
fn architecture_md_tells_the_layers_and_paths_as_they_are_and_stays_short() {
    let root = workspace();
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let words = text.split_whitespace().count();
    assert!(
        words <= ARCHITECTURE_WORDS,
        "ARCHITECTURE.md has {words} words; keep it within {ARCHITECTURE_WORDS}"
    );
    let documented = documented_layers(&text);
    for (layer, crates) in LAYERS.iter().enumerate() {
        for name in crates.iter().filter(|n| !DEV_ONLY.contains(n)) {
            let at = documented.iter().find(|(_, names)| names.contains(*name));
            assert_eq!(
                at.map(|(n, _)| *n),
                Some(layer),
                "{name}: layer {layer} in tests/architecture.rs, {:?} in ARCHITECTURE.md",
                at.map(|(n, _)| n)
            );
        }
    }
    let missing = missing_paths(&text, &root);
    assert!(missing.is_empty(), "ARCHITECTURE.md names {missing:?}");
}

#[test]
fn the_architecture_md_checks_read_the_table_and_find_a_missing_path() {
    let text = "## Layers\n\n```\n1  mtcal-a   plugins/* (x y)\n   mtcal-b\n0  mtcal-c\n```\n\
                see `tests/architecture.rs` and `crates/nowhere/src/lib.rs`, `a::b/c`\n";
    let layers = documented_layers(text);
    let names = |n: usize| -> Vec<String> {
        layers
            .iter()
            .find(|(l, _)| *l == n)
            .map(|(_, s)| s.iter().cloned().collect())
            .unwrap_or_default()
    };
    assert_eq!(names(1), ["mtcal-a", "mtcal-b", "mtcal-x", "mtcal-y"]);
    assert_eq!(names(0), ["mtcal-c"]);
    assert_eq!(
        missing_paths(text, &workspace()),
        ["crates/nowhere/src/lib.rs"]
    );
}
