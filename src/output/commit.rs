//! Committing a run's outputs as one unit.
//!
//! A directory of outputs always holds one run: a renderer that loads
//! `svo.bin` and `lightfield.bin` from it must get two files of the same
//! placement. So a job never writes into the output directory. It writes
//! every file into a fresh staging directory beside it
//! (`.NAME.probeplace-PID-NANOS`), syncs each file and the directory, and
//! only then swaps the staging directory with the output directory in one
//! `renameat2(RENAME_EXCHANGE)` (Linux); the previous run, now under the
//! staging name, is removed. Whatever fails before the swap (a full disk, a
//! name that cannot be written) removes the staging directory and leaves
//! the previous output whole; a kill at any point leaves the old set or the
//! new one, never a mix, and the next run into the same output directory
//! (not one into another directory beside it) removes the
//! staging directories of dead processes. A run claims its directory
//! before its first stage ([`claim`]) with a lock beside it, so a second
//! run into it is refused while the first is under way, never mixed with
//! it. Files an earlier run of another job left there are gone after the
//! swap; a file no run wrote is never touched: a directory holding one is
//! refused ([`check_destination`]).
//!
//! Files a run reuses from an earlier one (`--from DIR`) are *carried*:
//! hard-linked (or copied) into the staging directory, so they too belong
//! to the new set. A carried file is linked by its resolved path, never as
//! a symbolic link (one pointing into the output directory would point at
//! itself after the swap), and only if it is still the file, with the
//! contents, that the run checked against the earlier manifest at its
//! start: another run's commit or an edit in between refuses the run.
//!
//! Every set gets a [`manifest`] (`manifest.json`, written last among the
//! files): each file's size and SHA-256, and the run's provenance, which
//! its PNG and EXR files carry in their own metadata too (text chunks and
//! header attributes).

use super::manifest::{self, Manifest};
use super::names;
use crate::error::{Error, Result};
use crate::provenance::Stamp;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A file of an earlier run that a set carries: its name in the set, its
/// path, and what the earlier run's manifest recorded of it when the run
/// checked it (`None`: carried unchecked).
#[derive(Debug)]
struct Carried {
    name: String,
    from: PathBuf,
    expect: Option<(manifest::Entry, manifest::FileId)>,
}

/// The files of one run, by name, not yet on disk (`default()`: a set
/// without provenance).
#[derive(Debug, Default)]
pub struct OutputSet {
    files: Vec<(String, Vec<u8>)>,
    carried: Vec<Carried>,
    stamp: Option<Stamp>,
}

impl OutputSet {
    /// An empty set of a run of `provenance`: its manifest records it, and
    /// its PNG and EXR files carry it ([`OutputSet::add`]).
    pub fn of(provenance: &crate::provenance::Provenance) -> OutputSet {
        OutputSet {
            stamp: Some(Stamp::of(provenance)),
            ..OutputSet::default()
        }
    }

    /// Adds a file with its contents; a later file of the same name
    /// replaces it. A `.png` or `.exr` of a set with provenance gets it in
    /// its metadata.
    pub fn add(&mut self, name: impl Into<String>, bytes: Vec<u8>) {
        let name = name.into();
        self.remove(&name);
        let bytes = match &self.stamp {
            Some(stamp) if name.ends_with(".png") => {
                crate::encode::png::png_with_text(bytes, &stamp.pairs())
            }
            Some(stamp) if name.ends_with(".exr") => {
                crate::encode::exr::with_attributes(bytes, &stamp.pairs())
            }
            _ => bytes,
        };
        self.files.push((name, bytes));
    }

    /// Adds the file `from` (of an earlier run) under `name`, unchanged
    /// and unchecked (the tests' shortcut).
    #[cfg(test)]
    pub fn carry(&mut self, name: impl Into<String>, from: PathBuf) {
        let name = name.into();
        self.remove(&name);
        self.carried.push(Carried {
            name,
            from,
            expect: None,
        });
    }

