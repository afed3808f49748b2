//! Reading the user's files safely: only regular files (a FIFO or a device
//! given as `--config` would block forever), and `.npy` headers checked
//! against the file's length before anything is allocated.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use ndarray::{Array, Array3, Array4, Dimension};
use ndarray_npy::{ReadNpyExt, ReadableElement};

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

/// An element type an `.npy` input may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dtype {
    /// Little-endian f32, `'<f4'`.
    F32,
    /// Little-endian f64, `'<f8'`.
    F64,
}

impl Dtype {
    /// Its spellings in a header's `descr`.
    fn names(self) -> [&'static str; 2] {
        match self {
            Dtype::F32 => ["'<f4'", "'float32'"],
            Dtype::F64 => ["'<f8'", "'float64'"],
        }
    }

    /// Bytes per element.
    fn size(self) -> u64 {
        match self {
            Dtype::F32 => 4,
            Dtype::F64 => 8,
        }
    }
}

/// The element type and shape an `.npy` header declares, checked to be one
/// of `dtypes`, little-endian in C order, and to match the bytes that follow
/// it in a file of `file_len` bytes.
fn npy_shape(
    header: &[u8],
    file_len: u64,
    dtypes: &[Dtype],
) -> Result<(Dtype, Vec<usize>), String> {
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
    let Some(&dtype) = dtypes
        .iter()
        .find(|d| d.names().iter().any(|n| descr.starts_with(n)))
    else {
        let allowed: Vec<&str> = dtypes.iter().map(|d| d.names()[0]).collect();
        return Err(format!(
            "its dtype is {}, not {}",
            descr.split(',').next().unwrap_or(descr),
            allowed.join(" or ")
        ));
    };
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
        .try_fold(dtype.size(), |a, &n| a.checked_mul(n as u64))
        .ok_or("its shape's size overflows")?;
    let have = file_len.saturating_sub((start + len) as u64);
    if need != have {
        return Err(format!(
            "its header declares shape {dims:?} ({need} bytes of data) but the file holds {have}"
        ));
    }
    Ok((dtype, dims))
}

/// Read an f32 `.npy` volume of shape `(nz, ny, nx)`, checking the file and
/// its header before allocating.
pub fn read_npy3(path: &Path) -> Result<Array3<f32>, InputError> {
    read_checked(path, "an f32", "(nz, ny, nx)", &[Dtype::F32])
}

/// Read a cell-centred density `.npy` of shape `(nz, ny, nx)`, f32 or f64
/// (rounded to f32), the header checked as [`read_npy3`] does — against
/// the file's length at the header's element size — before allocating.
pub fn read_density_npy(path: &Path) -> Result<Array3<f32>, InputError> {
    const WHAT: &str = "an f32 or f64";
    const SHAPE: &str = "(nz, ny, nx)";
    let (dtype, _) = npy_header(path, WHAT, SHAPE, &[Dtype::F32, Dtype::F64], 3)?;
    match dtype {
        Dtype::F32 => read_checked(path, WHAT, SHAPE, &[Dtype::F32]),
        Dtype::F64 => {
            Ok(read_checked::<f64, _>(path, WHAT, SHAPE, &[Dtype::F64])?.mapv(|v| v as f32))
        }
    }
}

/// Read an f32 `.npy` vector volume of shape `(nz, ny, nx, 3)` (as `smokelab
/// run` writes `vel_NNNN.npy`), checking the file and its header before
/// allocating.
pub fn read_npy4(path: &Path) -> Result<Array4<f32>, InputError> {
    read_checked(path, "an f32", "(nz, ny, nx, 3)", &[Dtype::F32])
}

/// The refusal of the volume `path`: `why`, and that it must be `what`
/// (`"an f32"`) `.npy` array of `shape`.
fn bad_volume(path: &Path, what: &str, shape: &str, why: impl std::fmt::Display) -> InputError {
    InputError::new(format!(
        "volume {}: {why}; it must be {what} .npy array of shape {shape}",
        path.display()
    ))
}

