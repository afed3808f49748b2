//! An output folder and its one writer: the lock that keeps a second
//! writer out, and the record of every file and folder smokelab wrote in
//! it — all that `--overwrite` may ever remove.
//!
//! - The record, [`RECORD`] (`.smokelab-files`), lists one path a line,
//!   relative to the folder and `/`-separated; a folder's path ends in `/`.
//!   A path is appended and synced *before* its file is first written, so
//!   the files of a killed writer are recorded too. A line cut short by a
//!   kill (no final newline) is ignored.
//! - The lock, [`LOCK`] (`.smokelab-lock`), is an advisory whole-file lock
//!   (`flock`) held for as long as an [`OutputFolder`] is open; the file
//!   names its holder (process id and command line) for the message a
//!   second writer gets.
//!
//! While an [`OutputFolder`] is open, every writer of [`crate::io`] calls
//! [`claim`] first: it records a new path, and refuses to replace a file
//! that is not in the record (a user's `notes.png` beside the frames) or to
//! write through a folder that is a symbolic link.

use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::{Read as _, Write as _};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context as _, Result};

use crate::error::InputError;

/// The record of the files and folders smokelab wrote in an output folder.
pub const RECORD: &str = ".smokelab-files";

/// The lock file of an output folder's writer.
pub const LOCK: &str = ".smokelab-lock";

/// An output folder open for writing: locked, and recording what is
/// written under it until dropped.
pub struct OutputFolder {
    root: PathBuf,
    /// Held for the lock; closing it releases the lock.
    _lock: File,
}

/// An open folder's record, as [`claim`] extends it.
struct Active {
    /// The folder as an absolute path (lexically, symbolic links kept).
    root: PathBuf,
    /// The record, open for appending.
    record: File,
    /// The record's entries.
    entries: BTreeSet<String>,
}

/// The folders open for writing in this process.
static ACTIVE: Mutex<Vec<Active>> = Mutex::new(Vec::new());

fn active() -> std::sync::MutexGuard<'static, Vec<Active>> {
    ACTIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Open `path` for reading and writing without following a symbolic link
/// in its last component, creating it if missing.
fn open_no_follow(path: &Path, append: bool) -> std::io::Result<File> {
    let mut o = OpenOptions::new();
    o.read(true).create(true);
    if append {
        o.append(true);
    } else {
        o.write(true);
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        o.custom_flags(libc::O_NOFOLLOW);
    }
    o.open(path)
}

/// `path` as an absolute path, lexically (`.` removed; `..` and symbolic
/// links kept).
fn absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    abs.components()
        .filter(|c| *c != Component::CurDir)
        .collect()
}

/// Check that `entry`, read from a record, is a path inside the folder:
/// relative, without `..`, and not empty.
fn check_entry(dir: &Path, entry: &str) -> Result<(), InputError> {
    let p = Path::new(entry.trim_end_matches('/'));
    let inside = !entry.is_empty()
        && p.components().all(|c| matches!(c, Component::Normal(_)))
        && p.components().next().is_some();
    if inside {
        Ok(())
    } else {
        Err(InputError::new(format!(
            "{} lists {entry:?}, which is not a path inside the folder; the record is damaged: move the folder away or give another --out",
            dir.join(RECORD).display()
        )))
    }
}

/// The record of `dir`, or `None` when there is none (a folder smokelab
/// never wrote, or wrote before it kept records).
pub fn read_record(dir: &Path) -> Result<Option<BTreeSet<String>>, InputError> {
    let path = dir.join(RECORD);
    let meta = match std::fs::symlink_metadata(&path) {
        Ok(m) => m,
        Err(_) => return Ok(None),
    };
    if !meta.is_file() {
        return Err(InputError::new(format!(
            "{} is not a file (a symbolic link?); it cannot be the folder's record of smokelab's files",
            path.display()
        )));
    }
    let text = std::fs::read_to_string(&path)
        .map_err(|e| InputError::new(format!("cannot read {}: {e}", path.display())))?;
    // A last line without its newline was cut short by a kill: not an entry.
    let whole = text.rfind('\n').map_or("", |end| &text[..end]);
    let mut entries = BTreeSet::new();
    for line in whole.lines().filter(|l| !l.is_empty()) {
        check_entry(dir, line)?;
        entries.insert(line.to_string());
    }
    Ok(Some(entries))
}