    /// [`OutputSet::carry`] of a file the earlier run's manifest recorded
    /// as `entry`, checked as the file `id` ([`manifest::verify`]): the
    /// commit links it only if the path still names that file with those
    /// contents, and refuses the run otherwise, since what the run
    /// computed from it may no longer match it.
    pub fn carry_checked(
        &mut self,
        name: impl Into<String>,
        from: PathBuf,
        entry: manifest::Entry,
        id: manifest::FileId,
    ) {
        let name = name.into();
        self.remove(&name);
        self.carried.push(Carried {
            name,
            from,
            expect: Some((entry, id)),
        });
    }

    /// The contents of `name`: added bytes, or a carried file read back
    /// (`report.html` embeds the run's images, computed or reused);
    /// `None` when the set has no such file.
    pub fn contents(&self, name: &str) -> Result<Option<std::borrow::Cow<'_, [u8]>>> {
        if let Some((_, bytes)) = self.files.iter().find(|(n, _)| n == name) {
            return Ok(Some(std::borrow::Cow::Borrowed(bytes)));
        }
        match self.carried.iter().find(|c| c.name == name) {
            Some(Carried { from, .. }) => {
                crate::input::read(from, name, crate::limits::memory_budget())
                    .map(|b| Some(std::borrow::Cow::Owned(b)))
            }
            None => Ok(None),
        }
    }

    /// Drops `name` from the set.
    pub fn remove(&mut self, name: &str) {
        self.files.retain(|(n, _)| n != name);
        self.carried.retain(|c| c.name != name);
    }
}

/// The files that mark a directory as a probeplace output.
const MARKERS: [&str; 2] = ["report.json", "compare.json"];

/// Refuses an output directory the commit could not or must not replace:
/// a path that exists and is not a directory, one that cannot be created
/// (below a file, or where nothing may be written: [`check_creatable`]), a
/// non-empty directory that holds no probeplace output (replacing it would
/// delete the user's files), or one that holds an input of the run
/// (`inputs`: the config, the scene, its MTL files), which the swap would
/// delete. Called before any expensive stage, and again at the commit.
pub fn check_destination(dir: &Path, inputs: &[PathBuf]) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::user_file(
            dir,
            "output path exists and is not a directory",
        ));
    }
    check_creatable(dir)?;
    let out = absolute(dir);
    for input in inputs {
        if absolute(input).starts_with(&out) {
            return Err(Error::user_file(
                input,
                format!(
                    "is an input of this run but lies in the output directory {}, which the run replaces; choose another --out",
                    dir.display()
                ),
            ));
        }
    }
    if dir.is_dir() {
        let mut entries = std::fs::read_dir(dir)
            .map_err(|e| Error::user_file(dir, format!("cannot read output directory: {e}")))?;
        let empty = entries.next().is_none();
        let ours = MARKERS.iter().any(|m| is_probeplace_json(&dir.join(m)));
        if !empty && !ours {
            return Err(Error::user_file(
                dir,
                "is not empty and holds no probeplace output (report.json or compare.json); the run would replace its files, so choose an empty or new --out",
            ));
        }
        if let Some(stray) = foreign_file(dir) {
            return Err(stray);
        }
    }
    Ok(())
}

/// The first file of the output directory `dir` that its run did not
/// write, as the refusal that names it; `None` when every file is the
/// tool's. A manifest that reads cleanly lists the run's files; without
/// one (an older probeplace's directory, or a manifest deleted, cut short
/// or of another version) only names a job writes count as the tool's
/// ([`names::is_output_name`]), and only as files: a directory of that
/// name is the user's too.
fn foreign_file(dir: &Path) -> Option<Error> {
    let leave = |stray: &Path, why: String| {
        Error::user_file(
            stray,
            format!(
                "{why}, and the run replaces {} whole: move it out, or choose another --out",
                dir.display()
            ),
        )
    };
    match manifest::read(dir, "") {
        Ok(listing) => manifest::unlisted(dir, &listing).first().map(|stray| {
            leave(
                stray,
                format!(
                    "is not a file of the run in {} ({} does not list it)",
                    dir.display(),
                    manifest::NAME
                ),
            )
        }),
        Err(_) => {
            entries(dir)
                .unwrap_or_default()
                .into_iter()
                .find(|(name, is_dir)| *is_dir || !names::is_output_name(name))
                .map(|(name, _)| {
                    leave(
                        &dir.join(name),
                        format!(
                            "is not a file probeplace writes, and {} has no {} that reads cleanly to say which files its run wrote",
                            dir.display(),
                            manifest::NAME
                        ),
                    )
                })
        }
    }
}

