//! How the gases' [`DensityState`]s are serialized (serde), for a
//! checkpoint: every state as itself, except the gridless histories'
//! velocity grids. Gases share those grids ([`Arc`]: one grid per step for
//! all gridless gases), so they are stored once, first, in order of first
//! use, and each history step names its grid by index:
//!
//! ```text
//! ( grids: [FaceGrid],
//!   gases: [(B, Gridded(ScalarGrid)
//!             | Gridless { steps: [(grid index, Δt, backtrace)], centres: ScalarGrid }
//!             | Selma(SelmaState))] )
//! ```
//!
//! Reading gives the steps naming one grid one shared [`Arc`] again.
//! `B` is what the caller pairs each state with (the simulation's mass
//! budget); use as `#[serde(with = "smokelab::density::stored")]` on a
//! `Vec<(B, DensityState)>`.

use std::borrow::Cow;
use std::sync::Arc;

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{DensityState, SelmaState};
use crate::advection::Backtrace;
use crate::grid::{FaceGrid, ScalarGrid};

/// The gases' states as stored: borrowed when written, owned when read.
#[derive(Serialize, Deserialize)]
struct Stored<'a, B: Clone> {
    /// The distinct gridless velocity grids, in order of first use.
    grids: Vec<Cow<'a, FaceGrid>>,
    gases: Vec<(Cow<'a, B>, StoredState<'a>)>,
}

/// One [`DensityState`] as stored.
#[derive(Serialize, Deserialize)]
enum StoredState<'a> {
    Gridded(Cow<'a, ScalarGrid>),
    Gridless {
        /// Per stored step: its velocity grid's index in `grids`, Δt and
        /// the backtrace.
        steps: Vec<(usize, f32, Backtrace)>,
        centres: Cow<'a, ScalarGrid>,
    },
    /// Boxed as [`DensityState::Selma`] is: the state is large.
    Selma(Box<Cow<'a, SelmaState>>),
}

/// Serialize `gases`, each shared gridless velocity grid once.
pub fn serialize<B, S>(gases: &[(B, DensityState)], s: S) -> Result<S::Ok, S::Error>
where
    B: Clone + Serialize,
    S: Serializer,
{
    let mut grids: Vec<&Arc<FaceGrid>> = Vec::new();
    let gases = (gases.iter())
        .map(|(b, state)| {
            let stored = match state {
                DensityState::Gridded(d) => StoredState::Gridded(Cow::Borrowed(d)),
                DensityState::Gridless { history, centres } => StoredState::Gridless {
                    steps: (history.iter())
                        .map(|(u, dt, bt)| (index_in(&mut grids, u), *dt, *bt))
                        .collect(),
                    centres: Cow::Borrowed(centres),
                },
                DensityState::Selma(s) => StoredState::Selma(Box::new(Cow::Borrowed(&**s))),
            };
            (Cow::Borrowed(b), stored)
        })
        .collect();
    let grids = grids.into_iter().map(|g| Cow::Borrowed(&**g)).collect();
    Stored { grids, gases }.serialize(s)
}

/// `grid`'s index in `grids`, where it is appended if it is not there yet.
fn index_in<'a>(grids: &mut Vec<&'a Arc<FaceGrid>>, grid: &'a Arc<FaceGrid>) -> usize {
    match grids.iter().position(|g| Arc::ptr_eq(g, grid)) {
        Some(k) => k,
        None => {
            grids.push(grid);
            grids.len() - 1
        }
    }
}

/// Read what [`serialize`] wrote.
///
/// # Errors
/// If a history step names a grid that is not stored.
pub fn deserialize<'de, B, D>(de: D) -> Result<Vec<(B, DensityState)>, D::Error>
where
    B: Clone + Deserialize<'de>,
    D: Deserializer<'de>,
{
    let Stored { grids, gases } = Stored::<B>::deserialize(de)?;
    let grids: Vec<Arc<FaceGrid>> = grids
        .into_iter()
        .map(|g| Arc::new(g.into_owned()))
        .collect();
    let grid = |k: usize| {
        grids.get(k).map(Arc::clone).ok_or_else(|| {
            D::Error::custom(format!(
                "a gridless step names velocity grid {k} of the {} stored",
                grids.len()
            ))
        })
    };
    (gases.into_iter())
        .map(|(b, stored)| {
            let state = match stored {
                StoredState::Gridded(d) => DensityState::Gridded(d.into_owned()),
                StoredState::Gridless { steps, centres } => DensityState::Gridless {
                    history: (steps.into_iter())
                        .map(|(k, dt, bt)| Ok((grid(k)?, dt, bt)))
                        .collect::<Result<_, D::Error>>()?,
                    centres: centres.into_owned(),
                },
                StoredState::Selma(s) => DensityState::Selma(Box::new((*s).into_owned())),
            };
            Ok((b.into_owned(), state))
        })
        .collect()
}
