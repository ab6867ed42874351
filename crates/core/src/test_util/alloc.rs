//! An allocation probe for test binaries: the system's allocator, noting each thread's
//! largest single request, so that a parser test can say that no input made it ask for a
//! gigabyte at once (an input read whole or sized from a corrupt header). A request of
//! [`REFUSED_FROM`] bytes or more is refused outright, which aborts the test binary: a
//! parser that asks for gigabytes fails its test at once instead of taking a shared
//! machine's memory.
//!
//! A test binary installs it with
//!
//! ```ignore
//! #[global_allocator]
//! static PROBE: volphot::test_util::alloc::Probe = volphot::test_util::alloc::Probe;
//! ```

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// Requests this large are refused (the test binary aborts with "memory allocation of …
/// failed").
pub const REFUSED_FROM: usize = 2 << 30;

thread_local! {
    /// The largest allocation this thread asked for since [`reset_largest`].
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

/// The system's allocator, noting each thread's largest request and refusing any of
/// [`REFUSED_FROM`] bytes or more.
pub struct Probe;

// SAFETY: every call is forwarded to `System` unchanged, or refused with a null pointer as
// `GlobalAlloc` allows; the probe only reads the size.
unsafe impl GlobalAlloc for Probe {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !note(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !note(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if !note(new_size) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Notes a request; whether it may be served.
fn note(size: usize) -> bool {
    // `try_with`: a thread being torn down has no slot left; its allocations are not a
    // case's.
    let _ = LARGEST.try_with(|l| {
        if size > l.get() {
            l.set(size);
        }
    });
    size < REFUSED_FROM
}

/// Starts measuring this thread's allocations afresh.
pub fn reset_largest() {
    LARGEST.with(|l| l.set(0));
}

/// The largest single allocation this thread made since [`reset_largest`] (0 unless the
/// test binary installed [`Probe`]).
pub fn largest_allocation() -> usize {
    LARGEST.with(Cell::get)
}