/// The entries of the directory `dir` by name, sorted, each with whether
/// it is a directory (not followed through a link): what the checks of a
/// directory about to be replaced walk.
pub(crate) fn entries(dir: &Path) -> std::io::Result<Vec<(String, bool)>> {
    let mut found: Vec<(String, bool)> = std::fs::read_dir(dir)?
        .flatten()
        .map(|e| {
            let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
            (e.file_name().to_string_lossy().into_owned(), is_dir)
        })
        .collect();
    found.sort();
    Ok(found)
}

/// Refuses an earlier run's directory `from` (`--from`, named `label` in
/// messages) and an output directory `out` nested one in the other: the
/// commit replaces `out` whole, so a `from` inside it would be deleted
/// with it, and an `out` inside `from` would be deleted by the next run
/// into `from`. Both are compared with symbolic links resolved; the same
/// directory (a run updated in place) is allowed.
pub fn check_apart(from: &Path, out: &Path, label: &str) -> Result<()> {
    let (f, o) = (absolute(from), absolute(out));
    if f == o {
        return Ok(());
    }
    if f.starts_with(&o) {
        return Err(Error::user_file(
            from,
            format!(
                "{label}: lies inside the output directory {}, which the run replaces; choose another --out",
                out.display()
            ),
        ));
    }
    if o.starts_with(&f) {
        return Err(Error::user_file(
            out,
            format!(
                "lies inside {}, the directory of the earlier run, which a run into it would replace with this one; choose an --out outside it",
                from.display()
            ),
        ));
    }
    Ok(())
}

/// Refuses an output directory whose staging directory could not be
/// made: the commit creates the missing directories above `dir` and its
/// staging directory beside it, so the nearest ancestor of `dir` that
/// exists must be a directory (`--out notes.txt/run` names the file) in
/// which a directory can be made. The latter is tried, with a directory of
/// the staging name removed at once (a kill in between leaves one the next
/// run sweeps), since permission bits do not tell: root may write anywhere
/// the bits forbid, and nowhere on a read-only or virtual file system.
fn check_creatable(dir: &Path) -> Result<()> {
    let abs = std::path::absolute(dir).map_err(|e| Error::user_file(dir, e))?;
    let mut child = match abs.file_name() {
        Some(name) => name.to_owned(),
        None => return Ok(()),
    };
    // Messages name an ancestor as the user would: relative to the current
    // directory when `dir` is relative.
    let cwd = std::env::current_dir().unwrap_or_default();
    let shown = |a: &Path| -> PathBuf {
        match a.strip_prefix(&cwd) {
            Ok(r) if dir.is_relative() && r.as_os_str().is_empty() => PathBuf::from("."),
            Ok(r) if dir.is_relative() => r.to_path_buf(),
            _ => a.to_path_buf(),
        }
    };
    for ancestor in abs.ancestors().skip(1) {
        match std::fs::metadata(ancestor) {
            Ok(m) if m.is_dir() => {
                let probe = ancestor.join(format!(
                    ".{}.probeplace-{}-probe",
                    child.to_string_lossy(),
                    std::process::id()
                ));
                return match std::fs::create_dir(&probe) {
                    Ok(()) => {
                        let _ = std::fs::remove_dir(&probe);
                        Ok(())
                    }
                    Err(e) => Err(Error::user_file(
                        &shown(ancestor),
                        format!(
                            "cannot create the output directory {} here: {e}",
                            dir.display()
                        ),
                    )),
                };
            }
            Ok(_) => {
                return Err(Error::user_file(
                    &shown(ancestor),
                    format!(
                        "is not a directory, so the output directory {} cannot be created below it",
                        dir.display()
                    ),
                ))
            }
            Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
                return Err(Error::user_file(
                    &shown(ancestor),
                    format!("cannot reach the output directory {}: {e}", dir.display()),
                ))
            }
            // Missing, or below a file: the file is found further up.
            Err(_) => {
                if let Some(name) = ancestor.file_name() {
                    child = name.to_owned();
                }
            }
        }
    }
    Ok(())
}

