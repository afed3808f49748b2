//! The checkpoint file (`checkpoint.bin`, format 3): a simulation's state
//! written and read back steps on bit for bit as the simulation it came
//! from, in every density mode, with and without obstacles; the gridless
//! velocity grids the gases share are stored once; a file of another
//! format, truncated or corrupt is refused with one line naming the
//! problem, never a panic.

mod common;

use std::path::Path;

use common::reseal;
use smokelab::advection::Scheme;
use smokelab::boundary::ObstacleMethod;
use smokelab::density::{DensityMode, DensityState};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::slab_box::SlabBoxConfig;
use smokelab::scenario::{Scenario, ScenarioKind, SolverConfig};
use smokelab::simulation::Simulation;
use smokelab_app::run::checkpoint::{self, Checkpoint, RunRecord, FORMAT};

/// Steps taken before the checkpoint (hot/cold's SELMA map has re-anchored
/// once by then).
const BEFORE: usize = 4;

/// The run record of a checkpoint of `config`.
fn record<C: Scenario>(config: &C, scenario: ScenarioKind) -> RunRecord {
    RunRecord {
        scenario,
        config: toml::to_string(config).unwrap(),
        checkpoint_every: 1,
        vdb: false,
        vdb_frames: Default::default(),
        paraview: false,
        render: None,
    }
}

/// The solver of the cases at 16³ in `mode` (SELMA re-anchoring often, so
/// that the checkpoint holds a re-anchored map).
fn solver(mode: DensityMode) -> SolverConfig {
    let mut s = SolverConfig {
        res: 16,
        density: mode,
        ..SolverConfig::default()
    };
    if mode == DensityMode::Selma {
        s.selma_remap = 0.0005;
    }
    s
}

/// A named simulation, built afresh by its function, and its run record.
type Case = (String, Box<dyn Fn() -> Simulation>, RunRecord);

/// The cases of `mode`: hot/cold (two gases, periodic), and the slab box
/// with the exact obstacles and QUICK (the solves' warm starts) and with
/// the notes' rule and semi-Lagrangian advection.
fn cases(mode: DensityMode) -> Vec<Case> {
    let hot_cold = HotColdConfig {
        solver: solver(mode),
        ..Default::default()
    };
    let mut out: Vec<Case> = vec![(
        format!("hot-cold {mode}"),
        Box::new({
            let c = hot_cold.clone();
            move || c.build().unwrap()
        }),
        record(&hot_cold, ScenarioKind::HotCold),
    )];
    for (method, advection) in [
        (ObstacleMethod::Exact, Scheme::Quick),
        (ObstacleMethod::Notes, Scheme::Sl),
    ] {
        let slab = SlabBoxConfig {
            solver: SolverConfig {
                res: 32,
                advection,
                ..solver(mode)
            },
            obstacles: method,
            ..Default::default()
        };
        out.push((
            format!("slab-box {mode} {method:?} {advection:?}"),
            Box::new({
                let c = slab.clone();
                move || c.build().unwrap()
            }),
            record(&slab, ScenarioKind::SlabBox),
        ));
    }
    out
}

/// The first case of `mode` (hot/cold) after [`BEFORE`] steps, and its record.
fn hot_cold_stepped(mode: DensityMode) -> (Simulation, RunRecord) {
    let (_, build, record) = cases(mode).remove(0);
    let mut sim = build();
    for _ in 0..BEFORE {
        sim.try_step().unwrap();
    }
    (sim, record)
}

/// `sim`'s state as bytes: equal bytes, equal state to the bit.
fn state_bytes(sim: &Simulation) -> Vec<u8> {
    postcard::to_stdvec(&sim.state()).unwrap()
}

#[test]
fn a_state_read_back_steps_on_bitwise_in_every_mode() {
    for mode in DensityMode::ALL {
        for (name, build, record) in cases(mode) {
            let mut sim = build();
            for _ in 0..BEFORE {
                sim.try_step().unwrap();
            }
            if name == "hot-cold selma" {
                for (_, d) in &sim.state().gases {
                    let restarts = matches!(d, DensityState::Selma(s) if s.restarts > 0);
                    assert!(restarts, "{name}: the map should have re-anchored");
                }
            }
            let dir = tempfile::tempdir().unwrap();
            checkpoint::write(dir.path(), &sim, &record).unwrap();
            let read = Checkpoint::read(dir.path()).unwrap();
            assert_eq!((read.step(), read.run()), (BEFORE, &record), "{name}");
            let mut resumed = build();
            resumed.restore(read.into_state()).unwrap();
            assert!(
                state_bytes(&resumed) == state_bytes(&sim),
                "{name}: restored"
            );
            sim.try_step().unwrap();
            resumed.try_step().unwrap();
            sim.evaluate_densities();
            resumed.evaluate_densities();
            assert!(
                state_bytes(&resumed) == state_bytes(&sim),
                "{name}: one step on"
            );
            for (a, b) in sim.gases.iter().zip(&resumed.gases) {
                assert!(a.density().as_slice() == b.density().as_slice(), "{name}");
            }
        }
    }
}

