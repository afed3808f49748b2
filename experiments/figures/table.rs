//! CSV tables, written and read with the `csv` crate and serde.
//!
//! Writers take `#[derive(Serialize)]` rows, so a column's name and its value
//! come from one struct field and cannot drift apart; floats print shortest
//! round-trip (an `f32` as `0.05`, not `0.05000000074505806`), `NaN` as `NaN`.
//! [`Log`] appends and flushes one row at a time, so a killed run keeps every
//! finished row (only the row being written at the kill can be cut short).
//! Readers name the file, the row and the column of a bad cell.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context, Result};
use serde::de::DeserializeOwned;
use serde::Serialize;
use smokelab::io;

/// The column names of a flat `#[derive(Serialize)]` row type, in field
/// order (from `sample`; its values do not matter).
pub fn field_names<T: Serialize>(sample: &T) -> Vec<String> {
    let mut w = csv::Writer::from_writer(vec![]);
    w.serialize(sample).expect("a flat row serializes");
    let bytes = w.into_inner().expect("writing to memory");
    let mut r = csv::Reader::from_reader(bytes.as_slice());
    let header = r.headers().expect("a header was written");
    header.iter().map(String::from).collect()
}

/// Write `rows` (flat `#[derive(Serialize)]` structs) with a header line,
/// atomically.
pub fn write_rows<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    io::write_atomic(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        for row in rows {
            csv.serialize(row)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// Write a numeric table: the header `columns` and `rows` of values,
/// atomically.
pub fn write_columns(path: &Path, columns: &[String], rows: &[Vec<f64>]) -> Result<()> {
    io::write_atomic(path, |w| {
        let mut csv = csv::WriterBuilder::new().has_headers(false).from_writer(w);
        csv.write_record(columns)?;
        for row in rows {
            csv.serialize(row)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// Read every row of a CSV written by [`write_rows`] into `T`.
pub fn read_rows<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>> {
    let mut r =
        csv::Reader::from_path(path).with_context(|| format!("cannot read {}", path.display()))?;
    r.deserialize()
        .map(|row| row.map_err(|e| anyhow!("{}: {e}", path.display())))
        .collect()
}

/// Open the log at `path` to append, never through a symbolic link.
fn open_append(path: &Path) -> Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.append(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt as _;
        o.custom_flags(libc::O_NOFOLLOW);
    }
    o.open(path)
        .with_context(|| format!("cannot append to {}", path.display()))
}

/// A CSV file appended one row at a time, each flushed to the system;
/// [`Log::sync`] takes the rows to disk.
pub struct Log {
    path: PathBuf,
    csv: csv::Writer<BufWriter<File>>,
}

impl Log {
    /// Create `path` (replacing it, atomically) with the header `columns`.
    pub fn create(path: PathBuf, columns: &[String]) -> Result<Self> {
        io::write_atomic(&path, |w| {
            let mut csv = csv::WriterBuilder::new().has_headers(false).from_writer(w);
            csv.write_record(columns)?;
            csv.flush()?;
            Ok(())
        })?;
        Self::append(path)
    }

    /// Open `path`, a log [`Self::create`] wrote, to append rows after its
    /// last (a file smokelab did not write, or a symbolic link, is refused).
    pub fn append(path: PathBuf) -> Result<Self> {
        io::folder::claim(&path)?;
        let file = open_append(&path)?;
        let csv = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(BufWriter::new(file));
        Ok(Self { path, csv })
    }

    /// Append one row: a `#[derive(Serialize)]` value whose fields (nested
    /// structs and sequences flattened in order) match the header.
    pub fn push(&mut self, row: &impl Serialize) -> Result<()> {
        self.csv
            .serialize(row)
            .with_context(|| format!("cannot write a row of {}", self.path.display()))?;
        self.flush()
    }

    fn flush(&mut self) -> Result<()> {
        self.csv
            .flush()
            .with_context(|| format!("cannot write {}", self.path.display()))
    }

    /// Flush and sync the rows so far to disk (before a checkpoint, whose
    /// resume needs them).
    pub fn sync(&mut self) -> Result<()> {
        self.flush()?;
        self.csv
            .get_ref()
            .get_ref()
            .sync_data()
            .with_context(|| format!("cannot sync {} to disk", self.path.display()))
    }
}

/// A numeric CSV such as `metrics.csv`: its column names and rows. `NaN`
/// (measures computed every K steps leave it between) and empty cells read
/// as NaN; anything else that is not a number is an error naming its place.
pub struct Columns {
    /// Column names.
    pub header: Vec<String>,
    /// Rows of values, in file order.
    pub rows: Vec<Vec<f64>>,
}

impl Columns {
    /// Read `path`.
    pub fn read(path: &Path) -> Result<Self> {
        let mut r = csv::Reader::from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let header: Vec<String> = r.headers()?.iter().map(String::from).collect();
        let mut rows = Vec::new();
        for (n, record) in r.records().enumerate() {
            let record = record.map_err(|e| anyhow!("{}: {e}", path.display()))?;
            let row = record
                .iter()
                .zip(&header)
                .map(|(cell, name)| match cell.trim() {
                    "" | "NaN" | "nan" => Ok(f64::NAN),
                    v => v.parse().map_err(|_| {
                        anyhow!(
                            "{}: row {}, column '{name}': '{v}' is not a number",
                            path.display(),
                            n + 1
                        )
                    }),
                })
                .collect::<Result<Vec<f64>>>()?;
            rows.push(row);
        }
        if rows.is_empty() {
            bail!("{} has no rows", path.display());
        }
        Ok(Self { header, rows })
    }

    /// The index of column `name`.
    pub fn index(&self, name: &str) -> Result<usize> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| anyhow!("no column {name} (columns: {})", self.header.join(", ")))
    }

    /// Every value of column `name`.
    pub fn column(&self, name: &str) -> Result<Vec<f64>> {
        let i = self.index(name)?;
        Ok(self.rows.iter().map(|r| r[i]).collect())
    }

    /// `(time, f(row))` for every row.
    pub fn series(&self, f: impl Fn(&[f64]) -> f64) -> Result<Vec<(f64, f64)>> {
        let t = self.index("time")?;
        Ok(self.rows.iter().map(|r| (r[t], f(r))).collect())
    }

    /// The largest value of column `name` (NaN cells skipped; 0 if none).
    pub fn max(&self, name: &str) -> Result<f64> {
        Ok(self.column(name)?.into_iter().fold(0.0, f64::max))
    }

    /// The mean of column `name`.
    pub fn mean(&self, name: &str) -> Result<f64> {
        let c = self.column(name)?;
        Ok(c.iter().sum::<f64>() / c.len().max(1) as f64)
    }

    /// The last value of column `name`.
    pub fn last(&self, name: &str) -> Result<f64> {
        Ok(*self.column(name)?.last().unwrap_or(&f64::NAN))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Row {
        name: String,
        dt: f32,
        mass: f64,
    }

    #[test]
    fn rows_round_trip_bit_exactly_with_shortest_floats() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        let rows = vec![
            Row {
                name: "a".into(),
                dt: 0.05,
                mass: 1.0 / 3.0,
            },
            Row {
                name: "b".into(),
                dt: f32::MIN_POSITIVE,
                mass: -2.5e-300,
            },
        ];
        write_rows(&path, &rows).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("name,dt,mass\na,0.05,0.3333333333333333\n"),
            "{text}"
        );
        assert_eq!(read_rows::<Row>(&path).unwrap(), rows);
        assert_eq!(field_names(&rows[0]), ["name", "dt", "mass"]);
    }

    #[test]
    fn a_log_appends_whole_rows_and_nan_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        let mut log = Log::create(path.clone(), &["time".into(), "x".into()]).unwrap();
        log.push(&(0.1f32, f32::NAN)).unwrap();
        // Flushed: readable while the log is still open.
        let t = Columns::read(&path).unwrap();
        assert_eq!(t.header, ["time", "x"]);
        // Shortest round-trip: the f32 0.1 is written as "0.1", which reads
        // back as that same f32.
        assert_eq!(t.column("time").unwrap(), [0.1]);
        assert_eq!(t.column("time").unwrap()[0] as f32, 0.1f32);
        assert!(t.last("x").unwrap().is_nan());
        log.push(&(0.2f32, 3.0f32)).unwrap();
        assert_eq!(Columns::read(&path).unwrap().rows.len(), 2);
    }

    /// The ad-hoc readers this replaces turned a bad cell into NaN silently.
    #[test]
    fn a_garbage_cell_is_an_error_naming_row_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.csv");
        std::fs::write(&path, "time,mass\n0.1,2\n0.2,zwei\n").unwrap();
        let e = Columns::read(&path).err().unwrap().to_string();
        assert!(
            e.contains("row 2, column 'mass': 'zwei' is not a number"),
            "{e}"
        );
    }
}
