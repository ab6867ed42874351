//! End-to-end tests: one binary (ripgrep style) that drives the real `sweep` executable.
//!
//! * `runs` — experiments, reports, resuming, locking, errors, `sweep render`;
//! * `reliability` — inputs and events that used to hang, exhaust memory or mislead;
//! * `hardening` — the newest verbs (`claims`, `index`, `--update`) and loose inputs, round 4;
//! * `guards` — files a verb did not make, ignored axes, the peer's images and scripts, round 5;
//! * `faults` — runs killed at many moments, damaged cells, a full file system;
//! * `figures` — the report's plots draw what the cells say, with their data beside them;
//! * `import` — the thesis's pbrt-v1 scenes through `sweep import`;
//! * `medical` — a DICOM folder with a Slicer preset, and a broken series;
//! * `claims` — the thesis's findings that the committed studies reproduce, on small grids;
//! * `paper` — every number the paper and the README cite, against the committed data;
//! * `browser` — `report.html` and its image explorer in headless Chromium;
//! * `slurm` — a real single-node Slurm cluster (CI or `VOLPHOT_SLURM_TEST=1`);
//! * `peer` — Mitsuba 3 renders the same scene (CI or `VOLPHOT_PEER_TEST=1`).
//!
//! Tests that cannot run here (no real data, no Chromium, no Slurm) print `SKIPPED …` to
//! stderr; under `CI=true` they fail instead.

mod browser;
mod claims;
mod faults;
mod figures;
mod guards;
mod hardening;
mod import;
mod medical;
mod paper;
mod peer;
mod reliability;
mod runs;
mod slurm;
