//! The one rule for output folders, shared by every command that writes
//! (`run`, `experiment`, `script`, `render`, `noise`, `export`, `gallery`,
//! `paper`):
//!
//! 1. the folder is a folder or does not exist yet, inside a writable
//!    folder ([`io::check_output_dir`]);
//! 2. a folder that holds an earlier run's outputs — files of the kinds this
//!    command writes ([`Outputs::is_output`]) — is refused (exit 2, naming
//!    the folder and one of the files) unless `--overwrite` is given;
//! 3. with `--overwrite` exactly those files are removed, and only once every
//!    other input has been checked ([`Earlier::remove`]); a file of another
//!    kind stays (`notes.txt` beside a run's frames), and so does another
//!    command's `manifest.json`: writing ours would replace it, so such a
//!    folder is refused even with `--overwrite`.
//!
//! Two more parts of the rule live with the commands that need them: an
//! experiment at a size other than the default writes into `runs/`, never
//! into `results/`, unless `--out` asks for it (`cli/experiment.rs`); and `gallery`,
//! `paper` and the experiments' peer scripts look for the repository from the
//! working folder only, never falling back to the checkout the binary was
//! built from ([`repository_root`]).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use smokelab::error::InputError;
use smokelab::io;

/// What one command writes into its output folder.
#[derive(Clone, Copy, Debug)]
pub struct Outputs {
    /// The command, for messages (`run`, `render`…).
    pub command: &'static str,
    /// Whether a file of this name is of a kind the command writes.
    pub is_output: fn(&str) -> bool,
    /// Whether the command also writes folders of its own inside the
    /// output folder (an experiment's runs): the outputs in subfolders
    /// count and are removed too, and folders left empty are removed.
    pub subfolders: bool,
    /// For commands whose `manifest.json` holds `config.<key>`: a manifest
    /// without it is another command's, and refused even with `--overwrite`.
    /// `None`: every `manifest.json` counts as an output of the command.
    pub manifest_key: Option<&'static str>,
}