/// Whether `path` is a JSON file whose `format` names probeplace.
fn is_probeplace_json(path: &Path) -> bool {
    // Never opened unless a regular file: a FIFO would block.
    let regular = std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file());
    regular
        .then(|| crate::input::read(path, "report", 1 << 26).ok())
        .flatten()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| {
            v.get("format")?
                .as_str()
                .map(|f| f.starts_with("probeplace"))
        })
        .unwrap_or(false)
}

/// `path` made absolute and normalized, without touching the file system
/// beyond the current directory (so missing paths compare too).
pub(crate) fn absolute(path: &Path) -> PathBuf {
    let p = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    std::fs::canonicalize(&p).unwrap_or_else(|_| crate::config::normalize(&p))
}

/// An output directory claimed for one run: checked ([`check_destination`])
/// and locked against every other probeplace run into it until the claim
/// is dropped. Only a claim can be committed to, so every job goes through
/// the one check.
#[derive(Debug)]
pub struct Claim {
    dir: PathBuf,
    inputs: Vec<PathBuf>,
    lock: Option<Lock>,
}

/// Claims the output directory `dir` of a run reading `inputs`: refuses it
/// as [`check_destination`] does, and when another probeplace run holds
/// it. Called before any expensive stage; the claim lives until the run
/// has committed (or failed).
///
/// Two runs into one directory are refused, not mixed: the second names
/// the first's process. A directory whose parent does not exist yet is
/// locked at the commit instead, once the parent is made (so a refused run
/// creates nothing); no earlier run can be reused from it meanwhile.
pub fn claim(dir: &Path, inputs: &[PathBuf]) -> Result<Claim> {
    check_destination(dir, inputs)?;
    let lock = Lock::take_if_parent_exists(dir)?;
    // Another run may have committed between the check and the lock.
    check_destination(dir, inputs)?;
    Ok(Claim {
        dir: dir.to_path_buf(),
        inputs: inputs.to_vec(),
        lock,
    })
}

