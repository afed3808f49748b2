//! The one rule for output folders, shared by every command that writes a
//! folder (`run`, `run --resume`, `experiment`, `script`, `render`,
//! `noise`, `export`):
//!
//! 1. the folder is a folder or does not exist yet, inside a writable
//!    folder, and not a system folder ([`io::check_output_dir`]);
//! 2. one writer at a time: the command holds the folder's lock while it
//!    writes ([`io::folder::OutputFolder`]), and a second one is refused
//!    (exit 2, naming the holder);
//! 3. smokelab records every file and folder it writes there
//!    ([`io::folder::RECORD`]); a folder holding recorded files of the kinds
//!    this command writes ([`Outputs::replaces`]) is refused (exit 2, naming
//!    them) unless `--overwrite`, which removes exactly those — never a file
//!    smokelab did not write, whatever its name — and the recorded folders
//!    they leave empty, once every other input is checked;
//! 4. a file smokelab did not write is never replaced: one at a name the
//!    command writes is refused before any work when the name is fixed
//!    ([`Outputs::fixed`]), else when the write comes to it; and a folder
//!    with a `manifest.json` but no record (written by a smokelab that kept
//!    none) is refused even with `--overwrite`: nothing is removed by name;
//! 5. a default folder name (`runs/<scenario>-<seconds>`) is created
//!    atomically, with a suffix when another run took it ([`create_fresh`]).
//!
//! `gallery` and `paper` write one file each into a folder that is not
//! theirs (`index.html`, `paper/paper.html`): an existing one is replaced
//! only with `--overwrite` ([`check_file`]). Two more parts of the rule live
//! with the commands that need them: an experiment writes into a new folder
//! under `runs/`, and into the committed `results/` only when asked
//! (`--publish`, at the default size and from a clean build, or an `--out`
//! there; `cli/experiment.rs`); and `gallery`, `paper` and the experiments'
//! peer scripts look for the repository from the working folder only, never
//! falling back to the checkout the binary was built from
//! ([`repository_root`]).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use smokelab::error::InputError;
use smokelab::io::{self, folder};

/// What one command writes into its output folder.
#[derive(Clone, Copy, Debug)]
pub struct Outputs<'a> {
    /// The command, for messages (`run`, `render`…).
    pub command: &'static str,
    /// Whether a recorded file of this name is of a kind the command
    /// writes, and so replaced by `--overwrite` (besides the `fixed` ones).
    pub replaces: fn(&str) -> bool,
    /// Names the command always writes at the top of the folder; recorded,
    /// they are earlier outputs that `--overwrite` replaces.
    pub fixed: &'a [&'a str],
    /// Whether the command writes the folder's `manifest.json` (a folder
    /// holding one without a record is then refused).
    pub writes_manifest: bool,
    /// For commands whose `manifest.json` holds `config.<key>`: a manifest
    /// without it is another command's, and refused even with `--overwrite`.
    pub manifest_key: Option<&'static str>,
}