/// Two gridless gases after `BEFORE` steps share one velocity grid per
/// step: the file holds `BEFORE` history grids, not twice as many, and
/// every array as 4 bytes a value (the measured overhead: the header, the
/// lengths and the small fields, under 4 KiB).
#[test]
fn shared_gridless_grids_are_stored_once() {
    let (sim, record) = hot_cold_stepped(DensityMode::Gridless);
    let dir = tempfile::tempdir().unwrap();
    checkpoint::write(dir.path(), &sim, &record).unwrap();
    let size = std::fs::metadata(dir.path().join(checkpoint::FILE))
        .unwrap()
        .len() as usize;
    let cells = 16 * 16 * 16;
    // The velocity and BEFORE history grids (3 components each), and the
    // two gases' cell-centre caches.
    let arrays = 4 * (3 * cells * (1 + BEFORE) + 2 * cells);
    assert!(
        (arrays..arrays + 4096).contains(&size),
        "{size} bytes for {arrays} bytes of arrays"
    );
}

/// Where the state starts in a checkpoint's bytes: after the name, the
/// format, the header's size and the header.
fn state_start(bytes: &[u8]) -> usize {
    20 + u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize
}

#[test]
fn other_formats_and_truncated_or_corrupt_files_are_refused() {
    let (sim, record) = hot_cold_stepped(DensityMode::Gridded);
    let good = tempfile::tempdir().unwrap();
    checkpoint::write(good.path(), &sim, &record).unwrap();
    let original = std::fs::read(good.path().join(checkpoint::FILE)).unwrap();
    let start = state_start(&original);
    // `edit` applied to a copy of the good file; reading it fails with one
    // line containing each of `what`.
    let refused = |edit: &dyn Fn(&Path), what: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join(checkpoint::FILE);
        std::fs::write(&file, &original).unwrap();
        edit(&file);
        let err = Checkpoint::read(dir.path())
            .err()
            .expect("refused")
            .to_string();
        assert_eq!(err.lines().count(), 1, "{err}");
        for w in what {
            assert!(err.contains(w), "{err:?} lacks {w:?}");
        }
    };
    let previous = FORMAT - 1;
    refused(
        &|f| reseal(f, |b| b[8..12].copy_from_slice(&previous.to_le_bytes())),
        &[
            &format!("checkpoint format {previous}"),
            &format!("reads format {FORMAT}"),
        ],
    );
    // Cut anywhere: in the name, the preamble, the header, the state.
    for cut in [
        0,
        5,
        8,
        19,
        27,
        start / 2,
        start + 3,
        original.len() / 2,
        original.len() - 1,
    ] {
        let truncate = |f: &Path| std::fs::write(f, &original[..cut]).unwrap();
        refused(&truncate, &["truncated"]);
    }
    refused(
        &|f| std::fs::write(f, b"P6 not a checkpoint").unwrap(),
        &["not a smokelab checkpoint"],
    );
    let mut flipped = original.clone();
    flipped[start + 100] ^= 0x10;
    refused(
        &|f| std::fs::write(f, &flipped).unwrap(),
        &["truncated or corrupt", "checksum"],
    );
    // Checksums that match bodies a checksum cannot catch.
    refused(
        &|f| reseal(f, |b| b.truncate(start + 1000)),
        &["corrupt (state"],
    );
    refused(&|f| reseal(f, |b| b.push(0)), &["bytes after its state"]);
    // The step (its first byte) one more than the header's.
    refused(&|f| reseal(f, |b| b[start] += 1), &["differ in step"]);
    // The velocity's x cell count (after the step and the domain's origin
    // and cell size, 16 bytes) 17: its arrays no longer fit it.
    refused(&|f| reseal(f, |b| b[start + 17] += 1), &["corrupt (state"]);
}
