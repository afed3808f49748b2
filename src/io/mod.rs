//! Output: whole files only, and only smokelab's.
//!
//! Every writer here writes to a temporary file in the same folder, created
//! exclusively under an unpredictable name (`.<name>.XXXXXX.smokelab-tmp`,
//! [`tempfile`]), syncs it, renames it into place and syncs the folder, so
//! a killed run leaves finished files intact and never a half-written one
//! under a real name, and a write never follows a symbolic link planted at
//! the name (the rename replaces the link itself). A failed write or sync
//! is an error naming the file. A temporary file is removed when its write
//! fails, and [`remove_temporary_files`] (the application calls it on
//! Ctrl-C) removes those still being written. Inside an open output folder
//! ([`folder::OutputFolder`]) each file is claimed first ([`folder::claim`]):
//! recorded, or refused when it would replace a file smokelab did not write.

pub mod folder;
pub mod input;
pub mod manifest;
pub mod preview;
pub mod vdb;
pub mod vtk;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{bail, Context, Result};
use ndarray::{Array3, Array4};
use ndarray_npy::WriteNpyExt;

/// How the temporary files of [`write_atomic`] end: `.<name>.XXXXXX` then
/// this ([`is_temporary_file`]).
pub const TEMPORARY_SUFFIX: &str = ".smokelab-tmp";

/// Whether `name` is a temporary file of [`write_atomic`] (one a killed
/// process left behind).
pub fn is_temporary_file(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(TEMPORARY_SUFFIX)
}

/// The temporary files being written now; `None` once
/// [`remove_temporary_files`] has run, after which no write may start.
static TEMPORARY_FILES: Mutex<Option<Vec<PathBuf>>> = Mutex::new(Some(Vec::new()));

/// A temporary file being written: listed in [`TEMPORARY_FILES`] while it
/// exists, removed on drop unless renamed into place.
struct TemporaryFile {
    path: Option<tempfile::TempPath>,
    listed: PathBuf,
}

impl TemporaryFile {
    /// Create `.<name>.XXXXXX.smokelab-tmp` beside `path`, exclusively, and list it.
    fn create(path: &Path) -> Result<(Self, File)> {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map_or("output".into(), |n| n.to_string_lossy());
        let mut live = TEMPORARY_FILES.lock().unwrap_or_else(|e| e.into_inner());
        let Some(live) = live.as_mut() else {
            bail!("interrupted: not writing {}", path.display());
        };
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(TEMPORARY_SUFFIX)
            .tempfile_in(dir)
            .with_context(|| format!("cannot create a temporary file for {}", path.display()))?;
        let (file, tmp) = tmp.into_parts();
        live.push(tmp.to_path_buf());
        Ok((
            Self {
                listed: tmp.to_path_buf(),
                path: Some(tmp),
            },
            file,
        ))
    }

    /// Rename the finished file to `path`.
    fn rename_to(mut self, path: &Path) -> Result<()> {
        let tmp = self.path.take().expect("renamed once");
        tmp.persist(path).map_err(|e| {
            let shown = e.path.display().to_string();
            // Dropping the returned path removes the temporary file.
            anyhow::Error::new(e.error).context(format!("cannot rename {shown} into place"))
        })?;
        Ok(())
    }
}

impl Drop for TemporaryFile {
    fn drop(&mut self) {
        // Dropping an unrenamed `TempPath` removes its file.
        self.path.take();
        if let Some(live) = TEMPORARY_FILES
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_mut()
        {
            live.retain(|p| p != &self.listed);
        }
    }
}

/// Remove every temporary file still being written and refuse new writes
/// from then on; returns how many were removed. For an interrupt handler:
/// afterwards only whole files remain, and the process should exit.
pub fn remove_temporary_files() -> usize {
    let live = TEMPORARY_FILES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()
        .unwrap_or_default();
    live.iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// Whether [`remove_temporary_files`] has run: writes fail from then on,
/// and a failure may be its doing rather than an error of its own.
pub fn interrupted() -> bool {
    TEMPORARY_FILES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .is_none()
}

/// Name `path` in an I/O error (a full disk reads "No space left on device"
/// with the file); other errors (an [`crate::error::InputError`] a writer
/// raised) pass unchanged.
fn naming(e: anyhow::Error, path: &Path) -> anyhow::Error {
    if e.downcast_ref::<std::io::Error>().is_some() {
        e.context(format!("cannot write {}", path.display()))
    } else {
        e
    }
}

/// Sync the folder holding `path`, so a rename into it survives a crash.
pub fn sync_parent(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    File::open(dir)
        .and_then(|d| d.sync_all())
        .with_context(|| format!("cannot sync the folder {} to disk", dir.display()))
}

/// Write a file through a temporary name and an atomic rename; the
/// temporary file is removed if anything fails. The data and then the
/// folder are synced; a failure of either is an error naming the file.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    folder::claim(path)?;
    let (tmp, file) = TemporaryFile::create(path)?;
    let mut w = BufWriter::new(file);
    write(&mut w).map_err(|e| naming(e, path))?;
    w.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    w.into_inner()
        .map_err(|e| e.into_error())
        .and_then(|f| f.sync_data())
        .with_context(|| format!("cannot sync {} to disk", path.display()))?;
    tmp.rename_to(path)?;
    sync_parent(path)
}

/// Write a scalar volume as `.npy` (f32, shape `(nz, ny, nx)`).
pub fn write_npy3(path: &Path, data: &Array3<f32>) -> Result<()> {
    write_atomic(path, |w| Ok(data.write_npy(w)?))
}

/// Write a vector volume as `.npy` (f32, shape `(nz, ny, nx, 3)`).
pub fn write_npy4(path: &Path, data: &Array4<f32>) -> Result<()> {
    write_atomic(path, |w| Ok(data.write_npy(w)?))
}

