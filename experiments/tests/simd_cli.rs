//! `SMOKELAB_SIMD`: every instruction set this CPU has runs the same
//! simulation to the same bytes and says so in the manifest; an unknown
//! or unavailable one is refused before any work (exit 2, one line naming
//! the valid values).

mod common;

use std::path::Path;

use common::{assert_exit, assert_ok, smokelab_with, Sandbox};
use smokelab::simd::{Isa, ENV};

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
    let sb = Sandbox::new();
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
            let o = smokelab_with(&[(ENV, isa.name())], &args, sb.path());
            assert_ok(&o, &args);
            assert_eq!(sb.manifest(&out)["machine"]["simd"], isa.name(), "{out}");
            let saved = files(&sb.join(&out));
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
    let sb = Sandbox::new();
    let args = [
        "run", "hot-cold", "--res", "8", "--frames", "1", "--quiet", "--out", "x",
    ];
    let mut cases = vec![("sse9", "valid values are scalar, neon, avx2 or avx512")];
    let unavailable = Isa::ALL.into_iter().find(|i| !i.is_available());
    if let Some(isa) = unavailable {
        cases.push((isa.name(), "this CPU cannot run"));
    }
    for (simd, needle) in cases {
        let o = smokelab_with(&[(ENV, simd)], &args, sb.path());
        let err = assert_exit(&o, &[simd], 2);
        assert_eq!(
            err.lines().filter(|l| !l.trim().is_empty()).count(),
            1,
            "{err}"
        );
        assert!(
            err.contains(needle) && err.contains("SMOKELAB_SIMD"),
            "{err}"
        );
        assert!(!sb.join("x").exists(), "{simd}: wrote output");
    }
}