/// Writes `set` as the whole contents of the claimed directory (module
/// docs).
///
/// Contract: on `Ok`, the directory holds exactly the set's files, synced;
/// on `Err`, it is as it was and no staging directory remains. Files
/// carried with [`OutputSet::carry_checked`] are linked only while they
/// are the files and contents checked at the run's start; otherwise the
/// run is refused ([`Error::User`] naming the file) and nothing changes.
pub fn commit(claim: &Claim, set: &OutputSet) -> Result<()> {
    fault::hold();
    check_destination(&claim.dir, &claim.inputs)?;
    let dir = std::path::absolute(&claim.dir).map_err(|e| Error::io(&claim.dir, e))?;
    let (parent, name) = match (dir.parent(), dir.file_name()) {
        (Some(p), Some(n)) => (p.to_path_buf(), n.to_string_lossy().into_owned()),
        _ => return Err(Error::user_file(&dir, "is not a directory name")),
    };
    std::fs::create_dir_all(&parent)
        .map_err(|e| Error::user_file(&parent, format!("cannot create output directory: {e}")))?;
    let _late = match claim.lock {
        Some(_) => None,
        None => Some(Lock::take(&claim.dir)?),
    };
    sweep_dead_staging(&parent, &name);
    let staging = parent.join(format!(
        ".{name}.probeplace-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    ));
    std::fs::create_dir(&staging).map_err(|e| Error::io(&staging, e))?;
    let written = write_all(&staging, set).and_then(|()| swap(&staging, &dir, &parent));
    if written.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    written
}

/// An exclusive lock on an output directory: `flock` on the file
/// `.NAME.probeplace.lock` beside it (not in it: the commit swaps the
/// directory, and a lock inside would go with it). The file holds the
/// holder's process id, for the refusal's message, and is removed when
/// the lock is dropped; a taker that finds it removed under its lock takes
/// the new one. The kernel drops a killed holder's lock.
#[derive(Debug)]
struct Lock {
    path: PathBuf,
    file: std::fs::File,
}

impl Lock {
    /// [`Lock::take`] where `dir`'s parent exists; `None` elsewhere.
    fn take_if_parent_exists(dir: &Path) -> Result<Option<Lock>> {
        let abs = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
        match abs.parent() {
            Some(p) if p.is_dir() => Lock::take(dir).map(Some),
            _ => Ok(None),
        }
    }

    /// Locks `dir`, whose parent exists; refused while another process
    /// holds it.
    fn take(dir: &Path) -> Result<Lock> {
        let abs = std::path::absolute(dir).map_err(|e| Error::io(dir, e))?;
        let (Some(parent), Some(name)) = (abs.parent(), abs.file_name()) else {
            return Err(Error::user_file(dir, "is not a directory name"));
        };
        let path = parent.join(format!(".{}.probeplace.lock", name.to_string_lossy()));
        loop {
            let mut file = open_lock_file(&path)?;
            if !try_flock(&file) {
                let holder = std::fs::read_to_string(&path).unwrap_or_default();
                let holder = match holder.trim().parse::<u32>() {
                    Ok(pid) => format!("another probeplace run (process {pid})"),
                    Err(_) => "another probeplace run".to_string(),
                };
                return Err(Error::user_file(
                    dir,
                    format!("{holder} is writing this output directory; wait for it to finish, or choose another --out"),
                ));
            }
            // The holder before us removes the file as it lets go: a lock
            // on a removed file locks nothing, so take the new one.
            let same = match (file.metadata(), std::fs::symlink_metadata(&path)) {
                (Ok(a), Ok(b)) => manifest::FileId::of(&a) == manifest::FileId::of(&b),
                _ => false,
            };
            if same {
                let _ = file.set_len(0);
                let _ = writeln!(file, "{}", std::process::id());
                return Ok(Lock { path, file });
            }
        }
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Removed while still held, so no taker locks a file it removes.
        let ours = match (self.file.metadata(), std::fs::symlink_metadata(&self.path)) {
            (Ok(a), Ok(b)) => manifest::FileId::of(&a) == manifest::FileId::of(&b),
            _ => false,
        };
        if ours {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Opens (creating) the lock file at `path`, never through a link.
fn open_lock_file(path: &Path) -> Result<std::fs::File> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true).write(true).create(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
    }
    options
        .open(path)
        .map_err(|e| Error::user_file(path, format!("cannot lock the output directory: {e}")))
}

/// Takes an exclusive `flock` without waiting; `false` when another open
/// file holds one.
fn try_flock(file: &std::fs::File) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::io::AsRawFd;
        // SAFETY: a valid open descriptor; flock has no memory effects.
        unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) == 0 }
    }
    #[cfg(not(unix))]
    {
        let _ = file;
        true
    }
}

/// Writes and syncs every file of `set` into `staging`, then the directory.
fn write_all(staging: &Path, set: &OutputSet) -> Result<()> {
    let mut step = 0;
    let mut listing = Manifest::new(set.stamp.clone());
    for (name, bytes) in &set.files {
        write_synced(staging, name, bytes, &mut step)?;
        listing
            .files
            .insert(name.clone(), manifest::entry_of(bytes));
    }
    for Carried { name, from, expect } in &set.carried {
        let path = staging.join(name);
        fault::before_write(&path);
        // By the resolved path: a link to a symbolic link would resolve
        // into the directory this commit replaces.
        let resolved = std::fs::canonicalize(from).map_err(|e| Error::io(from, e))?;
        let linked = std::fs::hard_link(&resolved, &path).is_ok();
        if !linked {
            if let Some((_, want)) = expect {
                let now = std::fs::metadata(&resolved).map_err(|e| Error::io(from, e))?;
                if manifest::FileId::of(&now) != *want {
                    return Err(changed_since_read(from));
                }
            }
            std::fs::copy(&resolved, &path).map_err(|e| Error::io(&path, e))?;
            let f = std::fs::File::open(&path).map_err(|e| Error::io(&path, e))?;
            f.sync_all().map_err(|e| Error::io(&path, e))?;
        }
        let (entry, id) = manifest::identify(&path)?;
        if let Some((want_entry, want_id)) = expect {
            if (linked && id != *want_id) || entry != *want_entry {
                return Err(changed_since_read(from));
            }
        }
        listing.files.insert(name.clone(), entry);
        step += 1;
        fault::kill_at(step);
    }
    write_synced(staging, manifest::NAME, &listing.to_bytes()?, &mut step)?;
    sync_dir(staging)?;
    fault::kill_at(step + 1);
    Ok(())
}

