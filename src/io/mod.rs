//! Output: whole files only.
//!
//! Every writer here writes to `<name>.tmp` in the same folder and renames it
//! into place, so a killed run leaves finished files intact and never a
//! half-written one.

pub mod manifest;
pub mod preview;
pub mod vdb;
pub mod vtk;

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use ndarray::{Array3, Array4};
use ndarray_npy::WriteNpyExt;

/// Write a file through a temporary name and an atomic rename.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<()>,
) -> Result<()> {
    let tmp: PathBuf = {
        let mut s = path.as_os_str().to_owned();
        s.push(".tmp");
        s.into()
    };
    let file = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
    let mut w = BufWriter::new(file);
    write(&mut w)?;
    w.flush()?;
    w.into_inner().map_err(|e| e.into_error())?.sync_data().ok();
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot rename {} into place", tmp.display()))?;
    Ok(())
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

/// Write an 8-bit RGB image as PNG.
pub fn write_png(path: &Path, img: &image::RgbImage) -> Result<()> {
    write_atomic(path, |w| {
        img.write_to(w, image::ImageFormat::Png)?;
        Ok(())
    })
}

/// A CSV table kept in memory and rewritten whole on every [`CsvLog::flush`].
#[derive(Clone, Debug)]
pub struct CsvLog {
    path: PathBuf,
    text: String,
}

impl CsvLog {
    /// A table with the given column names.
    pub fn new(path: PathBuf, columns: &[&str]) -> Self {
        Self {
            path,
            text: columns.join(",") + "\n",
        }
    }

    /// Append one row of numbers.
    pub fn push(&mut self, row: &[f64]) {
        let cells: Vec<String> = row.iter().map(|v| format!("{v}")).collect();
        self.text.push_str(&cells.join(","));
        self.text.push('\n');
    }

    /// Rewrite the file with every row so far.
    pub fn flush(&self) -> Result<()> {
        write_atomic(&self.path, |w| Ok(w.write_all(self.text.as_bytes())?))
    }
}

/// Check that `dir` can be used as an output folder (it must not be a file).
///
/// The folder itself is created by [`create_output_dir`] only once all input
/// has been validated, so bad input leaves nothing behind.
pub fn check_output_dir(dir: &Path) -> Result<(), crate::error::InputError> {
    if dir.is_file() {
        return Err(crate::error::InputError::new(format!(
            "output path {} is a file; give a folder",
            dir.display()
        )));
    }
    Ok(())
}

/// Create the output folder (and parents).
pub fn create_output_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))
}
