//! Records the git commit the library was built from, with `-dirty` when
//! tracked files differ from it, as `SMOKELAB_COMMIT` (read by
//! `io::manifest::BUILD_COMMIT`). Outside a git checkout it is `unknown`.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // Rebuild when the commit moves or any tracked source changes. The git
    // files are asked of git, so that a linked worktree (whose `.git` is a
    // file) names its own HEAD and index: a path that does not exist would
    // rerun this script, and rebuild the library, on every cargo command.
    for path in ["src", "experiments", "Cargo.toml"] {
        println!("cargo:rerun-if-changed={path}");
    }
    for name in ["HEAD", "index", "refs", "packed-refs"] {
        if let Some(path) = git(&["rev-parse", "--git-path", name]) {
            if std::path::Path::new(&path).exists() {
                println!("cargo:rerun-if-changed={path}");
            }
        }
    }
    let commit = match git(&["rev-parse", "HEAD"]) {
        Some(c) => match git(&["status", "--porcelain", "--untracked-files=no"]) {
            Some(s) if !s.is_empty() => format!("{c}-dirty"),
            _ => c,
        },
        None => "unknown".into(),
    };
    println!("cargo:rustc-env=SMOKELAB_COMMIT={commit}");
}