/// The refusal of a carried file that is no longer the one the run
/// checked at its start.
fn changed_since_read(from: &Path) -> Error {
    Error::user_file(
        from,
        "changed since this run checked it against its manifest.json (replaced by another run, or edited), so this run's outputs would not match it; nothing was written: run the job again",
    )
}

/// Writes and syncs `name` in `staging`, commit step `step + 1`.
fn write_synced(staging: &Path, name: &str, bytes: &[u8], step: &mut usize) -> Result<()> {
    let path = staging.join(name);
    fault::before_write(&path);
    let mut f = std::fs::File::create(&path).map_err(|e| Error::io(&path, e))?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .map_err(|e| Error::io(&path, e))?;
    *step += 1;
    fault::kill_at(*step);
    Ok(())
}

/// Puts `staging` in place of `dir`, removes the previous contents.
fn swap(staging: &Path, dir: &Path, parent: &Path) -> Result<()> {
    let steps = 1_000;
    if !dir.exists() && std::fs::rename(staging, dir).is_ok() {
        sync_dir(parent)?;
        fault::kill_at(steps);
        return Ok(());
    }
    exchange(staging, dir).map_err(|e| Error::io(dir, format!("cannot replace: {e}")))?;
    sync_dir(parent)?;
    fault::kill_at(steps);
    // `staging` now holds the previous run.
    let _ = std::fs::remove_dir_all(staging);
    fault::kill_at(steps + 1);
    Ok(())
}

/// Exchanges two directories atomically.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    let ca = CString::new(a.as_os_str().as_bytes())?;
    let cb = CString::new(b.as_os_str().as_bytes())?;
    // SAFETY: both pointers are valid NUL-terminated paths for the call.
    let rc = unsafe {
        libc::renameat2(
            libc::AT_FDCWD,
            ca.as_ptr(),
            libc::AT_FDCWD,
            cb.as_ptr(),
            libc::RENAME_EXCHANGE,
        )
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// Exchanges two directories: two renames where no atomic exchange exists
/// (a kill between them leaves the old set under the staging name).
#[cfg(not(target_os = "linux"))]
fn exchange(a: &Path, b: &Path) -> std::io::Result<()> {
    let aside = a.with_extension("old");
    std::fs::rename(b, &aside)?;
    std::fs::rename(a, b)?;
    std::fs::rename(&aside, a)
}

/// Syncs a directory's entries to disk.
fn sync_dir(dir: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        let f = std::fs::File::open(dir).map_err(|e| Error::io(dir, e))?;
        f.sync_all().map_err(|e| Error::io(dir, e))?;
    }
    let _ = dir;
    Ok(())
}

