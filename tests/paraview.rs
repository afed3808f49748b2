//! ParaView output (`.vti` + `.pvd`), read back independently.
//!
//! The default tests parse the files with a small reader written here from
//! the VTK XML format description (attributes by string search, the appended
//! block by byte offsets). The ignored test reads them with VTK itself:
//!
//! ```sh
//! apt-get install -y python3-vtk9        # or: pip install vtk
//! cargo test --release --test paraview -- --ignored
//! ```
//!
//! (`SMOKELAB_PYTHON` names the interpreter; default `/usr/bin/python3` when
//! it exists, else `python3`.)

use std::path::Path;

use glam::Vec3;
use ndarray::{Array3, Array4};
use smokelab::io::vtk::{write_vti, PvdCollection, VolumeGeometry};

fn geometry() -> VolumeGeometry {
    VolumeGeometry::new(Vec3::new(-1.5, 0.25, 2.0), 0.25, [20, 24, 28])
}

fn volumes(g: &VolumeGeometry, t: f32) -> (Array3<f32>, Array3<f32>, Array4<f32>) {
    let (nz, ny, nx) = g.shape();
    let density = Array3::from_shape_fn((nz, ny, nx), |(k, j, i)| {
        let r = (g.cell_center(i, j, k) - g.origin - Vec3::new(2.4, 3.1, 3.3)).length();
        (1.6 - r).max(0.0) * (1.0 + t) + 1e-3 * i as f32
    });
    let temperature = Array3::from_shape_fn((nz, ny, nx), |(k, j, i)| {
        (i as f32 - 0.5 * j as f32 + 0.25 * k as f32) * 0.1 + t
    });
    let vel = Array4::from_shape_fn((nz, ny, nx, 3), |(k, j, i, c)| {
        let p = g.cell_center(i, j, k);
        [
            p.y * 0.5 - 0.1,
            -p.x * 0.75 + t,
            0.01 * (i + 2 * j + 3 * k) as f32,
        ][c]
    });
    (density, temperature, vel)
}

/// Value of `name="…"` in the first tag of `xml` that starts with `tag`
/// and contains `must`.
fn attr(xml: &str, tag: &str, must: &str, name: &str) -> String {
    let start = xml
        .match_indices(tag)
        .map(|(i, _)| i)
        .find(|&i| xml[i..i + xml[i..].find('>').unwrap()].contains(must))
        .unwrap_or_else(|| panic!("no {tag} with {must}"));
    let t = &xml[start..start + xml[start..].find('>').unwrap()];
    let key = format!(" {name}=\"");
    let a = t
        .find(&key)
        .unwrap_or_else(|| panic!("{tag} has no {name}"))
        + key.len();
    t[a..a + t[a..].find('"').unwrap()].to_string()
}

/// The XML head and the appended bytes after the `_` marker.
fn split(bytes: &[u8]) -> (String, &[u8]) {
    let marker = b"<AppendedData encoding=\"raw\">";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .expect("no raw AppendedData");
    let underscore = at + bytes[at..].iter().position(|&b| b == b'_').unwrap();
    (
        String::from_utf8(bytes[..underscore].to_vec()).unwrap(),
        &bytes[underscore + 1..],
    )
}

/// One appended array: UInt64 byte count, then little-endian f32.
fn array(xml: &str, data: &[u8], name: &str) -> (Vec<f32>, usize) {
    let must = format!("Name=\"{name}\"");
    assert_eq!(attr(xml, "<DataArray", &must, "type"), "Float32");
    assert_eq!(attr(xml, "<DataArray", &must, "format"), "appended");
    let offset: usize = attr(xml, "<DataArray", &must, "offset").parse().unwrap();
    let components: usize = if xml.contains(&format!("{must} NumberOfComponents")) {
        attr(xml, "<DataArray", &must, "NumberOfComponents")
            .parse()
            .unwrap()
    } else {
        1
    };
    let n = u64::from_le_bytes(data[offset..offset + 8].try_into().unwrap()) as usize;
    let values = data[offset + 8..offset + 8 + n]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (values, components)
}

