//! What the tests that run whole sessions share: a written session put as a user has it, a
//! bundled session copied to edit, and a work list run on a few threads.

use std::path::{Path, PathBuf};

/// The files of the session folder `from` (its manifest, runs and machine; not its
/// subfolders) copied into a new folder `to`, which is returned.
pub fn copied(from: &Path, to: &Path) -> PathBuf {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        if entry.file_type().unwrap().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
    to.to_path_buf()
}

/// The session in `dir` as a user has it: the machine's URDF copied beside it as
/// `machine.urdf` (without the shipped error-model file, so the default full model applies)
/// and, when `parameters` is given (a TOML list), those named in `[identify] parameters`.
pub fn as_a_user_has_it(dir: &Path, parameters: Option<&str>) {
    let manifest = dir.join("session.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let line = text.lines().find(|l| l.starts_with("machine")).unwrap();
    let urdf = line.split('"').nth(1).unwrap();
    std::fs::copy(dir.join(urdf), dir.join("machine.urdf")).unwrap();
    let named = match parameters {
        Some(list) => format!("machine = \"machine.urdf\"\n\n[identify]\nparameters = {list}"),
        None => "machine = \"machine.urdf\"".to_string(),
    };
    std::fs::write(&manifest, text.replace(line, &named)).unwrap();
}

/// `f` over `items` on up to four threads, the results in the items' order.
pub fn parallel<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let next = std::sync::atomic::AtomicUsize::new(0);
    let out: std::sync::Mutex<Vec<Option<R>>> =
        std::sync::Mutex::new((0..items.len()).map(|_| None).collect());
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(4);
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(item) = items.get(k) else { return };
                    let r = f(item);
                    out.lock().unwrap()[k] = Some(r);
                }
            });
        }
    });
    out.into_inner()
        .unwrap()
        .into_iter()
        .map(|r| r.expect("every item run"))
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn parallel_keeps_the_order_of_its_items() {
        let items: Vec<u64> = (0..50).collect();
        assert_eq!(
            super::parallel(&items, |&k| k * k),
            items.iter().map(|k| k * k).collect::<Vec<_>>()
        );
    }

    #[test]
    fn a_session_as_a_user_has_it_names_the_urdf_beside_it() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.urdf"), "<robot/>").unwrap();
        std::fs::write(
            dir.path().join("session.toml"),
            "machine = \"m.urdf\"\n[[run]]\n",
        )
        .unwrap();
        super::as_a_user_has_it(dir.path(), Some("[\"EX0C\"]"));
        let text = std::fs::read_to_string(dir.path().join("session.toml")).unwrap();
        assert!(
            text.starts_with("machine = \"machine.urdf\"\n\n[identify]\nparameters = [\"EX0C\"]\n"),
            "{text}"
        );
        assert!(dir.path().join("machine.urdf").exists());
    }
}
