//! The names in a sweep's folder that every executor and reader shares.

/// The index file in a sweep's folder.
pub const INDEX: &str = "sweep.json";

/// The folder of the points' logs (and of `run-point`'s failure records).
pub const LOGS: &str = "logs";