/// The element type and shape of the `.npy` file `path`, after checking it
/// is a regular file whose header names one of `dtypes` and `axes` axes
/// and matches its length.
fn npy_header(
    path: &Path,
    what: &str,
    shape: &str,
    dtypes: &[Dtype],
    axes: usize,
) -> Result<(Dtype, Vec<usize>), InputError> {
    let bad = |why: String| bad_volume(path, what, shape, why);
    let file = open_regular(path, "volume")?;
    let file_len = file.metadata().map_err(|e| bad(e.to_string()))?.len();
    let mut reader = BufReader::new(file);
    let mut head = vec![0u8; 4096.min(file_len as usize)];
    reader
        .read_exact(&mut head)
        .map_err(|e| bad(e.to_string()))?;
    let (dtype, dims) = npy_shape(&head, file_len, dtypes).map_err(bad)?;
    if dims.len() != axes {
        return Err(bad(format!("it has {} axes", dims.len())));
    }
    Ok((dtype, dims))
}

/// Read an `.npy` array of element `T` (one of `dtypes`) with `D`'s axes
/// after checking its header ([`npy_header`]); `what` and `shape` (e.g.
/// `"an f32"`, `"(nz, ny, nx)"`) for the messages.
fn read_checked<T: ReadableElement, D: Dimension>(
    path: &Path,
    what: &str,
    shape: &str,
    dtypes: &[Dtype],
) -> Result<Array<T, D>, InputError> {
    let axes = D::NDIM.expect("a fixed number of axes");
    npy_header(path, what, shape, dtypes, axes)?;
    let file = open_regular(path, "volume")?;
    Array::<T, D>::read_npy(BufReader::new(file)).map_err(|e| bad_volume(path, what, shape, e))
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

    /// An f64 volume's header is checked at 8 bytes an element: a header
    /// claiming 40 GB over a few bytes is refused before allocating, a
    /// whole file is read (and rounded to f32), an f32 header is read as f32.
    #[test]
    fn an_f64_header_is_checked_against_the_file_before_allocating() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.npy");
        let mut good = Vec::new();
        Array3::<f64>::from_elem((2, 3, 4), 0.25)
            .write_npy(&mut good)
            .unwrap();
        std::fs::write(&path, &good).unwrap();
        let read = read_density_npy(&path).unwrap();
        assert_eq!(read.dim(), (2, 3, 4));
        assert!(read.iter().all(|&v| v == 0.25));
        std::fs::write(&path, &good[..good.len() - 8]).unwrap();
        let e = read_density_npy(&path).unwrap_err().to_string();
        assert!(
            e.contains("declares shape [2, 3, 4] (192 bytes of data) but the file holds 184"),
            "{e}"
        );
        // A header claiming 40 GB of f64 over 16 bytes of data.
        let mut dict =
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2000, 2000, 1250), }".to_string();
        while !(11 + dict.len()).is_multiple_of(64) {
            dict.push(' ');
        }
        dict.push('\n');
        let mut head = b"\x93NUMPY\x01\x00".to_vec();
        head.extend((dict.len() as u16).to_le_bytes());
        head.extend(dict.bytes());
        head.extend([0u8; 16]);
        std::fs::write(&path, &head).unwrap();
        let e = read_density_npy(&path).unwrap_err().to_string();
        assert!(
            e.contains("declares shape [2000, 2000, 1250] (40000000000 bytes of data)"),
            "{e}"
        );
        let e = read_npy3(&path).unwrap_err().to_string();
        assert!(e.contains("not '<f4'"), "{e}");
        std::fs::write(&path, npy((2, 3, 4))).unwrap();
        assert_eq!(read_density_npy(&path).unwrap().dim(), (2, 3, 4));
    }

    #[test]
    fn only_regular_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_text(dir.path(), "config").unwrap_err().to_string();
        assert!(e.contains("is not a regular file"), "{e}");
        assert!(read_text(&dir.path().join("missing.toml"), "config").is_err());
    }
}