#[test]
fn vti_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.vti");
    let g = geometry();
    let (d, t, v) = volumes(&g, 0.0);
    write_vti(
        &path,
        &g,
        &[("density", d.view()), ("temperature", t.view())],
        &[("vel", v.view())],
    )
    .unwrap();
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    let bytes = std::fs::read(&path).unwrap();
    assert!(bytes.ends_with(b"</AppendedData>\n</VTKFile>\n"));
    let (xml, data) = split(&bytes);
    assert_eq!(attr(&xml, "<VTKFile", "", "type"), "ImageData");
    assert_eq!(attr(&xml, "<VTKFile", "", "byte_order"), "LittleEndian");
    assert_eq!(attr(&xml, "<VTKFile", "", "header_type"), "UInt64");
    // 20 × 24 × 28 cells: extents count points.
    assert_eq!(
        attr(&xml, "<ImageData", "", "WholeExtent"),
        "0 20 0 24 0 28"
    );
    assert_eq!(attr(&xml, "<Piece", "", "Extent"), "0 20 0 24 0 28");
    let origin: Vec<f32> = attr(&xml, "<ImageData", "", "Origin")
        .split(' ')
        .map(|s| s.parse().unwrap())
        .collect();
    assert_eq!(origin, [-1.5, 0.25, 2.0]);
    assert_eq!(attr(&xml, "<ImageData", "", "Spacing"), "0.25 0.25 0.25");
    assert_eq!(attr(&xml, "<CellData", "", "Scalars"), "density");
    assert_eq!(attr(&xml, "<CellData", "", "Vectors"), "vel");
    // Nothing on points: the volumes are cell data.
    assert!(xml.contains("<PointData>\n      </PointData>"));

    let cells = 20 * 24 * 28;
    for (name, a) in [("density", &d), ("temperature", &t)] {
        let (values, components) = array(&xml, data, name);
        assert_eq!(components, 1);
        assert_eq!(values.len(), cells);
        // VTK cell index i + nx (j + ny k) = the [z][y][x] order.
        for k in 0..28 {
            for j in 0..24 {
                for i in 0..20 {
                    assert_eq!(
                        values[i + 20 * (j + 24 * k)],
                        a[[k, j, i]],
                        "{name} ({i},{j},{k})"
                    );
                }
            }
        }
    }
    let (values, components) = array(&xml, data, "vel");
    assert_eq!(components, 3);
    assert_eq!(values.len(), 3 * cells);
    assert_eq!(values, v.iter().copied().collect::<Vec<_>>());
    assert_eq!(values[3 * (7 + 20 * (5 + 24 * 11)) + 1], v[[11, 5, 7, 1]]);
}

#[test]
fn non_contiguous_views_are_written_in_logical_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.vti");
    let g = VolumeGeometry::new(Vec3::ZERO, 1.0, [3, 4, 5]);
    // Build (nx, ny, nz) and view it transposed as (nz, ny, nx).
    let xyz = Array3::from_shape_fn((3, 4, 5), |(i, j, k)| (100 * k + 10 * j + i) as f32);
    let zyx = xyz.view().reversed_axes();
    write_vti(&path, &g, &[("a", zyx)], &[]).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let (xml, data) = split(&bytes);
    let (values, _) = array(&xml, data, "a");
    assert_eq!(values[..4], [0.0, 1.0, 2.0, 10.0]);
    assert_eq!(values[59], 432.0);
}

#[test]
fn pvd_lists_frames_and_is_rewritten_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let pvd = dir.path().join("run.pvd");
    let g = geometry();
    let mut run = PvdCollection::new(&pvd);
    assert!(!pvd.exists());
    for (n, time) in [0.0, 0.05, 0.1].into_iter().enumerate() {
        let (d, t, v) = volumes(&g, time as f32);
        let file = format!("frame_{n:04}.vti");
        run.write_frame(
            time,
            &file,
            &g,
            &[("density", d.view()), ("temperature", t.view())],
            &[("vel", v.view())],
        )
        .unwrap();
        let xml = std::fs::read_to_string(&pvd).unwrap();
        assert_eq!(xml.matches("<DataSet ").count(), n + 1);
        assert!(dir.path().join(&file).exists());
    }
    // A re-written frame replaces its entry.
    run.push(0.1, "frame_0002.vti").unwrap();
    let xml = std::fs::read_to_string(&pvd).unwrap();
    assert_eq!(attr(&xml, "<VTKFile", "", "type"), "Collection");
    let entries: Vec<(f64, String)> = xml
        .match_indices("<DataSet ")
        .map(|(i, _)| {
            let tag = &xml[i..];
            (
                attr(tag, "<DataSet", "", "timestep").parse().unwrap(),
                attr(tag, "<DataSet", "", "file"),
            )
        })
        .collect();
    assert_eq!(
        entries,
        [
            (0.0, "frame_0000.vti".to_string()),
            (0.05, "frame_0001.vti".to_string()),
            (0.1, "frame_0002.vti".to_string()),
        ]
    );
    assert_eq!(run.entries(), &entries[..]);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(
        names.iter().all(|n| !smokelab::io::is_temporary_file(n)),
        "{names:?}"
    );
    assert!(run.push(f64::NAN, "x.vti").is_err());
}