/// Whether `name` is `<stem>_NNNN.<ext>` with four or more digits and `ext`
/// one of `exts` (a saved frame: `hot_0010.npy`, `frame_0001.vdb`).
pub fn is_frame_file(name: &str, exts: &[&str]) -> bool {
    exts.iter().any(|ext| {
        name.strip_suffix(ext)
            .and_then(|s| s.strip_suffix('.'))
            .and_then(|stem| stem.rsplit_once('_'))
            .is_some_and(|(_, n)| n.len() >= 4 && n.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// `smokelab run` (and `run --resume`): everything it recorded.
pub const RUN: Outputs<'static> = Outputs {
    command: "run",
    replaces: |_| true,
    fixed: &[
        "manifest.json",
        "metrics.csv",
        "exact.csv",
        "energy.csv",
        "obstacle.npy",
        "run.pvd",
        crate::run::checkpoint::FILE,
    ],
    writes_manifest: true,
    manifest_key: None,
};

/// `smokelab script`: everything it recorded.
pub const SCRIPT: Outputs<'static> = Outputs {
    command: "script",
    replaces: |_| true,
    fixed: &["manifest.json"],
    writes_manifest: true,
    manifest_key: None,
};

/// `smokelab experiment`: everything it recorded, in its folder and the
/// run folders inside it.
pub const EXPERIMENT: Outputs<'static> = Outputs {
    command: "experiment",
    replaces: |_| true,
    fixed: &[],
    writes_manifest: true,
    manifest_key: None,
};

/// `smokelab render`: one frame's image, its preview and its manifest
/// (`render_NNNN.exr`, `.png`, `.json`, named by `cli::render`), so several
/// frames share a folder and `--overwrite` replaces only the frame rendered
/// again.
pub fn render<'a>(files: &'a [&'a str]) -> Outputs<'a> {
    Outputs {
        command: "render",
        replaces: |_| false,
        fixed: files,
        writes_manifest: false,
        manifest_key: None,
    }
}

/// `smokelab noise`: the sampled field, its slice and manifest.
pub const NOISE: Outputs<'static> = Outputs {
    command: "noise",
    replaces: |_| true,
    fixed: &["noise.npy", "slice.png", "manifest.json"],
    writes_manifest: true,
    manifest_key: Some("spec"),
};

/// `smokelab export vdb`: the OpenVDB frames (a run's own `--vdb` frames
/// among them).
pub const EXPORT_VDB: Outputs<'static> = Outputs {
    command: "export vdb",
    replaces: |name| name.starts_with("frame_") && is_frame_file(name, &["vdb"]),
    fixed: &[],
    writes_manifest: false,
    manifest_key: None,
};

/// `smokelab export paraview`: the VTK frames and their time series.
pub const EXPORT_PARAVIEW: Outputs<'static> = Outputs {
    command: "export paraview",
    replaces: |name| {
        (name.starts_with("frame_") && is_frame_file(name, &["vti"])) || name == "run.pvd"
    },
    fixed: &["run.pvd"],
    writes_manifest: false,
    manifest_key: None,
};

/// The recorded files of `record` in `dir` that `outputs` replaces and that
/// are there now, as recorded (relative, `/`-separated).
fn replaced(dir: &Path, record: &BTreeSet<String>, outputs: &Outputs) -> Vec<String> {
    record
        .iter()
        .filter(|e| !e.ends_with('/'))
        .filter(|e| {
            (outputs.replaces)(e.rsplit('/').next().unwrap_or(e))
                || outputs.fixed.contains(&e.as_str())
        })
        .filter(|e| std::fs::symlink_metadata(dir.join(e)).is_ok_and(|m| !m.is_dir()))
        .cloned()
        .collect()
}

