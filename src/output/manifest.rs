//! `manifest.json`: what an output directory holds, file by file.
//!
//! Every committed output set ([`super::commit`]) gets one, written with
//! the set: each file's name, size and SHA-256, and the provenance of the
//! run (tool, config hash, scene hash, seed). Whatever reads a directory
//! back (`--from`, `inspect`, `export`, `merge`) checks it first with
//! [`verify`], so a file changed or copied in from another run, a damaged
//! file, a missing file and a partial set are refused in one line naming
//! the file — never reused, never written back. The rule is one for every
//! reader: refuse, and say to run the earlier job again; nothing is
//! recomputed behind the user's back.
//!
//! The hashes are SHA-256 (FIPS 180-4), so `sha256sum FILE` checks a file
//! by hand, and a copy from another run cannot pass for the original.

use crate::error::{Error, Result};
use crate::provenance::Stamp;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The manifest's file name.
pub const NAME: &str = "manifest.json";
/// The manifest's `format`.
const FORMAT: &str = "probeplace.manifest";
/// The manifest version this build writes and reads.
const VERSION: u32 = 1;

/// One file of a manifest.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Entry {
    /// Its size in bytes.
    pub bytes: u64,
    /// Its SHA-256, 64 hex digits.
    pub sha256: String,
}

/// `manifest.json` (docs/formats.md).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    /// `probeplace.manifest`.
    pub format: String,
    /// [`VERSION`].
    pub version: u32,
    /// The run's provenance; `None` for a set that has none.
    pub provenance: Option<Stamp>,
    /// Every other file of the directory, by name.
    pub files: BTreeMap<String, Entry>,
    /// The file each entry was checked on by [`verify`] (none for a
    /// manifest only read): a run that carries the file into its output
    /// checks, when it links it, that it is still that file
    /// ([`super::commit`]).
    #[serde(skip)]
    pub seen: BTreeMap<String, FileId>,
}

/// Which file a path named when it was read: device and inode, so a file
/// replaced under the same name (another run's commit swaps the whole
/// directory) is told from the one checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FileId {
    dev: u64,
    ino: u64,
}

impl FileId {
    /// The identity of the file `meta` describes (zero where the platform
    /// has no inodes, which then compare equal: the hash still decides).
    pub fn of(meta: &std::fs::Metadata) -> FileId {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            FileId {
                dev: meta.dev(),
                ino: meta.ino(),
            }
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            FileId::default()
        }
    }
}

impl Manifest {
    /// An empty manifest of a run with `provenance`.
    pub fn new(provenance: Option<Stamp>) -> Manifest {
        Manifest {
            format: FORMAT.into(),
            version: VERSION,
            provenance,
            files: BTreeMap::new(),
            seen: BTreeMap::new(),
        }
    }

    /// Whether the manifest lists `name`.
    pub fn lists(&self, name: &str) -> bool {
        self.files.contains_key(name)
    }

    /// The manifest as written: pretty JSON and a newline.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        crate::encode::json::to_json(self)
    }
}

/// The entry of `bytes`.
pub fn entry_of(bytes: &[u8]) -> Entry {
    Entry {
        bytes: bytes.len() as u64,
        sha256: hex(&Sha256::digest(bytes)),
    }
}

/// The entry of the regular file at `path`, streamed.
#[cfg(test)]
pub fn entry_of_file(path: &Path) -> Result<Entry> {
    identify(path).map(|(entry, _)| entry)
}