fn python() -> String {
    std::env::var("SMOKELAB_PYTHON").unwrap_or_else(|_| {
        if Path::new("/usr/bin/python3").exists() {
            "/usr/bin/python3".into()
        } else {
            "python3".into()
        }
    })
}

/// Read the frames with VTK's own `vtkXMLImageDataReader` (through the
/// `.pvd` entries) and check origin, spacing, extents, array names,
/// components and every value.
///
/// Run: `cargo test --release --test paraview -- --ignored`
/// (needs `apt-get install -y python3-vtk9` or `pip install vtk`).
#[test]
#[ignore = "needs VTK's Python module (python3-vtk9 or pip vtk)"]
fn vtk_reads_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    let pvd = dir.path().join("run.pvd");
    let g = geometry();
    let mut run = PvdCollection::new(&pvd);
    for (n, time) in [0.0, 0.5].into_iter().enumerate() {
        let (d, t, v) = volumes(&g, time as f32);
        let file = format!("frame_{n:04}.vti");
        run.write_frame(
            time,
            &file,
            &g,
            &[("density", d.view()), ("temperature", t.view())],
            &[("vel", v.view())],
        )
        .unwrap();
        for (name, a) in [
            ("density", d.as_slice().unwrap()),
            ("temperature", t.as_slice().unwrap()),
            ("vel", v.as_slice().unwrap()),
        ] {
            let bytes: Vec<u8> = a.iter().flat_map(|x| x.to_le_bytes()).collect();
            std::fs::write(dir.path().join(format!("{n}_{name}.f32")), bytes).unwrap();
        }
    }
    let script = PY_CHECK.replace("@DIR@", dir.path().to_str().unwrap());
    let out = std::process::Command::new(python())
        .args(["-c", &script])
        .output()
        .expect("cannot run python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "python check failed");
    assert!(stdout.contains("VTK OK"));
}

const PY_CHECK: &str = r#"
import os
import xml.etree.ElementTree as ET
import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy
d = "@DIR@"
nx, ny, nz = 20, 24, 28
sets = ET.parse(os.path.join(d, "run.pvd")).getroot().find("Collection").findall("DataSet")
print("VTK", vtk.vtkVersion.GetVTKVersion(), "pvd entries", [(s.get("timestep"), s.get("file")) for s in sets])
assert [float(s.get("timestep")) for s in sets] == [0.0, 0.5]
for n, s in enumerate(sets):
    r = vtk.vtkXMLImageDataReader()
    r.SetFileName(os.path.join(d, s.get("file")))
    r.Update()
    img = r.GetOutput()
    assert np.allclose(img.GetOrigin(), (-1.5, 0.25, 2.0), atol=0), img.GetOrigin()
    assert np.allclose(img.GetSpacing(), (0.25, 0.25, 0.25), atol=0), img.GetSpacing()
    assert img.GetDimensions() == (nx + 1, ny + 1, nz + 1), img.GetDimensions()
    assert img.GetNumberOfCells() == nx * ny * nz
    assert img.GetPointData().GetNumberOfArrays() == 0
    cd = img.GetCellData()
    names = [cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())]
    assert names == ["density", "temperature", "vel"], names
    assert cd.GetScalars().GetName() == "density" and cd.GetVectors().GetName() == "vel"
    for name, comps in [("density", 1), ("temperature", 1), ("vel", 3)]:
        arr = cd.GetArray(name)
        assert arr.GetNumberOfComponents() == comps and arr.GetDataTypeAsString() == "float"
        got = vtk_to_numpy(arr).reshape(-1)
        src = np.fromfile(os.path.join(d, "%d_%s.f32" % (n, name)), dtype="<f4")
        assert np.array_equal(got, src), name
    # The cell containing a cell centre is that cell.
    i, j, k = 7, 5, 11
    centre = np.array((-1.5, 0.25, 2.0)) + (np.array((i, j, k)) + 0.5) * 0.25
    cid = img.FindCell(centre, None, 0, 1e-9, vtk.reference(0), [0.0] * 3, [0.0] * 8)
    assert cid == i + nx * (j + ny * k), cid
    print(s.get("file"), "dims", img.GetDimensions(), "origin", img.GetOrigin(),
          "spacing", img.GetSpacing(), "arrays", names, "range density", cd.GetArray("density").GetRange())
print("VTK OK")
"#;
