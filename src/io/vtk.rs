//! ParaView output: VTK XML ImageData (`.vti`) frames and a `.pvd` collection
//! that lists them by time.
//!
//! A `.vti` file holds one frame on the box's cells:
//!
//! - `WholeExtent="0 nx 0 ny 0 nz"` counts *points*, so the image has
//!   `nx × ny × nz` cells; `Origin` is the box's lower corner and `Spacing`
//!   is Δx on every axis, so cell `(i, j, k)` spans
//!   `origin + [i, i+1] × [j, j+1] × [k, k+1] Δx` and its centre is where
//!   [`crate::domain`] puts it;
//! - each scalar volume is a `Float32` array of `CellData`, each vector
//!   volume a `Float32` array with `NumberOfComponents="3"`; the first of
//!   each kind is marked as the active `Scalars`/`Vectors`. VTK orders cells
//!   with x fastest, then y, then z, which is the `[z][y][x]` order of the
//!   arrays;
//! - binary: the arrays follow the XML in one `<AppendedData
//!   encoding="raw">` block (after its `_` marker), each as a little-endian
//!   `UInt64` byte count (`header_type="UInt64"`) and the raw little-endian
//!   `f32` values; each `DataArray`'s `offset` counts bytes from the byte
//!   after `_`. Raw rather than base64: a third smaller and written as it is;
//!   uncompressed, so any VTK ≥ 6 reads it without zlib.
//!
//! A `.pvd` file (ParaView's "collection") lists `(time, file)` entries; open
//! it in ParaView to get the frames as one time series. [`PvdCollection`]
//! rewrites it whole, atomically, every time a frame is added, so a run that
//! stops leaves a valid collection of the frames written so far.
//!
//! All files go through [`super::write_atomic`].

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use ndarray::{ArrayView3, ArrayView4};

pub use super::vdb::VolumeGeometry;

/// Write one frame as VTK XML ImageData with the volumes as cell data,
/// atomically.
///
/// `scalars` have shape `(nz, ny, nx)`, `vectors` `(nz, ny, nx, 3)`; array
/// names must be non-empty and distinct. See the module documentation.
pub fn write_vti(
    path: &Path,
    geometry: &VolumeGeometry,
    scalars: &[(&str, ArrayView3<f32>)],
    vectors: &[(&str, ArrayView4<f32>)],
) -> Result<()> {
    super::vdb::check_inputs(geometry, scalars, vectors)?;
    super::write_atomic(path, |w| write_vti_to(w, geometry, scalars, vectors))
}

/// [`write_vti`] into any writer (no atomic rename).
pub fn write_vti_to(
    w: &mut impl Write,
    geometry: &VolumeGeometry,
    scalars: &[(&str, ArrayView3<f32>)],
    vectors: &[(&str, ArrayView4<f32>)],
) -> Result<()> {
    super::vdb::check_inputs(geometry, scalars, vectors)?;
    let [nx, ny, nz] = geometry.dims;
    let o = geometry.origin;
    let dx = geometry.cell;
    let extent = format!("0 {nx} 0 {ny} 0 {nz}");

    let mut active = String::new();
    if let Some((name, _)) = scalars.first() {
        active += &format!(" Scalars=\"{}\"", xml_escape(name));
    }
    if let Some((name, _)) = vectors.first() {
        active += &format!(" Vectors=\"{}\"", xml_escape(name));
    }

    let mut xml = String::new();
    xml += "<?xml version=\"1.0\"?>\n";
    xml += "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
    xml += &format!(
        "  <ImageData WholeExtent=\"{extent}\" Origin=\"{} {} {}\" Spacing=\"{dx} {dx} {dx}\">\n",
        o.x, o.y, o.z
    );
    xml += &format!("    <Piece Extent=\"{extent}\">\n");
    xml += "      <PointData>\n      </PointData>\n";
    xml += &format!("      <CellData{active}>\n");
    let cells = (nx * ny * nz) as u64;
    let mut offset = 0u64;
    let arrays = scalars
        .iter()
        .map(|(n, _)| (*n, 1u64))
        .chain(vectors.iter().map(|(n, _)| (*n, 3u64)));
    for (name, components) in arrays {
        let comp = if components == 1 {
            String::new()
        } else {
            format!(" NumberOfComponents=\"{components}\"")
        };
        xml += &format!(
            "        <DataArray type=\"Float32\" Name=\"{}\"{comp} format=\"appended\" offset=\"{offset}\"/>\n",
            xml_escape(name)
        );
        offset += 8 + 4 * components * cells;
    }
    xml += "      </CellData>\n    </Piece>\n  </ImageData>\n";
    xml += "  <AppendedData encoding=\"raw\">\n   _";
    w.write_all(xml.as_bytes())?;

    let mut put = |values: &mut dyn Iterator<Item = &f32>, count: u64| -> Result<()> {
        w.write_all(&(4 * count).to_le_bytes())?;
        let mut buf = Vec::with_capacity(1 << 16);
        for v in values {
            buf.extend_from_slice(&v.to_le_bytes());
            if buf.len() >= 1 << 16 {
                w.write_all(&buf)?;
                buf.clear();
            }
        }
        w.write_all(&buf)?;
        Ok(())
    };
    // `iter()` walks in logical (row-major) order whatever the memory layout.
    for (_, a) in scalars {
        put(&mut a.iter(), cells)?;
    }
    for (_, a) in vectors {
        put(&mut a.iter(), 3 * cells)?;
    }
    w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
    Ok(())
}

