//! Digests that say which files a campaign came from: the URDF, the error model and the
//! session (its manifest and every run file, in the manifest's order), SHA-256 in hex. Two
//! campaigns with the same machine digests were identified on the same machine description;
//! the same session digest means the same recordings.

use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};

/// Why a file could not be digested.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot read it for its digest: {cause}", path.display())]
pub struct DigestError {
    pub path: PathBuf,
    pub cause: std::io::Error,
}

/// SHA-256 of the files in order, each prefixed by its length so that moving bytes from one
/// file to the next changes the digest; `sha256:` and 64 hex digits.
pub fn digest_files(files: &[&Path]) -> Result<String, DigestError> {
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    for path in files {
        let fail = |cause| DigestError {
            path: path.to_path_buf(),
            cause,
        };
        let len = std::fs::metadata(path).map_err(fail)?.len();
        hasher.update(len.to_le_bytes());
        let mut file = std::fs::File::open(path).map_err(fail)?;
        loop {
            let n = file.read(&mut buf).map_err(fail)?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
        }
    }
    Ok(hex(&hasher.finalize()))
}

/// SHA-256 of a text (a topology code, "the full ISO model"), `sha256:` and hex.
pub fn digest_text(text: &str) -> String {
    hex(&Sha256::digest(text.as_bytes()))
}

fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(7 + 2 * bytes.len());
    s.push_str("sha256:");
    for b in bytes {
        s.push_str(&format!("{b:02x}"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digests_are_sha256_and_see_where_files_part() {
        // The SHA-256 of "abc" (FIPS 180-2's example).
        assert_eq!(
            digest_text("abc"),
            "sha256:ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c, d) = (
            dir.path().join("a"),
            dir.path().join("b"),
            dir.path().join("c"),
            dir.path().join("d"),
        );
        std::fs::write(&a, "ab").unwrap();
        std::fs::write(&b, "c").unwrap();
        std::fs::write(&c, "a").unwrap();
        std::fs::write(&d, "bc").unwrap();
        let one = digest_files(&[&a, &b]).unwrap();
        assert_eq!(one, digest_files(&[&a, &b]).unwrap());
        assert_ne!(one, digest_files(&[&c, &d]).unwrap());
        let missing = dir.path().join("missing");
        let e = digest_files(&[&missing]).unwrap_err().to_string();
        assert!(e.contains("missing") && e.contains("digest"), "{e}");
    }
}