/// Who holds the lock of `dir` now (its process id and command line), or
/// `None` when no one writes there.
pub fn holder(dir: &Path) -> Option<String> {
    let path = dir.join(LOCK);
    if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut file = File::open(&path).ok()?;
    match file.try_lock_shared() {
        Ok(()) => None,
        Err(_) => {
            let mut who = String::new();
            let _ = file.read_to_string(&mut who);
            Some(who.trim().to_string())
        }
    }
}

/// `Ok` when no other process writes in `dir` now, else an [`InputError`]
/// naming the holder.
pub fn check_free(dir: &Path) -> Result<(), InputError> {
    match holder(dir) {
        Some(who) => Err(held(dir, &who)),
        None => Ok(()),
    }
}

/// The error of a second writer: `dir` is held by `who`.
fn held(dir: &Path, who: &str) -> InputError {
    InputError::new(format!(
        "output folder {} is being written by another smokelab ({}); wait for it to finish, or give another --out",
        dir.display(),
        if who.is_empty() { "holder unknown" } else { who }
    ))
}

impl OutputFolder {
    /// Create `dir` (and its parents) if missing, lock it for this process
    /// (a folder another process holds is an [`InputError`] naming the
    /// holder) and record what is written under it from now on.
    pub fn open(dir: &Path) -> Result<Self> {
        create_dirs(dir)?;
        let lock_path = dir.join(LOCK);
        let mut lock = open_no_follow(&lock_path, false)
            .with_context(|| format!("cannot open {}", lock_path.display()))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut who = String::new();
                let _ = lock.read_to_string(&mut who);
                return Err(held(dir, who.trim()).into());
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("cannot lock {}", lock_path.display()))
            }
        }
        let command = std::env::args().collect::<Vec<_>>().join(" ");
        lock.set_len(0)
            .and_then(|()| writeln!(lock, "pid {}: {command}", std::process::id()))
            .with_context(|| format!("cannot write {}", lock_path.display()))?;
        let entries = read_record(dir)?.unwrap_or_default();
        let record_path = dir.join(RECORD);
        let record = open_no_follow(&record_path, true)
            .with_context(|| format!("cannot open {}", record_path.display()))?;
        let root = absolute(dir);
        active().push(Active {
            root: root.clone(),
            record,
            entries,
        });
        Ok(Self { root, _lock: lock })
    }

    /// The record's entries now.
    pub fn entries(&self) -> BTreeSet<String> {
        active()
            .iter()
            .find(|a| a.root == self.root)
            .map(|a| a.entries.clone())
            .unwrap_or_default()
    }

    /// Remove the recorded `files` (paths relative to the folder; a
    /// missing one is skipped, a folder left as it is), then the recorded
    /// folders left empty, and drop them from the record. Nothing else is
    /// removed.
    pub fn remove(&self, files: &[String]) -> Result<()> {
        let mut all = active();
        let Some(a) = all.iter_mut().find(|a| a.root == self.root) else {
            return Ok(());
        };
        for f in files {
            if !a.entries.contains(f) {
                continue;
            }
            let path = a.root.join(f);
            match std::fs::symlink_metadata(&path) {
                Ok(m) if m.is_dir() => continue,
                Ok(_) => std::fs::remove_file(&path)
                    .with_context(|| format!("cannot remove {} to overwrite it", path.display()))?,
                Err(_) => {}
            }
            a.entries.remove(f);
        }
        // Deepest first, so a folder's emptied subfolders go before it.
        let folders: Vec<String> = a
            .entries
            .iter()
            .filter(|e| e.ends_with('/'))
            .cloned()
            .collect();
        for d in folders.iter().rev() {
            let path = a.root.join(d);
            let gone = std::fs::remove_dir(&path).is_ok() || !path.exists();
            if gone {
                a.entries.remove(d);
            }
        }
        rewrite_record(a)
    }
}

