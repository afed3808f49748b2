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
    // Rebuild when the commit moves or any tracked source changes.
    for path in [
        ".git/HEAD",
        ".git/index",
        ".git/refs",
        "src",
        "experiments",
        "Cargo.toml",
    ] {
        println!("cargo:rerun-if-changed={path}");
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
