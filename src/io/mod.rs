//! Output: whole files only.
//!
//! Every writer here writes to a temporary file in the same folder,
//! `<name>.<pid>-<n>.tmp` (unique to the process and the write), and renames
//! it into place, so a killed run leaves finished files intact and never a
//! half-written one under a real name. A temporary file is removed when its
//! write fails, and [`remove_temporary_files`] (the application calls it on
//! Ctrl-C) removes those still being written.

pub mod input;
pub mod manifest;
pub mod preview;
pub mod vdb;
pub mod vtk;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use anyhow::{bail, Context, Result};
use ndarray::{Array3, Array4};
use ndarray_npy::WriteNpyExt;

/// The temporary files being written now; `None` once
/// [`remove_temporary_files`] has run, after which no write may start.
static TEMPORARY_FILES: Mutex<Option<Vec<PathBuf>>> = Mutex::new(Some(Vec::new()));

/// Numbers the temporary files of this process.
static NEXT_TEMPORARY: AtomicU64 = AtomicU64::new(0);

/// A temporary file being written: listed in [`TEMPORARY_FILES`] while it
/// exists, removed on drop unless renamed into place.
struct TemporaryFile {
    path: PathBuf,
    renamed: bool,
}

impl TemporaryFile {
    /// Create `<path>.<pid>-<n>.tmp` and list it.
    fn create(path: &Path) -> Result<(Self, File)> {
        let mut name = path.as_os_str().to_owned();
        let n = NEXT_TEMPORARY.fetch_add(1, Ordering::Relaxed);
        name.push(format!(".{}-{n}.tmp", std::process::id()));
        let tmp = PathBuf::from(name);
        let mut live = TEMPORARY_FILES.lock().unwrap_or_else(|e| e.into_inner());
        let Some(live) = live.as_mut() else {
            bail!("interrupted: not writing {}", path.display());
        };
        let file =
            File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        live.push(tmp.clone());
        Ok((
            Self {
                path: tmp,
                renamed: false,
            },
            file,
        ))
    }

    /// Rename the finished file to `path`.
    fn rename_to(mut self, path: &Path) -> Result<()> {
        std::fs::rename(&self.path, path)
            .with_context(|| format!("cannot rename {} into place", self.path.display()))?;
        self.renamed = true;
        Ok(())
    }
}

impl Drop for TemporaryFile {
    fn drop(&mut self) {
        if !self.renamed {
            let _ = std::fs::remove_file(&self.path);
        }
        if let Some(live) = TEMPORARY_FILES
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_mut()
        {
            live.retain(|p| p != &self.path);
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

/// Write a file through a temporary name and an atomic rename; the
/// temporary file is removed if anything fails.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let (tmp, file) = TemporaryFile::create(path)?;
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    w.flush()?;
    w.into_inner().map_err(|e| e.into_error())?.sync_data().ok();
    tmp.rename_to(path)
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

/// Create the output folder (and parents).
pub fn create_output_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))
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
    fn temporary_files_are_unique_and_removed_when_the_write_fails() {
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
        // Each write had its own temporary name, with this process's id.
        let pid = std::process::id();
        assert_eq!(seen.len(), 2);
        assert!(
            seen[0][0].starts_with(&format!("a.json.{pid}-")),
            "{seen:?}"
        );
        assert!(
            seen[0][0].ends_with(".tmp") && seen[0] != seen[1],
            "{seen:?}"
        );
        // The failed write left nothing; the good one only its file.
        assert_eq!(names(dir.path()), ["a.json"]);
        assert_eq!(std::fs::read(&path).unwrap(), b"{}");
    }
}