impl Drop for OutputFolder {
    fn drop(&mut self) {
        let mut all = active();
        if let Some(i) = all.iter().position(|a| a.root == self.root) {
            // Sorted, so a committed record changes only where files did.
            let _ = rewrite_record(&mut all[i]);
            all.remove(i);
        }
    }
}

/// Replace the record of `a` by its entries, sorted, atomically, and keep
/// appending to the new file.
fn rewrite_record(a: &mut Active) -> Result<()> {
    let path = a.root.join(RECORD);
    let mut text = String::new();
    for e in &a.entries {
        text.push_str(e);
        text.push('\n');
    }
    let tmp = tempfile::Builder::new()
        .prefix(&format!("{RECORD}."))
        .suffix(super::TEMPORARY_SUFFIX)
        .tempfile_in(&a.root)
        .with_context(|| format!("cannot create a temporary file in {}", a.root.display()))?;
    tmp.as_file()
        .write_all(text.as_bytes())
        .and_then(|()| tmp.as_file().sync_data())
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.persist(&path)
        .map_err(|e| e.error)
        .with_context(|| format!("cannot rename the new {} into place", path.display()))?;
    a.record =
        open_no_follow(&path, true).with_context(|| format!("cannot open {}", path.display()))?;
    Ok(())
}

/// The open folder holding `path` (the innermost one) and `path` relative
/// to it, `/`-separated (a folder's with a final `/` when `dir`).
fn locate<'a>(
    all: &'a mut [Active],
    path: &Path,
    dir: bool,
) -> Result<Option<(&'a mut Active, String)>> {
    let abs = absolute(path);
    let Some(a) = all
        .iter_mut()
        .filter(|a| abs.starts_with(&a.root) && abs != a.root)
        .max_by_key(|a| a.root.components().count())
    else {
        return Ok(None);
    };
    let rel = abs.strip_prefix(&a.root).expect("under the root");
    let mut parts = Vec::new();
    for c in rel.components() {
        match c {
            Component::Normal(s) => match s.to_str() {
                Some(s) if !s.contains('\n') => parts.push(s),
                _ => anyhow::bail!(
                    "cannot write {}: smokelab records only names in UTF-8 without line breaks",
                    path.display()
                ),
            },
            _ => {
                return Err(InputError::new(format!(
                    "{} is not a plain path inside the output folder {}",
                    path.display(),
                    a.root.display()
                ))
                .into())
            }
        }
    }
    let mut rel = parts.join("/");
    if dir {
        rel.push('/');
    }
    Ok(Some((a, rel)))
}

/// Append `rel` to the record of `a` and sync it.
fn record(a: &mut Active, rel: String) -> Result<()> {
    let path = a.root.join(RECORD);
    writeln!(a.record, "{rel}")
        .and_then(|()| a.record.sync_data())
        .with_context(|| format!("cannot write {}", path.display()))?;
    a.entries.insert(rel);
    Ok(())
}

/// Claim `path` for a write: outside every open [`OutputFolder`] this does
/// nothing; inside one, the folders between it and the file must not be
/// symbolic links, and the file must be smokelab's (in the record) or not
/// exist yet — then it is recorded.
///
/// # Errors
/// An [`InputError`] naming `path` when it would replace a file smokelab
/// did not write or write through a symbolic link.
pub fn claim(path: &Path) -> Result<()> {
    let mut all = active();
    let Some((a, rel)) = locate(&mut all, path, false)? else {
        return Ok(());
    };
    // No folder on the way may lead elsewhere.
    let mut inside = a.root.clone();
    let parts: Vec<&str> = rel.split('/').collect();
    for part in &parts[..parts.len() - 1] {
        inside.push(part);
        if std::fs::symlink_metadata(&inside).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(InputError::new(format!(
                "{} is a symbolic link; smokelab does not write through it (to {})",
                inside.display(),
                path.display()
            ))
            .into());
        }
    }
    if a.entries.contains(&rel) {
        return Ok(());
    }
    if let Ok(m) = std::fs::symlink_metadata(path) {
        let what = if m.file_type().is_symlink() {
            "a symbolic link smokelab did not make"
        } else {
            "a file smokelab did not write"
        };
        return Err(InputError::new(format!(
            "refusing to replace {}: it is {what} (not in {}); move it away, or give another --out",
            path.display(),
            a.root.join(RECORD).display()
        ))
        .into());
    }
    record(a, rel)
}

