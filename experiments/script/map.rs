//! SELMA's gridded map (ch. 8): the notes' `XmapCache`, as the script's
//! `mapcache`.
//!
//! The backward map `X(x)` of eq 8.7 is the identity plus a displacement,
//! and the identity is not periodic; a `mapcache` stores the
//! **displacement** `D = X − x` at the cell centres, which is periodic and
//! smooth, so its trilinear interpolation across the box's seam is exact —
//! the storage `smokelab::density::selma` chose. The script's verbs:
//!
//! - `advect(map, velocity, dt)` — eq 8.8, `X_n(x) = X_{n−1}(B_n(x))`, on the
//!   displacement: `D_n(x) = (B_n(x) − x) + D_{n−1}(B_n(x))`, with `B_n` the
//!   departure points of the step (shared with the caches' `advect`,
//!   [`super::functions::with_departures`]) — the arithmetic of `Selma`'s map
//!   step on the velocity grid;
//! - `cacheread(map)` — the vectorfield `X(x) = x + D(x)`, wrapped into the
//!   box, for `compose(reference, X)` (eq 8.7);
//! - `deformation(map)` — `max |D(x + h e_a) − D(x)| / h` over cells and
//!   axes: in cells, how far neighbouring map samples have moved relative to
//!   each other, `|X(x + h e_a) − X(x) − h e_a| / h` — the form of
//!   `Selma::lattice_deformation`, measured on the backward map instead of
//!   the library's forward-tracked lattice.

use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use rhai::{Engine, FLOAT};
use smokelab::domain::Domain;
use smokelab::field::VectorField;
use smokelab::grid::{BoxKind, FaceGrid, VectorGrid};

use super::functions::with_departures;
use super::types::{Fallible, Region, VectorCache, VectorF};

/// The notes' `XmapCache`: the displacement `D = X − x` at the cell centres.
#[derive(Clone)]
pub struct MapCache(pub Arc<VectorGrid>);

impl MapCache {
    /// The identity map (`D = 0`) on `domain`.
    pub fn identity(domain: Domain) -> Self {
        Self(Arc::new(VectorGrid::zeros(domain)))
    }

    /// Eq 8.8 through the velocity `u` over `dt`, on the velocity's grid.
    ///
    /// # Panics
    /// If the map is not on `u`'s domain (checked by the caller).
    pub fn advect(&self, u: &Arc<FaceGrid>, dt: f32) -> Self {
        let md = *self.0.domain();
        let old = &*self.0;
        let mut out = VectorGrid::zeros(md);
        with_departures(u, dt, |dep| {
            out.as_vec3_mut()
                .par_iter_mut()
                .zip(dep.points().par_iter())
                .enumerate()
                .for_each(|(n, (o, &g))| {
                    let [nx, ny, _] = md.dims;
                    let c = Vec3::new(
                        (n % nx) as f32,
                        ((n / nx) % ny) as f32,
                        (n / (nx * ny)) as f32,
                    );
                    *o = (g - c) * md.cell + old.sample_grid_coords(g);
                });
        });
        Self(Arc::new(out))
    }

    /// `max |D(x + h e_a) − D(x)| / h`, in cells.
    pub fn deformation(&self) -> f32 {
        let md = *self.0.domain();
        let [nx, ny, nz] = md.dims;
        let d = self.0.as_vec3();
        (0..nz)
            .into_par_iter()
            .map(|k| {
                let mut m = 0.0f32;
                for j in 0..ny {
                    for i in 0..nx {
                        let p = d[md.index(i, j, k)];
                        for q in [
                            d[md.index((i + 1) % nx, j, k)],
                            d[md.index(i, (j + 1) % ny, k)],
                            d[md.index(i, j, (k + 1) % nz)],
                        ] {
                            m = m.max((q - p).length());
                        }
                    }
                }
                m / md.cell
            })
            .reduce(|| 0.0, f32::max)
    }
}

/// `x ↦ x + D(x)` wrapped into the box: the map a `mapcache` holds, as a field.
pub struct MapField(pub Arc<VectorGrid>);

/// `x` wrapped into `[origin, origin + size)` along each axis.
fn wrap_world(d: &Domain, p: Vec3) -> Vec3 {
    let (o, s) = (d.origin, d.size());
    let w = (p - o).rem_euclid(s);
    // `rem_euclid` of a tiny negative number rounds to `s` itself.
    o + Vec3::select(w.cmpge(s), Vec3::ZERO, w)
}

impl VectorField for MapField {
    fn eval(&self, p: Vec3) -> Vec3 {
        let d = self.0.domain();
        wrap_world(d, p + self.0.sample_grid_coords(d.grid_coords(p)))
    }
}

/// Register `mapcache`, its `advect`, `cacheread` and `deformation`.
pub fn register(engine: &mut Engine) {
    engine.register_type_with_name::<MapCache>("mapcache");
    engine.register_fn("mapcache", |r: Region| -> Fallible<MapCache> {
        if r.kind != BoxKind::Periodic {
            return Err("mapcache: SELMA's map is periodic; the region is a closed box".into());
        }
        Ok(MapCache::identity(r.domain))
    });
    engine.register_fn(
        "advect",
        |m: MapCache, u: VectorCache, dt: FLOAT| -> Fallible<MapCache> {
            if m.0.domain() != u.0.domain() {
                return Err(
                    "advect: the mapcache and the velocity are on different domains".into(),
                );
            }
            Ok(m.advect(&u.0, super::types::time_step("advect", dt)?))
        },
    );
    engine.register_fn("cacheread", |m: MapCache| VectorF(Arc::new(MapField(m.0))));
    engine.register_fn("deformation", |m: MapCache| m.deformation() as FLOAT);
}
