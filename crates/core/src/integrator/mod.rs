//! Integrators: the thesis's ray-marching integrator (§6, §7.1.3) with its optional caches,
//! and the unbiased reference path tracer it is measured against.
//!
//! # Map
//!
//! One marching pass, stage by stage (files marked `*` each hold one part of
//! `impl Marcher`, split by stage as `marcher.rs` explains):
//!
//! ```text
//! stage                     file                 holds
//! ────────────────────────  ───────────────────  ─────────────────────────────────────────
//! entry, rows → films       pass.rs              render_march, render_march_beams,
//!                                                render_march_planes, their measured
//!                                                forms, MarchOutput, MarchStats
//! one image row             marcher.rs         * Marcher (what a pass reads) and its
//!                                                constructors, render_row, Row
//! one eye ray               eye_ray.rs         * collect_samples, trace, add_single,
//!                                                add_multiple, shadow_transmittance
//!   light to a sample       shadow_track.rs      ShadowTrack: optical depth to one light
//!   photon-map estimate     gather.rs            MsVariant, MapGroup (variants sharing a
//!                                                k-NN query), source_factor
//!     …behind the front     estimate_track.rs    EstimateTrack: one variant's estimate
//!   beam estimate           beam.rs            * add_beams, beam_radius
//!   plane estimate          plane.rs           * add_planes
//!   both tracks             adaptive_fill.rs     Track, fill_adaptive (midpoint-checked)
//!   thinning                thinning.rs          Bands, knot spacing, ThinningError
//!   caches                  cache.rs             TransmittanceCache, ScatterCache
//! after the pass            error_probes.rs    * CacheError, error_probe_pixels, probing
//!                           error_bound.rs       ErrorBound (relative error of pairs)
//! between passes            eye_samples.rs       EyeSamples, EyeSampleStore (replay)
//! every stage (a leaf)      sample.rs            RaySample, Accumulator, RowCounters,
//!                                                GatheredEstimates
//! which estimator (a leaf)  multiple.rs          MsSource (gathers, beams, spheres,
//!                                                planes), mask_estimates
//! ```
//!
//! Around the pass: `progressive.rs` (render_progressive: progressive photon mapping,
//! progressive beams and photon planes, one pass per iteration), `eye_probe.rs` (probe_eye_rays: samples per
//! eye ray, measured before rendering) and `reference.rs` (render_reference: the unbiased
//! path tracer, which needs no marcher). Imports run one way, from the entry points down to
//! the leaves `sample.rs`, `multiple.rs`, `error_bound.rs` and `adaptive_fill.rs`, with no
//! circle (`crates/sweep/tests/architecture.rs` fails on one).
//!
//! # The marching integrator
//!
//! Each eye ray is cut into segments of `stepsize`; one sample per segment at a random
//! offset that is the same for every segment of the ray (Pauly et al. 2000). At each sample
//! with σt > 0 (samples with σs = 0 are skipped, §7.1.3):
//!
//! * single scattering from every light: `σs · p · I·falloff/r² · T(x → light)`;
//! * multiple scattering from the photon map: `σs(x) · Σ p ΔΦ_p / (σt(x_p) · V_m)` with
//!   `V_m` the medium's share of the gather sphere (eq. 11 in fluence form, normalised by
//!   where photons can be; the thesis's own form is selectable, see
//!   [`Estimate`](crate::Estimate));
//! * emission: `Le · d(x)`;
//!
//! each weighted by the segment's quadrature and the running eye transmittance, which is
//! updated multiplicatively (eq. 3). Marching stops when the eye transmittance drops below
//! `termination`; the radiance lost is at most that fraction of what lies behind. Marched
//! shadow rays stop at the same threshold (the light they could still carry is below that
//! fraction) and count as blocked.
//!
//! All three layers come from ONE pass, so "single only" and "single + multiple" share
//! every random decision.
//!
//! Acceleration that keeps results honest: empty-space skipping over majorant bricks, an
//! optional per-light transmittance cache (`shadow_cache`) and an optional
//! multiple-scattering cache (`ms_cache`, view-independent for isotropic phase). Both
//! caches are off by default; their error against the uncached path is measured in tests.

mod adaptive_fill;
mod beam;
mod cache;
mod error_bound;
mod error_probes;
mod estimate_track;
mod eye_probe;
mod eye_ray;
mod eye_samples;
mod gather;
mod marcher;
mod multiple;
mod pass;
mod plane;
mod progressive;
mod reference;
mod sample;
mod shadow_track;
mod thinning;

pub use cache::CACHE_TAU_MAX;
pub use error_bound::ErrorBound;
pub use error_probes::{CacheError, error_probe_pixels};
pub use eye_probe::{EyeProbe, probe_eye_rays};
pub use gather::MsVariant;
pub use pass::{MarchOutput, MarchStats, render_march, render_march_beams, render_march_planes};
pub use progressive::{
    ProgressiveOutput, ProgressiveStats, StopReason, next_radius, progress_rows, render_progressive,
};
pub use reference::{
    Budget, CpuSplit, LayerVariance, PixelClass, ReferenceAccumulator, Route, SOURCES, Source,
    Variant, reference_budget, render_reference,
};
pub use thinning::ThinningError;
