//! Reading the user's files safely: only regular files (a FIFO or a device
//! given as `--config` would block forever), and `.npy` headers checked
//! against the file's length before anything is allocated.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use ndarray::{Array, Array3, Array4, Dimension};
use ndarray_npy::ReadNpyExt;

use crate::error::InputError;

/// Open `path` for reading if it is a regular file (after symlinks); the
/// error names `what` it was meant to be.
pub fn open_regular(path: &Path, what: &str) -> Result<File, InputError> {
    let meta = std::fs::metadata(path)
        .map_err(|e| InputError::new(format!("cannot read {what} {}: {e}", path.display())))?;
    if !meta.is_file() {
        return Err(InputError::new(format!(
            "{what} {} is not a regular file; give a file",
            path.display()
        )));
    }
    File::open(path)
        .map_err(|e| InputError::new(format!("cannot read {what} {}: {e}", path.display())))
}

/// Read a regular text file whole.
pub fn read_text(path: &Path, what: &str) -> Result<String, InputError> {
    let mut text = String::new();
    open_regular(path, what)?
        .read_to_string(&mut text)
        .map_err(|e| InputError::new(format!("cannot read {what} {}: {e}", path.display())))?;
    Ok(text)
}

/// The shape an `.npy` header declares, checked to be little-endian f32 in C
/// order and to match the bytes that follow it in a file of `file_len`
/// bytes.
fn npy_shape(header: &[u8], file_len: u64) -> Result<Vec<usize>, String> {
    if header.len() < 10 || &header[..6] != b"\x93NUMPY" {
        return Err("not an .npy file (no \\x93NUMPY magic)".into());
    }
    let (len, start) = match header[6] {
        1 => (u16::from_le_bytes([header[8], header[9]]) as usize, 10),
        2 | 3 if header.len() >= 12 => (
            u32::from_le_bytes([header[8], header[9], header[10], header[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy version {v}")),
    };
    let dict = header
        .get(start..start + len)
        .ok_or("the header is longer than the file")?;
    let dict = std::str::from_utf8(dict).map_err(|_| "the header is not text")?;
    let field = |key: &str| {
        let at = dict.find(&format!("'{key}'"))? + key.len() + 2;
        Some(dict[at..].trim_start().trim_start_matches(':').trim_start())
    };
    let descr = field("descr").ok_or("the header has no 'descr'")?;
    if !(descr.starts_with("'<f4'") || descr.starts_with("'float32'")) {
        return Err(format!(
            "its dtype is {}, not f32 ('<f4')",
            descr.split(',').next().unwrap_or(descr)
        ));
    }
    if field("fortran_order").is_some_and(|v| v.starts_with("True")) {
        return Err("it is in Fortran order; write it in C order".into());
    }
    let shape = field("shape").ok_or("the header has no 'shape'")?;
    let shape = shape
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or("its 'shape' is not a tuple")?;
    let dims: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse()
                .map_err(|_| format!("shape entry '{s}' is not a count"))
        })
        .collect::<Result<_, _>>()?;
    let need = dims
        .iter()
        .try_fold(4u64, |a, &n| a.checked_mul(n as u64))
        .ok_or("its shape's size overflows")?;
    let have = file_len.saturating_sub((start + len) as u64);
    if need != have {
        return Err(format!(
            "its header declares shape {dims:?} ({need} bytes of data) but the file holds {have}"
        ));
    }
    Ok(dims)
}

/// Read an f32 `.npy` volume of shape `(nz, ny, nx)`, checking the file and
/// its header before allocating.
pub fn read_npy3(path: &Path) -> Result<Array3<f32>, InputError> {
    read_checked(path, "(nz, ny, nx)")
}

/// Read a cell-centred density `.npy` of shape `(nz, ny, nx)`, f32 or f64
/// (rounded to f32), the header checked as [`read_npy3`] does.
pub fn read_density_npy(path: &Path) -> Result<Array3<f32>, InputError> {
    let mut head = [0u8; 256];
    let n = open_regular(path, "volume")?.read(&mut head).unwrap_or(0);
    let text = String::from_utf8_lossy(&head[..n]);
    if !(text.contains("'<f8'") || text.contains("'float64'")) {
        return read_npy3(path);
    }
    let bad = |why: String| {
        InputError::new(format!(
            "volume {}: {why}; it must be an f32 or f64 .npy array of shape (nz, ny, nx)",
            path.display()
        ))
    };
    let file = open_regular(path, "volume")?;
    let data = Array3::<f64>::read_npy(BufReader::new(file)).map_err(|e| bad(e.to_string()))?;
    Ok(data.mapv(|v| v as f32))
}

/// Read an f32 `.npy` vector volume of shape `(nz, ny, nx, 3)` (as `smokelab
/// run` writes `vel_NNNN.npy`), checking the file and its header before
/// allocating.
pub fn read_npy4(path: &Path) -> Result<Array4<f32>, InputError> {
    read_checked(path, "(nz, ny, nx, 3)")
}

/// Read an f32 `.npy` array with as many axes as `shape` (e.g.
/// `"(nz, ny, nx)"`) names, after checking the file is regular and its
/// header matches its length.
fn read_checked<D: Dimension>(path: &Path, shape: &str) -> Result<Array<f32, D>, InputError> {
    let file = open_regular(path, "volume")?;
    let bad = |why: String| {
        InputError::new(format!(
            "volume {}: {why}; it must be an f32 .npy array of shape {shape}",
            path.display()
        ))
    };
    let file_len = file.metadata().map_err(|e| bad(e.to_string()))?.len();
    let mut reader = BufReader::new(file);
    let mut head = vec![0u8; 4096.min(file_len as usize)];
    reader
        .read_exact(&mut head)
        .map_err(|e| bad(e.to_string()))?;
    let dims = npy_shape(&head, file_len).map_err(bad)?;
    if Some(dims.len()) != D::NDIM {
        return Err(bad(format!("it has {} axes", dims.len())));
    }
    let file = open_regular(path, "volume")?;
    Array::<f32, D>::read_npy(BufReader::new(file)).map_err(|e| bad(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray_npy::WriteNpyExt;

    fn npy(shape: (usize, usize, usize)) -> Vec<u8> {
        let mut bytes = Vec::new();
        Array3::<f32>::zeros(shape).write_npy(&mut bytes).unwrap();
        bytes
    }

    #[test]
    fn a_header_that_claims_more_than_the_file_holds_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let good = npy((2, 3, 4));
        let path = dir.path().join("v.npy");
        std::fs::write(&path, &good).unwrap();
        assert_eq!(read_npy3(&path).unwrap().dim(), (2, 3, 4));
        // The same header with the data cut short: refused before reading.
        std::fs::write(&path, &good[..good.len() - 4]).unwrap();
        let e = read_npy3(&path).unwrap_err().to_string();
        assert!(
            e.contains("declares shape [2, 3, 4] (96 bytes of data) but the file holds 92"),
            "{e}"
        );
        // A header claiming 360 GB over a few bytes of data.
        let big = npy((200, 300, 400));
        let mut head = big[..128].to_vec();
        let at = head
            .windows(15)
            .position(|w| w == b"(200, 300, 400)")
            .unwrap();
        head[at..at + 15].copy_from_slice(b"(99999,99999,9)");
        std::fs::write(&path, &head).unwrap();
        let e = read_npy3(&path).unwrap_err().to_string();
        assert!(e.contains("declares shape [99999, 99999, 9]"), "{e}");
    }

    #[test]
    fn only_regular_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_text(dir.path(), "config").unwrap_err().to_string();
        assert!(e.contains("is not a regular file"), "{e}");
        assert!(read_text(&dir.path().join("missing.toml"), "config").is_err());
    }
}