/// A ParaView `.pvd` collection: `(time, file)` entries, rewritten whole and
/// atomically on every change.
///
/// File names are stored as given, relative to the `.pvd` file's folder
/// (use [`PvdCollection::write_frame`] to write a frame beside it and list
/// it in one call). Adding a file that is already listed replaces its entry,
/// so a re-run frame is not listed twice.
#[derive(Clone, Debug)]
pub struct PvdCollection {
    path: PathBuf,
    entries: Vec<(f64, String)>,
}

impl PvdCollection {
    /// An empty collection to be written at `path` (e.g. `out/run.pvd`).
    /// Nothing is written until the first entry is added.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            entries: Vec::new(),
        }
    }

    /// Where the collection is written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The `(time, file)` entries, in the order added.
    pub fn entries(&self) -> &[(f64, String)] {
        &self.entries
    }

    /// List `file` (relative to the `.pvd` file's folder) at `time` and
    /// rewrite the collection.
    pub fn push(&mut self, time: f64, file: &str) -> Result<()> {
        ensure!(time.is_finite(), "frame time is {time}; it must be finite");
        ensure!(!file.is_empty(), "frame file name is empty");
        match self.entries.iter_mut().find(|(_, f)| f == file) {
            Some(entry) => entry.0 = time,
            None => self.entries.push((time, file.to_owned())),
        }
        self.flush()
    }

    /// Write a frame as `.vti` named `file` beside the `.pvd` file, then
    /// list it at `time` (the collection is rewritten after the frame is
    /// complete, so it never lists a missing file).
    pub fn write_frame(
        &mut self,
        time: f64,
        file: &str,
        geometry: &VolumeGeometry,
        scalars: &[(&str, ArrayView3<f32>)],
        vectors: &[(&str, ArrayView4<f32>)],
    ) -> Result<()> {
        ensure!(time.is_finite(), "frame time is {time}; it must be finite");
        let dir = self.path.parent().unwrap_or(Path::new(""));
        write_vti(&dir.join(file), geometry, scalars, vectors)
            .with_context(|| format!("writing frame {file}"))?;
        self.push(time, file)
    }

    /// The collection as XML.
    pub fn to_xml(&self) -> String {
        let mut xml = String::new();
        xml += "<?xml version=\"1.0\"?>\n";
        xml += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
        xml += "  <Collection>\n";
        for (time, file) in &self.entries {
            xml += &format!(
                "    <DataSet timestep=\"{time}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
                xml_escape(file)
            );
        }
        xml += "  </Collection>\n</VTKFile>\n";
        xml
    }

    /// Rewrite the `.pvd` file with every entry so far.
    pub fn flush(&self) -> Result<()> {
        let xml = self.to_xml();
        super::write_atomic(&self.path, |w| Ok(w.write_all(xml.as_bytes())?))
    }
}

/// Escape text for an XML attribute value.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_attributes() {
        assert_eq!(xml_escape("a<b & \"c\">"), "a&lt;b &amp; &quot;c&quot;&gt;");
    }
}
