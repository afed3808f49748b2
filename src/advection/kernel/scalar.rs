//! The kernel in one lane of plain `f32` arithmetic: runs on any CPU, and
//! is the reference the vector widths are tested against.

/// Lanes per vector.
const W: usize = 1;
/// Whether the grid sweeps take two groups at a time, their chains
/// interleaved.
const PAIRS: bool = false;
type F = f32;
type I = i32;
type M = bool;

#[inline(always)]
fn splat(x: f32) -> F {
    x
}
#[inline(always)]
fn iota() -> F {
    0.0
}
#[inline(always)]
fn add(a: F, b: F) -> F {
    a + b
}
#[inline(always)]
fn sub(a: F, b: F) -> F {
    a - b
}
#[inline(always)]
fn mul(a: F, b: F) -> F {
    a * b
}
#[inline(always)]
fn div(a: F, b: F) -> F {
    a / b
}
#[inline(always)]
fn load(s: &[f32]) -> F {
    s[0]
}
#[inline(always)]
fn store(s: &mut [f32], v: F) {
    s[0] = v;
}
#[inline(always)]
fn lt(a: F, b: F) -> M {
    a < b
}
#[inline(always)]
fn gt(a: F, b: F) -> M {
    a > b
}
#[inline(always)]
fn ge(a: F, b: F) -> M {
    a >= b
}
#[inline(always)]
fn nan(a: F) -> M {
    a.is_nan()
}
#[inline(always)]
fn sel(m: M, a: F, b: F) -> F {
    if m {
        a
    } else {
        b
    }
}
/// Toward zero, saturating (the lanes where it saturates are left to the
/// reference by `axis`, as x86's out-of-range value is).
#[inline(always)]
fn trunc(a: F) -> I {
    a as i32
}
#[inline(always)]
fn itof(a: I) -> F {
    a as f32
}
/// `⌊g⌋` (the truncation, less one where it rounded up) and `g − ⌊g⌋`.
#[inline(always)]
fn floor(g: F) -> (I, F) {
    let t = trunc(g);
    let f = isel(gt(itof(t), g), isub(t, isplat(1)), t);
    (f, sub(g, itof(f)))
}
#[inline(always)]
fn isplat(x: i32) -> I {
    x
}
#[inline(always)]
fn iadd(a: I, b: I) -> I {
    a.wrapping_add(b)
}
#[inline(always)]
fn isub(a: I, b: I) -> I {
    a.wrapping_sub(b)
}
#[inline(always)]
fn imul(a: I, b: I) -> I {
    a.wrapping_mul(b)
}
#[inline(always)]
fn ilt(a: I, b: I) -> M {
    a < b
}
#[inline(always)]
fn igt(a: I, b: I) -> M {
    a > b
}
#[inline(always)]
fn ieq(a: I, b: I) -> M {
    a == b
}
#[inline(always)]
fn isel(m: M, a: I, b: I) -> I {
    if m {
        a
    } else {
        b
    }
}
#[inline(always)]
fn imin(a: I, b: I) -> I {
    a.min(b)
}
#[inline(always)]
fn ule(a: I, b: I) -> M {
    (a as u32) <= (b as u32)
}
#[inline(always)]
fn and(a: M, b: M) -> M {
    a & b
}
#[inline(always)]
fn or(a: M, b: M) -> M {
    a | b
}
#[inline(always)]
fn none() -> M {
    false
}
#[inline(always)]
fn bits(m: M) -> u32 {
    u32::from(m)
}

/// Nothing to plan: every corner is loaded.
type Plan = ();

#[inline(always)]
fn plan(_: usize, _: [I; 4], _: [I; 2], _: Option<[i32; 4]>) -> Plan {}

/// The corners `data[rows[r] + x[c]]`, by plain (checked) loads.
#[inline(always)]
fn fetch(data: &[f32], _: Plan, rows: [I; 4], x: [I; 2]) -> [[F; 2]; 4] {
    let at = |r: I, x: I| data[(r + x) as usize];
    rows.map(|r| [at(r, x[0]), at(r, x[1])])
}

kernel!();
