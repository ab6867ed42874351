//! The fuzzing harness the parsers' property tests share: each generated case runs in a
//! thread of its own, bounded in time, with its largest single allocation measured; a run
//! must see both accepted and rejected cases.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

/// How long one case may take.
const BOUND: Duration = Duration::from_secs(20);

/// The largest single allocation a case may make: a gigabyte asked for at once is an input
/// read whole that should have been refused by its size (`/dev/zero`, a sparse file).
pub(crate) const ALLOCATION_BOUND: usize = 1 << 30;

thread_local! {
    /// The largest allocation this thread asked for since [`reset_largest`].
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

/// The test build's allocator: the system's, noting each thread's largest request.
struct Probe;

// SAFETY: every call is forwarded to `System` unchanged; the probe only reads the size.
unsafe impl GlobalAlloc for Probe {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: forwarded with the caller's layout.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn note(size: usize) {
    // `try_with`: a thread being torn down has no slot left; its allocations are not a case's.
    let _ = LARGEST.try_with(|l| {
        if size > l.get() {
            l.set(size);
        }
    });
}

#[global_allocator]
static PROBE: Probe = Probe;

/// Starts measuring this thread's allocations afresh.
pub(crate) fn reset_largest() {
    LARGEST.with(|l| l.set(0));
}

/// The largest single allocation this thread made since [`reset_largest`].
pub(crate) fn largest_allocation() -> usize {
    LARGEST.with(Cell::get)
}

/// Runs `check` on each generated case in a thread of its own, failing a case that
/// panics, hangs past [`BOUND`] or is rejected without pointing into its file, and a run
/// whose cases were all accepted or all rejected; `check` says whether a case was accepted.
pub(crate) fn run<S, F>(name: &str, dir: &Path, cases: u32, strategy: S, check: F)
where
    S: Strategy,
    S::Value: std::fmt::Debug + Send + 'static,
    F: Fn(&Path, S::Value) -> Result<bool, String> + Send + Sync + Clone + 'static,
{
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let counts = std::sync::Mutex::new((0u32, 0u32));
    let result = runner.run(&strategy, |text| {
        let (tx, rx) = mpsc::channel();
        let case_dir = dir.to_path_buf();
        let shown = format!("{text:?}");
        let check = check.clone();
        std::thread::spawn(move || {
            reset_largest();
            let r =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(&case_dir, text)));
            let _ = tx.send((r, largest_allocation()));
        });
        match rx.recv_timeout(BOUND) {
            Err(_) => Err(TestCaseError::fail(format!("a hang on\n{shown}"))),
            Ok((_, largest)) if largest >= ALLOCATION_BOUND => Err(TestCaseError::fail(format!(
                "an allocation of {largest} bytes on\n{shown}"
            ))),
            Ok((Err(_), _)) => Err(TestCaseError::fail(format!("panicked on\n{shown}"))),
            Ok((Ok(Err(m)), _)) => Err(TestCaseError::fail(m)),
            Ok((Ok(Ok(ok)), _)) => {
                let mut c = counts.lock().unwrap();
                if ok {
                    c.0 += 1
                } else {
                    c.1 += 1
                }
                Ok(())
            }
        }
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let (accepted, rejected) = counts.into_inner().unwrap();
    use std::io::Write as _;
    let _ = writeln!(
        std::io::stderr().lock(),
        "fuzz {name}: {cases} cases, {accepted} accepted, {rejected} rejected, 0 panics, 0 hangs, no allocation of 1 GiB"
    );
    // A generator that drifted to one side of the parser no longer tests the other.
    assert!(
        accepted > 0,
        "fuzz {name}: the parser accepted none of {cases} generated files; the generator makes no valid file any more"
    );
    assert!(
        rejected > 0,
        "fuzz {name}: the parser rejected none of {cases} generated files; the generator makes no invalid file any more"
    );
}

/// The harness itself: a generator that drifted to making only rejected cases (or only
/// accepted ones) tests one side of the parser, and must fail the test that uses it.
#[test]
#[should_panic(expected = "accepted none")]
fn a_generator_of_only_rejected_cases_fails_its_test() {
    let dir = tempfile::tempdir().unwrap();
    run(
        "only_rejected",
        dir.path(),
        8,
        Just(String::new()),
        |_, _| Ok(false),
    );
}

#[test]
#[should_panic(expected = "rejected none")]
fn a_generator_of_only_accepted_cases_fails_its_test() {
    let dir = tempfile::tempdir().unwrap();
    run(
        "only_accepted",
        dir.path(),
        8,
        Just(String::new()),
        |_, _| Ok(true),
    );
}

#[test]
#[should_panic(expected = "an allocation of")]
fn a_case_that_allocates_a_gigabyte_fails() {
    let dir = tempfile::tempdir().unwrap();
    run("allocates", dir.path(), 1, Just(String::new()), |_, _| {
        let v: Vec<u8> = Vec::with_capacity(ALLOCATION_BOUND);
        Ok(v.capacity() > 0)
    });
}
