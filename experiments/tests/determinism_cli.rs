//! Outputs are bitwise identical across thread counts, in every density
//! mode.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::Sandbox;
use smokelab::density::DensityMode;

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
fn assert_thread_count_does_not_change_the_volumes(mode: DensityMode) {
    let mode = mode.name();
    let sb = Sandbox::new();
    let run = |threads: &str| {
        let out = format!("{mode}-{threads}");
        sb.ok(&[
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
        ]);
        let folder = sb.join(out);
        assert_eq!(
            common::manifest(&folder)["machine"]["threads"].to_string(),
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
    for mode in DensityMode::ALL {
        assert_thread_count_does_not_change_the_volumes(mode);
    }
}