/// Create the folder `dir` and its missing parents, recording those made
/// inside an open [`OutputFolder`].
pub fn create_dirs(dir: &Path) -> Result<()> {
    let mut missing = Vec::new();
    let mut d = dir;
    while !d.as_os_str().is_empty() && std::fs::symlink_metadata(d).is_err() {
        missing.push(d);
        match d.parent() {
            Some(p) => d = p,
            None => break,
        }
    }
    for d in missing.into_iter().rev() {
        {
            let mut all = active();
            if let Some((a, rel)) = locate(&mut all, d, true)? {
                if !a.entries.contains(&rel) {
                    record(a, rel)?;
                }
            }
        }
        match std::fs::create_dir(d) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && d.is_dir() => {}
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("cannot create output folder {}", d.display()))
            }
        }
    }
    if !dir.is_dir() {
        anyhow::bail!(
            "cannot create output folder {}: a file is in the way",
            dir.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_under_an_open_folder_are_recorded_and_foreign_files_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("out");
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("notes.png"), "mine").unwrap();
        let folder = OutputFolder::open(&d).unwrap();
        create_dirs(&d.join("a/b")).unwrap();
        claim(&d.join("a/b/x.npy")).unwrap();
        claim(&d.join("y.csv")).unwrap();
        let e = claim(&d.join("notes.png")).unwrap_err().to_string();
        assert!(
            e.contains("notes.png") && e.contains("did not write"),
            "{e}"
        );
        let want = ["a/", "a/b/", "a/b/x.npy", "y.csv"];
        assert_eq!(folder.entries().into_iter().collect::<Vec<_>>(), want);
        assert_eq!(
            read_record(&d)
                .unwrap()
                .unwrap()
                .into_iter()
                .collect::<Vec<_>>(),
            want
        );
        // A second writer is refused, naming this process.
        let who = holder(&d).unwrap();
        assert!(
            who.contains(&format!("pid {}", std::process::id())),
            "{who}"
        );
        drop(folder);
        assert_eq!(holder(&d), None);
    }

    #[test]
    fn remove_takes_only_recorded_files_and_the_folders_they_empty() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let folder = OutputFolder::open(d).unwrap();
        for f in ["a/x.npy", "b/y.npy"] {
            let p = d.join(f);
            create_dirs(p.parent().unwrap()).unwrap();
            claim(&p).unwrap();
            std::fs::write(&p, "x").unwrap();
        }
        std::fs::write(d.join("b/keep.txt"), "mine").unwrap();
        folder
            .remove(&["a/x.npy".to_string(), "b/y.npy".to_string()])
            .unwrap();
        assert!(!d.join("a").exists() && d.join("b/keep.txt").is_file());
        assert!(!d.join("b/y.npy").exists());
        assert_eq!(folder.entries().into_iter().collect::<Vec<_>>(), ["b/"]);
    }

    #[test]
    fn a_damaged_record_cannot_name_a_path_outside() {
        let dir = tempfile::tempdir().unwrap();
        for bad in ["../x\n", "/etc/passwd\n", "a/../../x\n"] {
            std::fs::write(dir.path().join(RECORD), bad).unwrap();
            let e = read_record(dir.path()).unwrap_err().to_string();
            assert!(e.contains("not a path inside"), "{e}");
        }
        // A line cut short by a kill is not an entry.
        std::fs::write(dir.path().join(RECORD), "a.npy\nb.np").unwrap();
        let r = read_record(dir.path()).unwrap().unwrap();
        assert_eq!(r.into_iter().collect::<Vec<_>>(), ["a.npy"]);
    }
}
