//! Per-stage wall-clock timers and the process's peak memory.

use std::time::Instant;

use serde::Serialize;

/// Seconds spent in each stage of one time step, in the step's order
/// ([`crate::simulation::Simulation::try_step`]), then the run's own.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StageTimes {
    /// Advection of densities and velocity.
    pub advect: f64,
    /// Injecting the sources (with a gridded gas's totals, summed in the
    /// same pass).
    pub inject: f64,
    /// Evaluating gridless/SELMA densities at the cell centres for buoyancy.
    pub density: f64,
    /// Buoyancy.
    pub force: f64,
    /// FFT projection (and viscosity).
    pub project: f64,
    /// Obstacles: the dry cells cleared and the velocity's closed faces
    /// (eqs 6.6–6.7, or the exact method's wall extension).
    pub boundary: f64,
    /// Writing volumes, previews and metrics.
    pub output: f64,
    /// The run's measures: the per-step ones and, on their cadence, the fine
    /// ones (densities at 2×, spectra, the interpolant's divergence).
    pub metrics: f64,
}

impl StageTimes {
    /// Sum over stages.
    pub fn total(&self) -> f64 {
        self.advect
            + self.inject
            + self.density
            + self.force
            + self.project
            + self.boundary
            + self.output
            + self.metrics
    }
}

impl std::ops::AddAssign for StageTimes {
    /// Add `other`'s seconds stage by stage.
    fn add_assign(&mut self, other: Self) {
        self.advect += other.advect;
        self.inject += other.inject;
        self.density += other.density;
        self.force += other.force;
        self.project += other.project;
        self.boundary += other.boundary;
        self.output += other.output;
        self.metrics += other.metrics;
    }
}

/// Run `f`, add its wall time in seconds to `slot`, return its result.
pub fn timed<T>(slot: &mut f64, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let r = f();
    *slot += t.elapsed().as_secs_f64();
    r
}

/// Peak resident set size of this process in bytes (`VmHWM`), if the OS says.
pub fn peak_rss_bytes() -> Option<u64> {
    proc_status_kib("VmHWM:").map(|k| k * 1024)
}

/// Memory the OS reports as available for new allocations, in bytes.
pub fn available_memory_bytes() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = s.lines().find(|l| l.starts_with("MemAvailable:"))?;
    line.split_whitespace()
        .nth(1)?
        .parse::<u64>()
        .ok()
        .map(|k| k * 1024)
}

fn proc_status_kib(key: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Most worker threads a run may ask for per logical core: beyond a few per
/// core, more threads only cost memory and start-up time.
pub const MAX_THREADS_PER_CORE: usize = 4;

/// Check a requested worker-thread count against this machine: at least 1
/// and at most [`MAX_THREADS_PER_CORE`] per logical core (a count of 100000
/// used to hang spawning threads).
pub fn check_threads(threads: usize) -> Result<(), crate::error::InputError> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = MAX_THREADS_PER_CORE * cores;
    if (1..=max).contains(&threads) {
        Ok(())
    } else {
        Err(crate::error::InputError::new(format!(
            "threads is {threads}; it must be between 1 and {max} ({MAX_THREADS_PER_CORE} per logical core, {cores} here)"
        )))
    }
}
