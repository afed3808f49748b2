//! Helpers every application test shares.

use std::path::Path;
use std::process::{Command, Output};

/// Run the `smokelab` binary with `args` in the folder `cwd`.
pub fn smokelab(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run smokelab")
}

/// Run `smokelab run hot-cold` at 10³ for 4 frames, quietly, into `cwd/out`,
/// with `extra` flags (e.g. `--save-every 2`), and check that it succeeded.
// Each test binary compiles this module; not every one runs a scenario.
#[allow(dead_code)]
pub fn small_hot_cold_run(cwd: &Path, out: &str, extra: &[&str]) {
    let mut args = vec!["run", "hot-cold", "--res", "10", "--frames", "4"];
    args.extend_from_slice(&["--quiet", "--out", out]);
    args.extend_from_slice(extra);
    let o = smokelab(&args, cwd);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A CSV file (plain numbers and names, no quoting) as rows of column → value.
#[allow(dead_code)]
pub fn table(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
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
#[allow(dead_code)]
pub fn num(row: &std::collections::HashMap<String, String>, col: &str) -> f64 {
    row[col].parse().unwrap()
}

/// Run experiment `id` at smoke size, quietly, into `dir/id`; its folder.
#[allow(dead_code)]
pub fn smoke_experiment(dir: &Path, id: &str) -> std::path::PathBuf {
    use smokelab_app::registry::{find, Context, Size};
    let out = dir.join(id);
    let ctx = Context {
        out: out.clone(),
        size: Size::Smoke,
        progress: false,
    };
    (find(id).unwrap().run)(&ctx).unwrap_or_else(|e| panic!("{id}: {e:#}"));
    out
}