/// Removes staging directories of `name` in `parent` whose process is gone
/// (left by a kill); live ones belong to a concurrent run and stay.
fn sweep_dead_staging(parent: &Path, name: &str) {
    let prefix = format!(".{name}.probeplace-");
    let Ok(entries) = std::fs::read_dir(parent) else {
        return;
    };
    for e in entries.flatten() {
        let file_name = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file_name.strip_prefix(&prefix) else {
            continue;
        };
        let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
        let alive = pid.is_some_and(|p| Path::new(&format!("/proc/{p}")).exists());
        if !alive && cfg!(target_os = "linux") {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Faults for the tests of this module's promises, set by environment
/// variables the tests give the binary ([`fault::hold`] too): `PROBEPLACE_TEST_KILL_AT=N` sends
/// the process SIGKILL after commit step N (files written count 1, 2, …,
/// then the directory sync, then 1000 after the swap and 1001 after the old
/// set is removed); `PROBEPLACE_TEST_DIR_AT=NAME` makes a directory where
/// output NAME is about to be written, as a name taken by a directory would.
mod fault {
    use std::path::Path;

    /// `PROBEPLACE_TEST_HOLD_COMMIT=PATH`: at the start of the commit,
    /// with the destination claimed, writes `PATH.held` and waits (at most
    /// two minutes) until `PATH` exists, so a test can act in the window
    /// between a run's start and its commit deterministically.
    pub fn hold() {
        let Some(path) = std::env::var_os("PROBEPLACE_TEST_HOLD_COMMIT") else {
            return;
        };
        let go = std::path::PathBuf::from(path);
        let mut held = go.clone().into_os_string();
        held.push(".held");
        let _ = std::fs::write(&held, std::process::id().to_string());
        let start = std::time::Instant::now();
        while !go.exists() && start.elapsed() < std::time::Duration::from_secs(120) {
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    }

    pub fn kill_at(step: usize) {
        let Some(at) = std::env::var_os("PROBEPLACE_TEST_KILL_AT") else {
            return;
        };
        if at.to_str().and_then(|s| s.parse::<usize>().ok()) == Some(step) {
            #[cfg(unix)]
            // SAFETY: signalling our own process has no memory effects.
            unsafe {
                libc::kill(libc::getpid(), libc::SIGKILL);
            }
            std::process::abort();
        }
    }

    pub fn before_write(path: &Path) {
        if let Some(name) = std::env::var_os("PROBEPLACE_TEST_DIR_AT") {
            if path.file_name() == Some(name.as_os_str()) {
                let _ = std::fs::create_dir(path);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut v: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (
                    e.file_name().to_string_lossy().into_owned(),
                    std::fs::read(e.path()).unwrap(),
                )
            })
            .collect();
        v.sort();
        v
    }

    fn commit_to(dir: &Path, set: &OutputSet) -> Result<()> {
        commit(&claim(dir, &[])?, set)
    }

    fn set(files: &[(&str, &str)]) -> OutputSet {
        let mut s = OutputSet::default();
        for (n, b) in files {
            s.add(*n, b.as_bytes().to_vec());
        }
        s
    }

    /// A set that marks its directory as ours, with one more file.
    fn ours(name: &str, bytes: &str) -> OutputSet {
        set(&[
            ("report.json", "{\"format\":\"probeplace.report\"}"),
            (name, bytes),
        ])
    }

    #[test]
    fn a_commit_replaces_the_whole_directory_and_leaves_no_staging() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        commit_to(&out, &ours("lightfield.bin", "old")).unwrap();
        commit_to(&out, &ours("svo.bin", "new")).unwrap();
        let names: Vec<String> = listing(&out).into_iter().map(|(n, _)| n).collect();
        assert_eq!(names, ["manifest.json", "report.json", "svo.bin"]);
        assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_set_with_provenance_lists_every_file_and_stamps_its_images() {
        let p = crate::provenance::Provenance {
            tool: "probeplace test".into(),
            config_hash: "00000000000000aa".into(),
            seed: 9,
            scene_hash: "00000000000000bb".into(),
            config_given: "c.ron".into(),
            cwd: "/".into(),
            config_text: String::new(),
            overrides: Default::default(),
        };
        let mut s = OutputSet::of(&p);
        s.add(
            "report.json",
            b"{\"format\":\"probeplace.report\"}".to_vec(),
        );
        let image = crate::raster::RgbImage::from_pixel(3, 2, [10, 20, 30]);
        s.add(
            "a.png",
            crate::encode::png::encode_png(&image, "a.png").unwrap(),
        );
        s.add(
            "a.exr",
            crate::encode::exr::encode_rgb(1, 1, &[[0.5, 1.0, 2.0]]),
        );
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        commit_to(&out, &s).unwrap();
        let listing = manifest::verify(&out, "").unwrap();
        assert_eq!(listing.provenance, Some(Stamp::of(&p)));
        let names: Vec<&String> = listing.files.keys().collect();
        assert_eq!(names, ["a.exr", "a.png", "report.json"]);
        // The PNG decodes, with the four facts as text chunks.
        let png = std::fs::read(out.join("a.png")).unwrap();
        let mut reader = png::Decoder::new(std::io::Cursor::new(png))
            .read_info()
            .unwrap();
        let text: Vec<(String, String)> = reader
            .info()
            .uncompressed_latin1_text
            .iter()
            .map(|t| (t.keyword.clone(), t.text.clone()))
            .collect();
        assert_eq!(Stamp::of(&p).mismatch(&text), None, "{text:?}");
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut buf).unwrap();
        assert_eq!(&buf[..3], [10, 20, 30]);
        let exr = std::fs::read(out.join("a.exr")).unwrap();
        let attrs = crate::encode::exr::string_attributes(&exr);
        assert_eq!(Stamp::of(&p).mismatch(&attrs), None, "{attrs:?}");
        assert_eq!(
            crate::encode::exr::decode_rgb(&exr).unwrap().2,
            [[0.5, 1.0, 2.0]]
        );
    }

    #[test]
    fn a_carried_file_keeps_its_bytes_after_its_directory_is_replaced() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        commit_to(&out, &ours("probes.json", "P")).unwrap();
        let mut s = set(&[("report.json", "{\"format\":\"probeplace.report\"}")]);
        s.carry("probes.json", out.join("probes.json"));
        commit_to(&out, &s).unwrap();
        assert_eq!(std::fs::read(out.join("probes.json")).unwrap(), b"P");
    }

    #[test]
    fn a_foreign_directory_and_an_input_inside_the_output_are_refused() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("photos");
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("holiday.jpg"), b"x").unwrap();
        let e = commit_to(&out, &set(&[("a", "b")])).unwrap_err();
        assert!(matches!(e, Error::User(_)), "{e}");
        assert_eq!(listing(&out).len(), 1);
        let run = root.path().join("run");
        let e = check_destination(&run, &[run.join("scene.obj")]).unwrap_err();
        assert!(e.to_string().contains("scene.obj"), "{e}");
    }

    #[test]
    fn a_file_that_cannot_be_written_leaves_the_previous_output_whole() {
        let root = tempfile::tempdir().unwrap();
        let out = root.path().join("out");
        let old = ours("svo.bin", "old");
        commit_to(&out, &old).unwrap();
        let before = listing(&out);
        let bad = set(&[("svo.bin", "new"), ("no/such/dir/report.json", "x")]);
        assert!(commit_to(&out, &bad).is_err());
        assert_eq!(listing(&out), before);
        assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_destination_below_a_file_or_where_nothing_is_written_is_refused() {
        let root = tempfile::tempdir().unwrap();
        let file = root.path().join("notes.txt");
        std::fs::write(&file, b"x").unwrap();
        for below in [file.join("out"), file.join("a/b/out")] {
            let e = check_destination(&below, &[]).unwrap_err();
            let m = e.to_string();
            assert!(matches!(e, Error::User(_)), "{m}");
            assert!(
                m.starts_with(&format!("{}: is not a directory", file.display())),
                "{m}"
            );
        }
        // Missing directories above the destination are created by the
        // commit, so they are no reason to refuse; nor is the probe left.
        let deep = root.path().join("new/deeper/out");
        check_destination(&deep, &[]).unwrap();
        assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 1);
        // /proc takes no directories, even from root.
        if Path::new("/proc/self").exists() {
            let e = check_destination(Path::new("/proc/probeplace-out"), &[]).unwrap_err();
            assert!(e.to_string().starts_with("/proc: cannot create"), "{e}");
        }
    }
}
