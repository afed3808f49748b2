//! Memory measured, not counted: the peak a piece of work adds to the heap
//! and to the process's resident set.
//!
//! - **Heap**: every binary linking this crate allocates through
//!   [`Counting`], the system allocator with two counters — live bytes and
//!   their high-water mark. [`measure`] resets the mark to the live bytes,
//!   runs the work and reports `peak − live before`: the most the work held
//!   at once, from every thread (the render's workers included).
//! - **RSS**: on Linux, writing `5` to `/proc/self/clear_refs` resets the
//!   resident-set high-water mark `VmHWM` of `/proc/self/status` to the
//!   current `VmRSS`; [`measure`] reports `VmHWM after − VmRSS before`,
//!   after `malloc_trim` has returned the heap's free pages (glibc). It
//!   sees pages, not bytes, and the allocator's arenas: at small sizes it
//!   is coarse. `None` where `/proc` cannot be used.
//!
//! Both are process-wide: work running concurrently on other threads of the
//! same process (another test, say) is measured too. Callers that assert
//! on them run alone in their process.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The system allocator, counting live bytes and their high-water mark.
pub struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

impl Counting {
    fn grew(by: usize) {
        let now = LIVE.fetch_add(by, Ordering::Relaxed) + by;
        PEAK.fetch_max(now, Ordering::Relaxed);
    }

    fn shrank(by: usize) {
        LIVE.fetch_sub(by, Ordering::Relaxed);
    }
}

// SAFETY: every call is forwarded unchanged to `System`; the counters only
// observe the sizes of successful calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            Self::grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            Self::grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        Self::shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                Self::grew(new_size - layout.size());
            } else {
                Self::shrank(layout.size() - new_size);
            }
        }
        p
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Bytes currently allocated through [`Counting`].
pub fn live_bytes() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// What a piece of work added at its peak.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Peak {
    /// Heap: high-water mark of live bytes minus live bytes before.
    pub heap_bytes: usize,
    /// Resident set: `VmHWM` after minus `VmRSS` before (`None` without
    /// Linux's `/proc/self/clear_refs`).
    pub rss_bytes: Option<usize>,
}

/// A field of `/proc/self/status` in bytes (`VmRSS`, `VmHWM`: given in kB).
fn status_bytes(key: &str) -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kb: usize = line[key.len()..]
        .trim_start_matches(':')
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kb * 1024)
}

/// Return freed heap pages to the system (glibc keeps them otherwise, and
/// the work would reuse them without raising the resident set), then reset
/// `VmHWM` to the current `VmRSS`; the RSS before, or `None`.
fn reset_rss_mark() -> Option<usize> {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory of glibc's arenas.
    unsafe {
        libc::malloc_trim(0);
    }
    std::fs::write("/proc/self/clear_refs", "5").ok()?;
    status_bytes("VmRSS")
}

/// Run `work` and measure what it added to the heap and the resident set
/// at their peaks.
pub fn measure<T>(work: impl FnOnce() -> T) -> (T, Peak) {
    let rss_before = reset_rss_mark();
    let live_before = LIVE.load(Ordering::Relaxed);
    PEAK.store(live_before, Ordering::Relaxed);
    let out = work();
    let heap_bytes = PEAK.load(Ordering::Relaxed).saturating_sub(live_before);
    let rss_bytes =
        rss_before.and_then(|before| Some(status_bytes("VmHWM")?.saturating_sub(before)));
    (
        out,
        Peak {
            heap_bytes,
            rss_bytes,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_buffer_is_measured_to_the_byte_and_in_pages() {
        // 64 MiB, touched so its pages are resident.
        let n = 64 << 20;
        let (sum, peak) = measure(|| {
            let v = vec![1u8; n];
            v.iter().map(|&b| b as usize).sum::<usize>()
        });
        assert_eq!(sum, n);
        // Other unit tests of this binary run at the same time and hold a
        // few megabytes of images at most; counting the buffer twice would
        // exceed 1.5 n.
        assert!(
            peak.heap_bytes >= n && peak.heap_bytes < n + n / 2,
            "{peak:?}"
        );
        if let Some(rss) = peak.rss_bytes {
            assert!(rss > n * 9 / 10 && rss < n + (16 << 20), "{peak:?}");
        }
        // Freed: a second, smaller measurement does not see the first
        // (other tests' megabytes aside).
        let ((), small) = measure(|| drop(vec![1u8; 1 << 20]));
        assert!(small.heap_bytes < n / 4, "{small:?}");
    }
}