/// The entry of the file at `path` and which file it was: both from one
/// open file, so the hash is of the file the identity names.
pub fn identify(path: &Path) -> Result<(Entry, FileId)> {
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let id = FileId::of(&f.metadata().map_err(|e| Error::io(path, e))?);
    let mut hasher = Sha256::new();
    let mut chunk = vec![0u8; 1 << 20];
    let mut bytes = 0u64;
    loop {
        let n = f.read(&mut chunk).map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        hasher.update(&chunk[..n]);
        bytes += n as u64;
    }
    Ok((
        Entry {
            bytes,
            sha256: hex(&hasher.finalize()),
        },
        id,
    ))
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Reads `dir`'s manifest without checking the files it lists.
///
/// Contract: a missing manifest, one that is not a regular file, not JSON
/// of this format, or of another version is an [`Error::User`] naming it
/// and ending with `rerun`.
pub fn read(dir: &Path, rerun: &str) -> Result<Manifest> {
    let path = dir.join(NAME);
    let refuse = |file: &Path, why: String| Error::user_file(file, format!("{why}; {rerun}"));
    match std::fs::symlink_metadata(&path) {
        Err(_) => {
            return Err(refuse(
                &path,
                "missing: the directory was written by an older probeplace, or is not a whole output set".into(),
            ))
        }
        Ok(m) if !m.file_type().is_file() => {
            return Err(refuse(&path, "is not a regular file".into()))
        }
        Ok(_) => {}
    }
    let bytes = crate::input::read(&path, NAME, 1 << 26)?;
    let manifest: Manifest = serde_json::from_slice(&bytes)
        .map_err(|e| refuse(&path, format!("is not a probeplace manifest ({e})")))?;
    if manifest.format != FORMAT {
        return Err(refuse(
            &path,
            format!("has format `{}`, not `{FORMAT}`", manifest.format),
        ));
    }
    if manifest.version != VERSION {
        return Err(refuse(
            &path,
            format!(
                "`{FORMAT}` version {}: this build reads version {VERSION}",
                manifest.version
            ),
        ));
    }
    Ok(manifest)
}

/// Reads `dir`'s manifest and checks every file it lists: present, a
/// regular file (not a symbolic link, a FIFO or a directory), of the
/// recorded size and SHA-256. Files the manifest does not list are the
/// caller's to judge ([`unlisted`]).
///
/// Contract: never opens a file that is not a regular one (a FIFO would
/// block); every refusal is an [`Error::User`] naming the file and ending
/// with `rerun`, what the user should do.
pub fn verify(dir: &Path, rerun: &str) -> Result<Manifest> {
    let mut manifest = read(dir, rerun)?;
    let mut seen = BTreeMap::new();
    let refuse = |file: &Path, why: String| Error::user_file(file, format!("{why}; {rerun}"));
    let path = dir.join(NAME);
    for (name, want) in &manifest.files {
        if Path::new(name).file_name() != Some(std::ffi::OsStr::new(name)) || name == NAME {
            return Err(refuse(
                &path,
                format!("lists `{name}`, which is not a file of the directory"),
            ));
        }
        let file = dir.join(name);
        let meta = std::fs::symlink_metadata(&file).map_err(|_| {
            refuse(
                &file,
                format!("missing, though {NAME} lists it: the directory holds part of a run"),
            )
        })?;
        let kind = meta.file_type();
        if kind.is_symlink() {
            return Err(refuse(
                &file,
                "is a symbolic link: a run's files are reused as regular files only, never through links (copy the file in)".into(),
            ));
        }
        if !kind.is_file() {
            return Err(refuse(&file, "is not a regular file".into()));
        }
        if meta.len() != want.bytes {
            return Err(refuse(
                &file,
                format!(
                    "holds {} bytes where {NAME} records {}: changed since its run wrote it",
                    meta.len(),
                    want.bytes
                ),
            ));
        }
        let (found, id) = identify(&file)?;
        if found.sha256 != want.sha256 {
            return Err(refuse(
                &file,
                format!("its contents are not what {NAME} records (SHA-256 differs): changed since its run wrote it, or copied from another run"),
            ));
        }
        seen.insert(name.clone(), id);
    }
    manifest.seen = seen;
    Ok(manifest)
}

/// The entries of `dir` that `manifest` does not list (besides the
/// manifest itself), sorted: a file a user or another run put there.
pub fn unlisted(dir: &Path, manifest: &Manifest) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name != NAME && !manifest.lists(&name)
        })
        .map(|e| e.path())
        .collect();
    found.sort();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_set(dir: &Path, files: &[(&str, &[u8])]) {
        std::fs::create_dir_all(dir).unwrap();
        let mut m = Manifest::new(None);
        for (name, bytes) in files {
            std::fs::write(dir.join(name), bytes).unwrap();
            m.files.insert(name.to_string(), entry_of(bytes));
        }
        std::fs::write(dir.join(NAME), m.to_bytes().unwrap()).unwrap();
    }

    #[test]
    fn the_hash_is_sha256_as_sha256sum_gives_it() {
        // FIPS 180-4's example "abc".
        assert_eq!(
            entry_of(b"abc").sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let d = tempfile::tempdir().unwrap();
        let big: Vec<u8> = (0..3_000_000u32).map(|i| (i * 7 % 251) as u8).collect();
        std::fs::write(d.path().join("f"), &big).unwrap();
        assert_eq!(entry_of_file(&d.path().join("f")).unwrap(), entry_of(&big));
    }

    #[test]
    fn a_changed_missing_linked_or_foreign_file_is_refused_by_name() {
        let d = tempfile::tempdir().unwrap();
        let run = d.path().join("run");
        write_set(&run, &[("a.bin", b"first"), ("b.json", b"{}")]);
        let m = verify(&run, "rerun").unwrap();
        assert!(m.lists("a.bin") && !m.lists("c"));
        assert!(unlisted(&run, &m).is_empty());
        let refused = |why: &str| {
            let e = verify(&run, "rerun").unwrap_err();
            assert!(matches!(e, Error::User(_)), "{e}");
            let m = e.to_string();
            assert!(
                m.contains("a.bin") && m.contains(why) && m.ends_with("; rerun"),
                "{m}"
            );
        };
        // Same size, other contents: a copy from another run.
        std::fs::write(run.join("a.bin"), b"other").unwrap();
        refused("SHA-256 differs");
        std::fs::write(run.join("a.bin"), b"first!").unwrap();
        refused("holds 6 bytes");
        std::fs::remove_file(run.join("a.bin")).unwrap();
        refused("missing");
        std::fs::write(d.path().join("elsewhere"), b"first").unwrap();
        std::os::unix::fs::symlink(d.path().join("elsewhere"), run.join("a.bin")).unwrap();
        refused("symbolic link");
        std::fs::remove_file(run.join("a.bin")).unwrap();
        let fifo = std::ffi::CString::new(run.join("a.bin").to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
        refused("not a regular file");
        std::fs::remove_file(run.join("a.bin")).unwrap();
        std::fs::write(run.join("a.bin"), b"first").unwrap();
        std::fs::write(run.join("stray.exr"), b"x").unwrap();
        let m = verify(&run, "rerun").unwrap();
        assert_eq!(unlisted(&run, &m), [run.join("stray.exr")]);
        // No manifest: an older or partial directory.
        std::fs::remove_file(run.join(NAME)).unwrap();
        let e = verify(&run, "rerun").unwrap_err().to_string();
        assert!(e.contains("manifest.json: missing"), "{e}");
    }
}