/// Write a value as pretty JSON.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    write_atomic(path, |w| {
        serde_json::to_writer_pretty(&mut *w, value)?;
        writeln!(w)?;
        Ok(())
    })
}

/// Write an 8-bit RGB image as PNG, compressed as far as the encoder goes
/// (adaptive filters, best deflate): figures with noise rows stay small.
pub fn write_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    write_atomic(path, |w| {
        let png = PngEncoder::new_with_quality(w, CompressionType::Best, FilterType::Adaptive);
        img.write_with_encoder(png)?;
        Ok(())
    })
}

/// Check that `dir` can be used as an output folder: it is a folder or does
/// not exist yet, and its nearest existing ancestor is a writable folder
/// (not a file such as `/dev/null`).
///
/// The folder itself is created by [`create_output_dir`] only once all input
/// has been validated, so bad input leaves nothing behind.
pub fn check_output_dir(dir: &Path) -> Result<(), crate::error::InputError> {
    let bad = |why: &str| {
        Err(crate::error::InputError::new(format!(
            "output path {} {why}; give a folder",
            dir.display()
        )))
    };
    if is_system_folder(dir) {
        return bad("is a system folder (or the home folder itself), where a command's files would mix with everything else");
    }
    let mut existing = dir;
    while !existing.as_os_str().is_empty() && std::fs::symlink_metadata(existing).is_err() {
        match existing.parent() {
            Some(p) => existing = p,
            None => break,
        }
    }
    if existing.as_os_str().is_empty() {
        existing = Path::new(".");
    }
    match std::fs::metadata(existing) {
        Ok(m) if m.is_dir() => {
            if m.permissions().readonly() {
                return bad(&format!(
                    "is inside {}, which is read-only",
                    existing.display()
                ));
            }
            Ok(())
        }
        Ok(_) if existing == dir => bad("is a file"),
        Ok(_) => bad(&format!(
            "is inside {}, which is not a folder",
            existing.display()
        )),
        Err(e) => bad(&format!("cannot be checked: {e}")),
    }
}

/// Create the output folder (and parents; those inside an open output
/// folder are recorded as smokelab's, [`folder::create_dirs`]).
pub fn create_output_dir(dir: &Path) -> Result<()> {
    folder::create_dirs(dir)
}

/// The folders no command may write into directly: the file system's root,
/// the system's top folders and the home folder itself (a run's files
/// scattered there could not be told from the user's).
fn is_system_folder(dir: &Path) -> bool {
    const SYSTEM: [&str; 22] = [
        "/",
        "/bin",
        "/boot",
        "/dev",
        "/etc",
        "/home",
        "/lib",
        "/lib64",
        "/media",
        "/mnt",
        "/opt",
        "/proc",
        "/root",
        "/run",
        "/sbin",
        "/srv",
        "/sys",
        "/tmp",
        "/usr",
        "/var",
        "/usr/local",
        "/var/tmp",
    ];
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let same = |a: &Path, b: &Path| {
        a == b
            || a.canonicalize()
                .ok()
                .zip(b.canonicalize().ok())
                .is_some_and(|(x, y)| x == y)
    };
    let abs = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    let abs: PathBuf = abs
        .components()
        .filter(|c| *c != std::path::Component::CurDir)
        .collect();
    SYSTEM.iter().any(|s| same(&abs, Path::new(s))) || home.is_some_and(|h| same(&abs, &h))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        n.sort();
        n
    }

    #[test]
    fn temporary_files_are_unpredictable_and_removed_when_the_write_fails() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        let mut seen = Vec::new();
        let e = write_atomic(&path, |_| {
            seen.push(names(dir.path()));
            bail!("the writer failed")
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "the writer failed");
        write_atomic(&path, |w| {
            seen.push(names(dir.path()));
            Ok(w.write_all(b"{}")?)
        })
        .unwrap();
        // Each write had its own temporary name, hidden and random.
        assert_eq!(seen.len(), 2);
        for s in &seen {
            assert!(
                s[0].starts_with(".a.json.") && is_temporary_file(&s[0]),
                "{seen:?}"
            );
        }
        assert_ne!(seen[0], seen[1]);
        // The failed write left nothing; the good one only its file.
        assert_eq!(names(dir.path()), ["a.json"]);
        assert_eq!(std::fs::read(&path).unwrap(), b"{}");
    }

    #[test]
    fn a_symbolic_link_at_the_name_is_replaced_not_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let outside = dir.path().join("outside.csv");
        std::fs::write(&outside, "precious").unwrap();
        let path = dir.path().join("metrics.csv");
        std::os::unix::fs::symlink(&outside, &path).unwrap();
        write_atomic(&path, |w| Ok(w.write_all(b"rows")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&outside).unwrap(), "precious");
        assert!(!std::fs::symlink_metadata(&path).unwrap().is_symlink());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "rows");
    }

    #[test]
    fn a_full_disk_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("frame.npy");
        let e = write_atomic(&path, |_| {
            Err(std::io::Error::from_raw_os_error(libc::ENOSPC).into())
        })
        .unwrap_err();
        let e = format!("{e:#}");
        assert!(
            e.contains("frame.npy") && e.to_lowercase().contains("no space left on device"),
            "{e}"
        );
        assert!(!path.exists());
    }

    #[test]
    fn system_folders_are_refused_as_output_folders() {
        for d in ["/", "/usr", "/etc", "/tmp/.", "/usr/../usr"] {
            let e = check_output_dir(Path::new(d)).unwrap_err().to_string();
            assert!(e.contains("system folder"), "{d}: {e}");
        }
        let dir = tempfile::tempdir().unwrap();
        check_output_dir(&dir.path().join("run")).unwrap();
    }
}