/// A few of `files`, for a message.
fn some(files: &[String]) -> String {
    let shown: Vec<&str> = files.iter().take(3).map(String::as_str).collect();
    let more = files.len().saturating_sub(shown.len());
    if more > 0 {
        format!("{} and {more} more", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

/// The rule's checks on `dir`, the lock aside: what `--overwrite` would
/// remove, or the refusal.
fn earlier(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<Vec<String>, InputError> {
    if let Some(key) = outputs.manifest_key {
        check_own_manifest(dir, key, outputs.command)?;
    }
    let record = folder::read_record(dir)?;
    let foreign = |name: &str| {
        InputError::new(format!(
            "output folder {} holds {name}, which smokelab did not write; `smokelab {}` would replace it: move it away, or give another --out",
            dir.display(),
            outputs.command
        ))
    };
    let Some(record) = record else {
        if outputs.writes_manifest && std::fs::symlink_metadata(dir.join("manifest.json")).is_ok() {
            return Err(InputError::new(format!(
                "output folder {} holds a manifest.json but no record of the files smokelab wrote there ({}; a smokelab older than 0.4 kept none, or the folder is not smokelab's); nothing is removed by name, even with --overwrite: move its files away, or give another --out",
                dir.display(),
                folder::RECORD
            )));
        }
        if let Some(name) = outputs
            .fixed
            .iter()
            .find(|n| std::fs::symlink_metadata(dir.join(n)).is_ok())
        {
            return Err(foreign(name));
        }
        return Ok(Vec::new());
    };
    if let Some(name) = outputs
        .fixed
        .iter()
        .find(|n| !record.contains(**n) && std::fs::symlink_metadata(dir.join(n)).is_ok())
    {
        return Err(foreign(name));
    }
    let files = replaced(dir, &record, outputs);
    if !files.is_empty() && !overwrite {
        return Err(InputError::new(format!(
            "output folder {} holds {} files an earlier smokelab wrote ({}); give another --out, or --overwrite to replace exactly those (files smokelab did not write stay)",
            dir.display(),
            files.len(),
            some(&files)
        )));
    }
    Ok(files)
}

/// Apply the rule to `dir` for the command `outputs` describes, before any
/// work: a usable folder, not being written by another process, without
/// another command's manifest or a file smokelab did not write at a name it
/// writes, and without earlier outputs unless `overwrite`. Nothing is
/// removed or created; [`open`] does that once all input is checked.
pub fn check(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<(), InputError> {
    io::check_output_dir(dir)?;
    folder::check_free(dir)?;
    earlier(dir, outputs, overwrite).map(|_| ())
}

/// Create and lock `dir`, check the rule again under the lock, and remove
/// the earlier outputs `overwrite` replaces: for commands that have checked
/// all their other input already ([`check`]). The folder records what is
/// written in it until the returned guard is dropped.
pub fn open(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<folder::OutputFolder> {
    io::check_output_dir(dir)?;
    // Before the lock creates the record: a folder without one is checked
    // as it is.
    earlier(dir, outputs, overwrite)?;
    let open = folder::OutputFolder::open(dir)?;
    let files = earlier(dir, outputs, overwrite)?;
    open.remove(&files)?;
    Ok(open)
}

/// Remove the folder `dir` when it holds nothing but smokelab's own
/// bookkeeping (the record and the lock [`open`] made): what a command
/// that created the folder and failed before writing any output leaves.
/// A folder holding anything else stays as it is.
pub fn remove_if_unwritten(dir: &Path) {
    let bookkeeping = [folder::RECORD, folder::LOCK];
    let only_bookkeeping = std::fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .flatten()
            .all(|e| bookkeeping.iter().any(|b| e.file_name() == *b))
    });
    if only_bookkeeping {
        for name in bookkeeping {
            let _ = std::fs::remove_file(dir.join(name));
        }
        let _ = std::fs::remove_dir(dir);
    }
}

/// [`check`] then [`open`]: for commands whose input is all checked.
pub fn prepare(dir: &Path, outputs: &Outputs, overwrite: bool) -> Result<folder::OutputFolder> {
    check(dir, outputs, overwrite)?;
    open(dir, outputs, overwrite)
}

/// Create the default folder `base` (`runs/hot-cold-<seconds>`) or, when
/// another process made it first, `base-2`, `base-3`…: each attempt
/// creates the folder exclusively, so two runs never share one.
pub fn create_fresh(base: &Path) -> Result<PathBuf> {
    if let Some(parent) = base.parent().filter(|p| !p.as_os_str().is_empty()) {
        io::check_output_dir(parent)?;
        io::create_output_dir(parent)?;
    }
    for n in 1.. {
        let dir = match n {
            1 => base.to_path_buf(),
            n => {
                let mut name = base.as_os_str().to_owned();
                name.push(format!("-{n}"));
                PathBuf::from(name)
            }
        };
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("cannot create output folder {}", dir.display()))
            }
        }
    }
    unreachable!("some suffix is free")
}

/// `gallery` and `paper`: `path`, the one file the command writes into a
/// folder that is not its own, is replaced only with `overwrite`.
pub fn check_file(path: &Path, command: &str, overwrite: bool) -> Result<(), InputError> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        io::check_output_dir(dir)?;
    }
    if std::fs::symlink_metadata(path).is_ok() && !overwrite {
        return Err(InputError::new(format!(
            "{} exists (an earlier `smokelab {command}`'s?); give --overwrite to replace it",
            path.display()
        )));
    }
    Ok(())
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

    fn write(p: &Path) {
        io::create_output_dir(p.parent().unwrap()).unwrap();
        io::write_atomic(p, |w| Ok(std::io::Write::write_all(w, b"x")?)).unwrap();
    }

    fn touch(p: &Path) {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, b"x").unwrap();
    }

    fn names(d: &Path) -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| !n.starts_with(".smokelab"))
            .collect();
        n.sort();
        n
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
    fn overwrite_removes_exactly_the_recorded_files_whatever_their_names() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // The user's files, named as frames are.
        for f in [
            "IMG_1234.png",
            "scan_00012.npy",
            "notes.txt",
            "sub/data.csv",
        ] {
            touch(&d.join(f));
        }
        {
            let _open = open(d, &EXPERIMENT, false).unwrap();
            for f in ["hot_0010.npy", "a/manifest.json", "a/b/x.png"] {
                write(&d.join(f));
            }
        }
        let e = check(d, &EXPERIMENT, false).unwrap_err().to_string();
        assert!(
            e.contains("holds 3 files") && e.contains("a/b/x.png") && e.contains("--overwrite"),
            "{e}"
        );
        drop(open(d, &EXPERIMENT, true).unwrap());
        assert_eq!(
            names(d),
            ["IMG_1234.png", "notes.txt", "scan_00012.npy", "sub"]
        );
        assert!(d.join("sub/data.csv").is_file());
        // Now it holds nothing smokelab wrote: accepted without --overwrite.
        check(d, &EXPERIMENT, false).unwrap();
    }

    #[test]
    fn a_file_smokelab_did_not_write_is_never_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        touch(&d.join("metrics.csv"));
        let e = check(d, &RUN, true).unwrap_err().to_string();
        assert!(
            e.contains("metrics.csv, which smokelab did not write"),
            "{e}"
        );
        let _open = open(d, &SCRIPT, false).unwrap();
        let e = io::write_atomic(&d.join("metrics.csv"), |_| Ok(()))
            .unwrap_err()
            .to_string();
        assert!(e.contains("did not write"), "{e}");
        assert_eq!(std::fs::read(d.join("metrics.csv")).unwrap(), b"x");
    }

    #[test]
    fn a_folder_without_a_record_is_refused_not_cleared_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in ["manifest.json", "hot_0010.npy"] {
            touch(&d.join(f));
        }
        let e = check(d, &RUN, true).unwrap_err().to_string();
        assert!(
            e.contains("no record") && e.contains("nothing is removed"),
            "{e}"
        );
        assert!(open(d, &RUN, true).is_err());
        assert_eq!(names(d), ["hot_0010.npy", "manifest.json"]);
    }

    #[test]
    fn default_folders_get_a_suffix_instead_of_being_shared() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("runs/hot-cold-7");
        let a = create_fresh(&base).unwrap();
        let b = create_fresh(&base).unwrap();
        assert_eq!(a, base);
        assert_eq!(b, dir.path().join("runs/hot-cold-7-2"));
    }

    #[test]
    fn another_commands_manifest_is_refused_even_with_overwrite() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("manifest.json"),
            r#"{"config": {"res": 10}}"#,
        )
        .unwrap();
        let e = check(dir.path(), &NOISE, true).unwrap_err().to_string();
        assert!(e.contains("did not write"), "{e}");
    }
}