/// Whether `name` is `<stem>_NNNN.<ext>` with four or more digits and `ext`
/// one of `exts` (a saved frame: `hot_0010.npy`, `preview_0010.png`).
pub fn is_frame_file(name: &str, exts: &[&str]) -> bool {
    exts.iter().any(|ext| {
        name.strip_suffix(ext)
            .and_then(|s| s.strip_suffix('.'))
            .and_then(|stem| stem.rsplit_once('_'))
            .is_some_and(|(_, n)| n.len() >= 4 && n.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// `smokelab run` (and `run --resume`): volumes, previews, renders, VDB and
/// VTK frames, the obstacle, metrics (and a prescribed flow's `exact.csv`),
/// manifest and checkpoint.
pub const RUN: Outputs = Outputs {
    command: "run",
    is_output: |name| {
        is_frame_file(name, &["npy", "png", "exr", "vdb", "vti"])
            || [
                "metrics.csv",
                "exact.csv",
                "manifest.json",
                "run.pvd",
                "obstacle.npy",
                crate::run::checkpoint::FILE,
            ]
            .contains(&name)
    },
    subfolders: false,
    manifest_key: None,
};

/// `smokelab script`: what a run writes, plus the arrays a script names
/// (`<name>.npy`).
pub const SCRIPT: Outputs = Outputs {
    command: "script",
    is_output: |name| (RUN.is_output)(name) || name.ends_with(".npy"),
    subfolders: false,
    manifest_key: None,
};

/// `smokelab experiment`: figures, tables, arrays, frames, captions and
/// manifests, in the experiment's folder and the run folders inside it.
pub const EXPERIMENT: Outputs = Outputs {
    command: "experiment",
    is_output: |name| {
        const KINDS: [&str; 11] = [
            "png", "svg", "csv", "json", "md", "npy", "exr", "vdb", "vti", "pvd", "obj",
        ];
        name.rsplit_once('.')
            .is_some_and(|(_, ext)| KINDS.contains(&ext))
    },
    subfolders: true,
    manifest_key: None,
};

/// `smokelab render`: the image and its manifest.
pub const RENDER: Outputs = Outputs {
    command: "render",
    is_output: |name| ["render.exr", "render.png", "manifest.json"].contains(&name),
    subfolders: false,
    manifest_key: Some("densities"),
};

/// `smokelab noise`: the sampled field, its slice and manifest.
pub const NOISE: Outputs = Outputs {
    command: "noise",
    is_output: |name| ["noise.npy", "slice.png", "manifest.json"].contains(&name),
    subfolders: false,
    manifest_key: Some("spec"),
};

/// `smokelab export vdb`: the OpenVDB frames.
pub const EXPORT_VDB: Outputs = Outputs {
    command: "export vdb",
    is_output: |name| name.starts_with("frame_") && is_frame_file(name, &["vdb"]),
    subfolders: false,
    manifest_key: None,
};

/// `smokelab export paraview`: the VTK frames and their time series.
pub const EXPORT_PARAVIEW: Outputs = Outputs {
    command: "export paraview",
    is_output: |name| {
        (name.starts_with("frame_") && is_frame_file(name, &["vti"])) || name == "run.pvd"
    },
    subfolders: false,
    manifest_key: None,
};

/// `smokelab gallery`: the page.
pub const GALLERY: Outputs = Outputs {
    command: "gallery",
    is_output: |name| name == "index.html",
    subfolders: false,
    manifest_key: None,
};

/// `smokelab paper`: the HTML build of the paper (the Markdown is the
/// source; only its generated blocks are rewritten).
pub const PAPER: Outputs = Outputs {
    command: "paper",
    is_output: |name| name == "paper.html",
    subfolders: false,
    manifest_key: None,
};

/// The earlier outputs found in a folder by [`check`]: removed by
/// [`Earlier::remove`] once everything else has been checked.
#[derive(Debug, Default)]
pub struct Earlier {
    /// The outputs, sorted.
    pub files: Vec<PathBuf>,
    /// Subfolders holding some of them, deepest first (removed when empty).
    folders: Vec<PathBuf>,
}

impl Earlier {
    /// Whether the folder held no outputs of the command.
    pub fn is_empty(&self) -> bool {
        self.files.is_empty()
    }

    /// Remove the earlier outputs, then the subfolders they leave empty.
    pub fn remove(self) -> Result<()> {
        for f in &self.files {
            std::fs::remove_file(f)
                .with_context(|| format!("cannot remove {} to overwrite it", f.display()))?;
        }
        for d in &self.folders {
            // Only when empty: a file of another kind keeps its folder.
            let _ = std::fs::remove_dir(d);
        }
        Ok(())
    }
}

/// The files in `dir` that `outputs` names (recursively when it writes
/// subfolders), sorted, and the subfolders holding them; nothing when `dir`
/// does not exist.
pub fn earlier_outputs(dir: &Path, outputs: &Outputs) -> Earlier {
    let mut found = Earlier::default();
    collect(dir, outputs, &mut found, false);
    found.files.sort();
    found
}

fn collect(dir: &Path, outputs: &Outputs, found: &mut Earlier, nested: bool) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let before = found.files.len();
    for e in entries.filter_map(|e| e.ok()) {
        let Ok(kind) = e.file_type() else { continue };
        let path = e.path();
        if kind.is_dir() && outputs.subfolders {
            collect(&path, outputs, found, true);
        } else if kind.is_file() && e.file_name().to_str().is_some_and(outputs.is_output) {
            found.files.push(path);
        }
    }
    if nested && found.files.len() > before {
        found.folders.push(dir.to_path_buf());
    }
}

/// Apply the rule to `dir` for the command `outputs` describes: check that
/// it can be an output folder, refuse another command's manifest in it,
/// and refuse earlier outputs unless `overwrite`. Nothing is removed or
/// created; the caller removes the returned [`Earlier`] outputs (empty
/// unless `overwrite`) once all its input is checked, then creates `dir`.
pub fn check(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<Earlier, InputError> {
    io::check_output_dir(dir)?;
    if let Some(key) = outputs.manifest_key {
        check_own_manifest(dir, key, outputs.command)?;
    }
    let earlier = earlier_outputs(dir, outputs);
    if !earlier.is_empty() && !overwrite {
        return Err(InputError::new(format!(
            "output folder {} holds {} files of an earlier run (e.g. {}); give another --out, or --overwrite to replace them (only the files `smokelab {}` writes are removed)",
            dir.display(),
            earlier.files.len(),
            earlier.files[0].display(),
            outputs.command
        )));
    }
    Ok(earlier)
}

/// [`check`], then remove the earlier outputs and create `dir`: for
/// commands that have checked all their other input already.
pub fn prepare(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<()> {
    check(dir, outputs, overwrite)?.remove()?;
    io::create_output_dir(dir)
}

/// Refuse `out` when it holds a `manifest.json` that is not `command`'s
/// (one without `config.<own_key>`): writing there would replace another
/// command's manifest, e.g. a run's.
pub fn check_own_manifest(out: &Path, own_key: &str, command: &str) -> Result<(), InputError> {
    let path = out.join("manifest.json");
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(());
    }
    let ours = io::input::read_text(&path, "manifest")
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .is_some_and(|m| m["config"].get(own_key).is_some());
    if ours {
        return Ok(());
    }
    Err(InputError::new(format!(
        "output folder {} holds a manifest.json that `smokelab {command}` did not write (a run's?); \
         writing there would replace it, even with --overwrite; give another --out",
        out.display()
    )))
}

/// The repository the working folder is in: the nearest folder at or
/// above it that holds `paper/paper.md`. There is no fallback to the
/// checkout this binary was built from: outside a repository the commands
/// that write into it (`paper`, `gallery`) need a path given.
pub fn repository_root() -> Result<PathBuf> {
    let cwd = std::env::current_dir().context("cannot read the working directory")?;
    cwd.ancestors()
        .map(Path::to_path_buf)
        .find(|d| d.join("paper/paper.md").is_file())
        .map(|d| d.canonicalize().unwrap_or(d))
        .ok_or_else(|| {
            anyhow::Error::new(InputError::new(format!(
                "no paper/paper.md in {} or above it: run inside the repository, or give its folder (paper --root DIR, gallery --results DIR)",
                cwd.display()
            )))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, b"x").unwrap();
    }

    #[test]
    fn frame_files_are_named_with_four_or_more_digits() {
        assert!(is_frame_file("hot_0010.npy", &["npy"]));
        assert!(is_frame_file("frame_12345.vdb", &["vdb"]));
        assert!(!is_frame_file("hot_010.npy", &["npy"]));
        assert!(!is_frame_file("hot_0010.npy", &["png"]));
        assert!(!is_frame_file("sequence.png", &["png"]));
    }

    #[test]
    fn a_used_folder_is_refused_and_overwrite_removes_only_the_commands_files() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in [
            "hot_0010.npy",
            "preview_0010.png",
            "manifest.json",
            "notes.txt",
        ] {
            touch(&d.join(f));
        }
        let e = check(d, &RUN, false).unwrap_err().to_string();
        assert!(
            e.contains(&d.display().to_string()) && e.contains("--overwrite"),
            "{e}"
        );
        let earlier = check(d, &RUN, true).unwrap();
        assert_eq!(earlier.files.len(), 3);
        earlier.remove().unwrap();
        let left: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("notes.txt")]);
        // Now it holds nothing of a run's: accepted without --overwrite.
        assert!(check(d, &RUN, false).unwrap().is_empty());
    }

    #[test]
    fn an_experiment_clears_its_run_folders_and_keeps_foreign_files() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in [
            "data.csv",
            "a/manifest.json",
            "a/hot_0010.npy",
            "b/keep.txt",
            "b/x.png",
        ] {
            touch(&d.join(f));
        }
        assert!(check(d, &EXPERIMENT, false).is_err());
        check(d, &EXPERIMENT, true).unwrap().remove().unwrap();
        assert!(!d.join("a").exists(), "an emptied run folder stays");
        assert!(d.join("b/keep.txt").is_file() && !d.join("b/x.png").exists());
        assert!(!d.join("data.csv").exists());
    }

    #[test]
    fn another_commands_manifest_is_refused_even_with_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("manifest.json"),
            r#"{"config": {"res": 10}}"#,
        )
        .unwrap();
        let e = check(dir.path(), &RENDER, true).unwrap_err().to_string();
        assert!(e.contains("did not write"), "{e}");
        std::fs::write(
            dir.path().join("manifest.json"),
            r#"{"config": {"densities": []}}"#,
        )
        .unwrap();
        assert!(check(dir.path(), &RENDER, false).is_err());
        assert_eq!(check(dir.path(), &RENDER, true).unwrap().files.len(), 1);
    }
}
