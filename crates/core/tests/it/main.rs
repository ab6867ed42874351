//! The core's integration tests, one binary: each file a module (one link of the library
//! instead of one per file — the build of `cargo test` on a fresh clone spent minutes
//! linking sixteen binaries).

/// The test binary's allocator notes each thread's largest request (and refuses 2 GiB), so
/// the fuzz and bad-input tests can bound what one case allocates.
#[global_allocator]
static PROBE: volphot::test_util::alloc::Probe = volphot::test_util::alloc::Probe;

mod architecture;
mod bad_input;
mod caches;
mod clip;
mod colour;
mod consistency;
mod conventions;
mod dicom;
mod fuzz;
mod ignored_keys;
mod lights;
mod nifti;
mod physics;
mod real_data;
mod reliability;
mod thinning;
mod trackers;
