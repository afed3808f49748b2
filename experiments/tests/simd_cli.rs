//! `SMOKELAB_SIMD`: every instruction set this CPU has runs the same
//! simulation to the same bytes and says so in the manifest; an unknown
//! or unavailable one is refused before any work (exit 2, one line naming
//! the valid values).

use std::path::Path;
use std::process::{Command, Output};

use smokelab::simd::Isa;

/// `smokelab args` in `cwd` with `SMOKELAB_SIMD=simd`.
fn smokelab_on(simd: &str, args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(args)
        .env("SMOKELAB_SIMD", simd)
        .current_dir(cwd)
        .output()
        .expect("run smokelab")
}

/// Every file under `dir` (relative path, bytes), sorted, but the manifest.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = vec![];
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else if p.extension().is_some_and(|x| x == "npy") {
                let rel = p.strip_prefix(dir).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn every_available_instruction_set_writes_the_same_fields_and_records_itself() {
    let dir = tempfile::tempdir().unwrap();
    let mut runs = vec![];
    for isa in Isa::available() {
        for (bt, kind) in [("rk2", "periodic"), ("rk3", "closed")] {
            let out = format!("{isa}-{bt}");
            let args = [
                "run",
                "hot-cold",
                "--res",
                "12",
                "--frames",
                "4",
                "--save-every",
                "2",
                "--backtrace",
                bt,
                "--box",
                kind,
                "--quiet",
                "--out",
                &out,
            ];
            let o = smokelab_on(isa.name(), &args, dir.path());
            assert!(
                o.status.success(),
                "{isa}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let manifest: serde_json::Value = serde_json::from_slice(
                &std::fs::read(dir.path().join(&out).join("manifest.json")).unwrap(),
            )
            .unwrap();
            assert_eq!(manifest["machine"]["simd"], isa.name(), "{out}");
            let saved = files(&dir.path().join(&out));
            assert!(!saved.is_empty(), "{out}: no fields saved");
            runs.push((isa, bt, saved));
        }
    }
    for (isa, bt, saved) in &runs {
        let (first, _, want) = runs.iter().find(|r| r.1 == *bt).unwrap();
        assert!(saved == want, "{bt}: {isa}'s fields differ from {first}'s");
    }
}

#[test]
fn an_unknown_or_unavailable_instruction_set_is_refused_with_the_valid_ones() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "run", "hot-cold", "--res", "8", "--frames", "1", "--quiet", "--out", "x",
    ];
    let mut cases = vec![("sse9", "valid values are scalar, neon, avx2 or avx512")];
    let unavailable = Isa::ALL.into_iter().find(|i| !i.is_available());
    if let Some(isa) = unavailable {
        cases.push((isa.name(), "this CPU cannot run"));
    }
    for (simd, needle) in cases {
        let o = smokelab_on(simd, &args, dir.path());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{simd}: {err}");
        assert_eq!(
            err.lines().filter(|l| !l.trim().is_empty()).count(),
            1,
            "{err}"
        );
        assert!(
            err.contains(needle) && err.contains("SMOKELAB_SIMD"),
            "{err}"
        );
        assert!(!dir.path().join("x").exists(), "{simd}: wrote output");
    }
}
