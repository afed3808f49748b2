//! How the staggered (MAC) velocity is read between its faces: the
//! interpolant every trace that follows the velocity goes through
//! (semi-Lagrangian, MacCormack and BFECC backtraces, gridless walks, SELMA
//! maps, the velocity as a field).
//!
//! - [`Interpolant::Trilinear`]: each component trilinear on its own
//!   lattice. Smooth across cells, but its divergence is zero only at the
//!   cell centres of a projected velocity, not between them.
//! - [`Interpolant::Rt0`]: the lowest-order Raviart–Thomas interpolant
//!   (Raviart & Thomas 1977; the velocity of Pollock's particle tracking,
//!   Pollock 1988, *Ground Water* 26(6)). Inside the cell containing the
//!   point, component `a` is linear along its own axis between the cell's
//!   two `a`-faces and constant across:
//!
//!   ```text
//!   u_a(x) = (1 − t) u_a[c] + t u_a[c + e_a],   t = (x_a − x_{c−½e_a}) / Δx
//!   ```
//!
//!   so `∂u_a/∂x_a = (u_a[c + e_a] − u_a[c]) / Δx` and the divergence
//!   inside every cell is exactly its compact divergence `D u` (zero to
//!   round-off after the projection). The normal component is continuous
//!   across every face (it is the face's value there), so no walk crosses
//!   a face of zero flux: a closed box's walls or an obstacle's closed faces.
//!   The tangential components jump between cells; the interpolant is first
//!   order. It reproduces exactly any field whose component `a` is linear in
//!   `x_a` and independent of the other coordinates — uniform flows and
//!   `(αx, βy, γz)` with `α + β + γ = 0` among the divergence-free ones —
//!   but not a rotation or a shear (trilinear reproduces every field linear
//!   in each coordinate).
//!
//! In the lattice coordinates of [`super::face`] the RT0 value is the
//! trilinear stencil at the point with every coordinate across the
//! component's own axis moved to the centre of the cell holding it
//! ([`cell_centre`]): the weights across are then `1` and `0` exactly,
//! so both interpolants share one stencil and, in the semi-Lagrangian
//! kernel's lanes, one fetch.

use serde::{Deserialize, Serialize};

/// How the MAC velocity is interpolated between its faces (module
/// documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Interpolant {
    /// Each component trilinear on its own face lattice.
    #[default]
    Trilinear,
    /// Lowest-order Raviart–Thomas (Pollock): linear along each
    /// component's own axis inside a cell, constant across; pointwise
    /// divergence-free for a projected velocity.
    #[serde(alias = "pollock")]
    #[cfg_attr(feature = "clap", value(alias = "pollock"))]
    Rt0,
}

impl Interpolant {
    /// Every interpolant, in a fixed order (for tests and sweeps).
    pub const ALL: [Interpolant; 2] = [Interpolant::Trilinear, Interpolant::Rt0];

    /// Lower-case name, as serialised.
    pub fn name(self) -> &'static str {
        match self {
            Interpolant::Trilinear => "trilinear",
            Interpolant::Rt0 => "rt0",
        }
    }
}

impl std::fmt::Display for Interpolant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Beyond this magnitude every `f32` is an integer (2²³), so
/// [`cell_centre`] leaves it as it is.
pub(crate) const INTEGER_ABOVE: f32 = 8_388_608.0;

/// The centre of the cell holding cell-centre grid coordinate `g` along one
/// axis, `⌊g + ½⌋`: the truncation of `g + ½` less one where it rounded up,
/// for `|g + ½| < 2²³`; `g + ½` itself beyond (already an integer) and for
/// NaN (kept NaN). The semi-Lagrangian kernel's lanes do these operations
/// in this order, so every instruction set gives these bits.
#[inline(always)]
pub(crate) fn cell_centre(g: f32) -> f32 {
    let s = g + 0.5;
    if s < INTEGER_ABOVE && s > -INTEGER_ABOVE {
        let t = s as i32;
        let f = if (t as f32) > s { t - 1 } else { t };
        f as f32
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_centre_is_the_nearest_integer_rounding_halves_up() {
        for (g, want) in [
            (0.0f32, 0.0f32),
            (0.49, 0.0),
            (0.5, 1.0),
            (-0.5, 0.0),
            (-0.51, -1.0),
            (-3.7, -4.0),
            (12.2, 12.0),
            (1e7, 1e7),
            (-1e9, -1e9),
        ] {
            assert_eq!(cell_centre(g), want, "{g}");
        }
        assert!(cell_centre(f32::NAN).is_nan());
        assert_eq!(cell_centre(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn names_round_trip_and_pollock_is_an_alias() {
        for i in Interpolant::ALL {
            let s = serde_json::to_string(&i).unwrap();
            assert_eq!(s, format!("\"{}\"", i.name()));
            assert_eq!(serde_json::from_str::<Interpolant>(&s).unwrap(), i);
        }
        let p: Interpolant = serde_json::from_str("\"pollock\"").unwrap();
        assert_eq!(p, Interpolant::Rt0);
    }
}
