//! Outputs are bitwise identical across thread counts, in every density
//! mode.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::smokelab;

/// Every `.npy` file in `dir`, by name.
fn volumes(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "npy"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect()
}

/// `run hot-cold --res 16 --frames 4` in density mode `mode` on one thread
/// and on two writes the same `.npy` files, byte for byte.
fn assert_thread_count_does_not_change_the_volumes(mode: &str) {
    let dir = tempfile::tempdir().unwrap();
    let run = |threads: &str| {
        let out = format!("{mode}-{threads}");
        let o = smokelab(
            &[
                "run",
                "hot-cold",
                "--density",
                mode,
                "--res",
                "16",
                "--frames",
                "4",
                "--save-every",
                "2",
                "--threads",
                threads,
                "--quiet",
                "--out",
                &out,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let folder = dir.path().join(out);
        let manifest: serde_json::Value =
            serde_json::from_slice(&std::fs::read(folder.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(
            manifest["machine"]["threads"].to_string(),
            threads,
            "{mode}: the run did not use {threads} threads"
        );
        volumes(&folder)
    };
    let (one, two) = (run("1"), run("2"));
    assert!(
        one.contains_key("hot_0004.npy") && one.contains_key("vel_0004.npy"),
        "{mode}: {:?}",
        one.keys()
    );
    assert_eq!(
        one.keys().collect::<Vec<_>>(),
        two.keys().collect::<Vec<_>>(),
        "{mode}"
    );
    for (name, bytes) in &one {
        assert!(
            bytes == &two[name],
            "{mode}: {name} differs between 1 and 2 threads"
        );
    }
}

#[test]
fn every_density_mode_writes_the_same_volumes_on_one_and_two_threads() {
    for mode in smokelab::density::DensityMode::ALL {
        assert_thread_count_does_not_change_the_volumes(mode.name());
    }
}
