//! Helpers every application test shares: [`Sandbox`], a temporary folder
//! to run the `smokelab` binary in, with the checks every command-line test
//! makes (it succeeded; it failed with this exit code), and readers of what
//! runs write.
// Each test binary compiles this module and uses only part of it.
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run the `smokelab` binary with `args` in the folder `cwd`, with the
/// environment variables `env` set; whatever its outcome.
pub fn smokelab_with(env: &[(&str, &str)], args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(args)
        .envs(env.iter().copied())
        .current_dir(cwd)
        .output()
        .expect("run smokelab")
}

/// Run the `smokelab` binary with `args` in the folder `cwd`.
pub fn smokelab(args: &[&str], cwd: &Path) -> Output {
    smokelab_with(&[], args, cwd)
}

/// Check that `o` exited 0; the message names `args` and holds its stderr.
pub fn assert_ok(o: &Output, args: &[&str]) {
    assert!(
        o.status.success(),
        "{args:?}: exit {:?}, stderr {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Check that `o` exited with `code`; its stderr.
pub fn assert_exit(o: &Output, args: &[&str], code: i32) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "{args:?}: stderr {err}");
    err
}

/// A temporary folder to run `smokelab` in, removed when dropped.
pub struct Sandbox(tempfile::TempDir);

impl Sandbox {
    pub fn new() -> Self {
        Self(tempfile::tempdir().expect("a temporary folder"))
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        self.0.path()
    }

    /// `rel` inside the folder.
    pub fn join(&self, rel: impl AsRef<Path>) -> PathBuf {
        self.path().join(rel)
    }

    /// `smokelab args` in the folder, whatever its outcome.
    pub fn run(&self, args: &[&str]) -> Output {
        smokelab(args, self.path())
    }

    /// `smokelab args` in the folder, checked to succeed; its output.
    pub fn ok(&self, args: &[&str]) -> Output {
        let o = self.run(args);
        assert_ok(&o, args);
        o
    }

    /// `smokelab args` in the folder, checked to exit with `code` (2: bad
    /// input, 1: a run that failed); its stderr.
    pub fn fails(&self, args: &[&str], code: i32) -> String {
        assert_exit(&self.run(args), args, code)
    }

    /// `smokelab args` in the folder, checked to exit 2 (bad input) with a
    /// stderr that mentions every one of `needles`; its stderr.
    pub fn refused(&self, args: &[&str], needles: &[&str]) -> String {
        let err = self.fails(args, 2);
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err:?} does not mention {n:?}");
        }
        err
    }

    /// `smokelab run hot-cold` at 10³ for 4 frames, quietly, into `out`,
    /// with `extra` flags (e.g. `--save-every 2`), checked to succeed.
    pub fn small_hot_cold_run(&self, out: &str, extra: &[&str]) {
        let mut args = vec!["run", "hot-cold", "--res", "10", "--frames", "4"];
        args.extend_from_slice(&["--quiet", "--out", out]);
        args.extend_from_slice(extra);
        self.ok(&args);
    }

    /// The `manifest.json` of the folder `rel`.
    pub fn manifest(&self, rel: impl AsRef<Path>) -> serde_json::Value {
        manifest(&self.join(rel))
    }
}

/// The `manifest.json` of the folder `dir`.
pub fn manifest(dir: &Path) -> serde_json::Value {
    manifest_file(&dir.join("manifest.json"))
}

/// A manifest by its path (`render_0004.json`).
pub fn manifest_file(path: &Path) -> serde_json::Value {
    let text = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_slice(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A CSV file (plain numbers and names, no quoting) as rows of column → value.
pub fn table(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            cols.iter()
                .zip(l.split(','))
                .map(|(c, v)| (c.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

/// The number in column `col` of a [`table`] row.
pub fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    row[col].parse().unwrap()
}

/// Run experiment `id` at smoke size, quietly, into `dir/id`; its folder.
pub fn smoke_experiment(dir: &Path, id: &str) -> PathBuf {
    use smokelab_app::experiment::kit::{Context, Size};
    use smokelab_app::experiment::registry::find;
    let out = dir.join(id);
    let ctx = Context {
        out: out.clone(),
        size: Size::Smoke,
        progress: false,
        peers: None,
    };
    (find(id).unwrap().run)(&ctx).unwrap_or_else(|e| panic!("{id}: {e:#}"));
    out
}

/// FNV-1a 64 of `bytes`, the checkpoint's checksum.
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The checkpoint `file` with `edit` applied to its body and its checksum
/// recomputed: a file only its content can refuse.
pub fn reseal(file: &Path, edit: impl FnOnce(&mut Vec<u8>)) {
    let mut body = std::fs::read(file).unwrap();
    body.truncate(body.len() - 8);
    edit(&mut body);
    let hash = fnv(&body);
    body.extend(hash.to_le_bytes());
    std::fs::write(file, body).unwrap();
}
