//! The participating medium (thesis §2.3, §7.2.2–7.2.4; structure after pbrt-v4's
//! `media.h`): transferred density, σ mapping, emission and phase function, answering point
//! queries (`sigma_t`, `albedo`, `emission`) and yielding majorant segments along a ray.
//!
//! * [`transfer`] and [`sigma`] turn normalised density into σa, σs (the choices under study);
//! * [`majorant`] bounds σt brick by brick and walks a ray's majorant segments;
//! * [`free_path`] holds every tracker on one collision loop (delta, ratio, march, thesis);
//! * [`march`] is the thesis's ray marching and marched optical depth;
//! * [`optical_depth`] integrates σt exactly along a ray, cell by cell, skipping the
//!   cells [`empty_cells`] marks (which also answer where the density is zero) and reading
//!   the corners from a [`compact_density`] copy of the grid;
//! * [`phase`] is the phase function.

mod clip;
pub mod colour;
mod compact_density;
mod empty_cells;
mod free_path;
mod majorant;
mod march;
mod optical_depth;
mod phase;
mod shadow;
mod sigma;
mod transfer;

use glam::Vec3;

pub use clip::{
    ClipParams, ClipPlaneParams, ClipRegion, ClipSpace, CropBoxParams, HalfSpace, ViewFrame,
};
pub use colour::ColourTransfer;
pub use free_path::{FreePath, sample_interaction_march, sample_interaction_thesis};
pub use majorant::{MajorantGrid, MajorantSegment, MajorantSegments};
pub use optical_depth::blocked_depth;
pub use phase::Phase;
pub(crate) use shadow::transmittance_of;
pub use shadow::{DepthCap, ShadowBy, ShadowSegment};
pub use sigma::{
    Coefficients, MIN_MEAN_FREE_PATH, MappingKind, SigmaMapping, SigmaParams, SigmaReport, Split,
    THESIS_ALBEDO, THESIS_T,
};
pub use transfer::{Pgm, TransferFunction, TransferKind, TransferParams, write_pgm};

use crate::error::{Error, Result};
use crate::math::{Aabb, Ray, Sphere};
use crate::volume::{
    CellCursor, Grid, NormalizationRecord, Reconstruction, Volume, Voxels, trilinear_corners,
};
use compact_density::CompactDensity;

/// Default majorant brick edge in voxels (a 256³ volume gets 64³ bricks). Small bricks skip
/// more empty space inside bone-only transfer functions; measured on the foot preset, 4
/// voxels render about 13 % faster than 8 and 30 % faster than 16.
pub const DEFAULT_BRICK_SIZE: usize = 4;

/// Everything besides the volume that defines a medium.
#[derive(Debug, Clone)]
pub struct MediumSettings {
    /// Applied to every voxel before σ scaling.
    pub transfer: TransferFunction,
    /// How density maps to σa, σs.
    pub mapping: SigmaMapping,
    /// Emission base value `Le` (radiance per unit length per unit density, pbrt-v1 `Lve`).
    pub emission: Vec3,
    /// Tint the emission by the colour transfer function's colour (needs one).
    pub emission_colour: bool,
    /// Phase function.
    pub phase: Phase,
    /// Reconstruction between voxels.
    pub reconstruction: Reconstruction,
    /// Majorant brick edge in voxels.
    pub brick_size: usize,
    /// What of the volume is kept (nothing clipped by default).
    pub clip: ClipParams,
    /// The camera's frame, for a clip in `space = "view"`.
    pub clip_view: Option<ViewFrame>,
}

impl Default for MediumSettings {
    fn default() -> Self {
        MediumSettings {
            transfer: TransferFunction::Identity,
            mapping: SigmaMapping::Thesis {
                t: sigma::THESIS_T,
                split: sigma::Split::Albedo(sigma::THESIS_ALBEDO),
            },
            emission: Vec3::ZERO,
            emission_colour: false,
            phase: Phase::ISOTROPIC,
            reconstruction: Reconstruction::Trilinear,
            brick_size: DEFAULT_BRICK_SIZE,
            clip: ClipParams::default(),
            clip_view: None,
        }
    }
}

/// Points of [`ball_points`].
const BALL_POINTS: usize = 32;

/// The centre and the [`ball_points`] by axis (`[axis][point]`, the centre at 0 with
/// offset 0, so `center + 0·r` is `center`).
fn ball_points_by_axis() -> &'static [[f32; BALL_POINTS + 1]; 3] {
    static AXES: std::sync::OnceLock<[[f32; BALL_POINTS + 1]; 3]> = std::sync::OnceLock::new();
    AXES.get_or_init(|| {
        let mut axes = [[0.0; BALL_POINTS + 1]; 3];
        for (i, p) in ball_points().iter().enumerate() {
            for (a, axis) in axes.iter_mut().enumerate() {
                axis[i + 1] = p[a];
            }
        }
        axes
    })
}

/// 32 points spread evenly through the unit ball (equal-volume shells, golden-angle
/// spirals), the same for every query so estimates stay deterministic.
fn ball_points() -> &'static [Vec3] {
    static POINTS: std::sync::OnceLock<Vec<Vec3>> = std::sync::OnceLock::new();
    POINTS.get_or_init(|| {
        let n = BALL_POINTS;
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        (0..n)
            .map(|i| {
                let f = (i as f32 + 0.5) / n as f32;
                let radius = f.cbrt();
                let z = 1.0 - 2.0 * f;
                let ring = (1.0 - z * z).max(0.0).sqrt();
                let phi = golden * i as f32;
                Vec3::new(ring * phi.cos(), ring * phi.sin(), z) * radius
            })
            .collect()
    })
}

/// The probability that a path or a photon scatters (rather than is absorbed) at a
/// collision with albedo `albedo` (Russian roulette, thesis §5.1); its throughput or power
/// is then multiplied by `albedo / survive`, which keeps every channel's expectation.
///
/// A grey albedo survives with itself (written as the channels' mean, the expression every
/// earlier release used, so grey media render the same to the bit). A coloured one survives
/// with its largest channel, so that no channel's weight `albedo_c / survive` exceeds 1: with
/// the mean instead, the strongest channel's throughput grows by `albedo_c / mean` at every
/// vertex (×2.6 for a red albedo (0.95, 0.1, 0.05)), and the rare long paths that survive
/// carry fireflies of many times the pixel's value: the weight's second moment per vertex,
/// `albedo_c² / survive`, exceeds 1 (2.5 for that red), so the variance grows without
/// bound with the path's length; with the largest channel it is at most `albedo_c` ≤ 1.
#[inline]
pub(crate) fn survival_probability(albedo: Vec3) -> f32 {
    if albedo.x == albedo.y && albedo.y == albedo.z {
        (albedo.x + albedo.y + albedo.z) / 3.0
    } else {
        albedo.max_element()
    }
}

/// Per-channel colour grids for a colour transfer function (evaluated on the raw values).
fn colour_grids(volume: &Volume, transfer: &TransferFunction) -> Option<Box<[Grid; 3]>> {
    transfer.colour_at(0.0)?;
    let values = volume.grid().values();
    let rgb: Vec<[f32; 3]> = values
        .iter()
        .map(|&d| transfer.colour_at(d).unwrap_or([1.0; 3]))
        .collect();
    Some(Box::new([0, 1, 2].map(|c| {
        volume
            .grid()
            .with_values(rgb.iter().map(|v| v[c]).collect())
    })))
}

/// A renderable medium built from a volume.
#[derive(Debug, Clone)]
pub struct Medium {
    density: Grid,
    reconstruction: Reconstruction,
    sigma_t_base: f32,
    albedo: Vec3,
    mean_albedo: f32,
    colour: Option<Box<[Grid; 3]>>,
    emission: Vec3,
    emission_colour: bool,
    phase: Phase,
    majorants: MajorantGrid,
    /// The kept part of the box (`None`: all of it).
    clip_region: Option<ClipRegion>,
    /// A sphere around everything that can scatter: the occupied majorant bricks inside
    /// the kept region (`None`: nothing can).
    scattering_sphere: Option<Sphere>,
    /// Built on first use by the exact optical depth.
    empty_cells: std::sync::OnceLock<empty_cells::EmptyCells>,
    /// Built on first use by the exact optical depth (`None`: too many distinct values).
    compact_density: std::sync::OnceLock<Option<CompactDensity>>,
    report: SigmaReport,
    mapping: SigmaMapping,
    transfer: String,
    normalization: NormalizationRecord,
}

impl Medium {
    /// Applies the transfer function to every voxel, resolves the σ mapping on the result and
    /// builds the majorant bricks.
    pub fn create(volume: &Volume, settings: &MediumSettings) -> Result<Self> {
        if settings.brick_size == 0 || settings.brick_size > 256 {
            return Err(Error::parameter(
                "brick_size",
                settings.brick_size,
                "a brick edge in [1, 256] voxels",
            ));
        }
        crate::error::check_rgb_non_negative("emission", settings.emission.to_array())?;
        let values: Vec<f32> = volume
            .grid()
            .values()
            .iter()
            .map(|&d| settings.transfer.apply(d))
            .collect();
        let density = volume.grid().with_values(values);
        let clip_region = ClipRegion::create(
            &settings.clip,
            density.bounds(),
            settings.clip_view.as_ref(),
        )
        .map_err(|e| e.within("clip"))?;
        let d_min = density.min_positive().unwrap_or(0.0);
        let (_, d_max) = density.min_max();
        let largest_extent = density.bounds().largest_extent();
        let coefficients = settings
            .mapping
            .resolve(d_min, d_max, largest_extent)
            .map_err(|e| e.within("sigma"))?;
        let report = SigmaReport::new(&coefficients, d_min, d_max, largest_extent);
        let majorants =
            MajorantGrid::build(&density, coefficients.sigma_t_base, settings.brick_size);
        let scattering_sphere = scattering_sphere(&majorants, clip_region.as_ref());
        let albedo = coefficients.albedo;
        let colour = colour_grids(volume, &settings.transfer);
        if settings.emission_colour && colour.is_none() {
            return Err(Error::parameter(
                "sigma.emission_colour",
                true,
                format!(
                    "a colour transfer function to take the colour from (a preset, a .vp file, or opacity + colour points), not {}",
                    settings.transfer.describe()
                ),
            ));
        }
        Ok(Medium {
            colour,
            density,
            reconstruction: settings.reconstruction,
            sigma_t_base: coefficients.sigma_t_base,
            albedo,
            mean_albedo: (albedo.x + albedo.y + albedo.z) / 3.0,
            emission: settings.emission,
            emission_colour: settings.emission_colour,
            phase: settings.phase,
            majorants,
            clip_region,
            scattering_sphere,
            empty_cells: std::sync::OnceLock::new(),
            compact_density: std::sync::OnceLock::new(),
            report,
            mapping: settings.mapping.clone(),
            transfer: settings.transfer.describe(),
            normalization: volume.normalization().clone(),
        })
    }

    /// The world box (no medium outside).
    pub fn bounds(&self) -> Aabb {
        self.density.bounds()
    }

    /// The transferred density grid.
    pub fn density_grid(&self) -> &Grid {
        &self.density
    }

    /// Transferred density at `p` (0 where a clip removes the medium).
    #[inline]
    pub fn density(&self, p: Vec3) -> f32 {
        if let Some(region) = &self.clip_region
            && !region.contains(p)
        {
            return 0.0;
        }
        self.density.sample(p, self.reconstruction)
    }

    /// A sphere around everything that can scatter light — the box of the occupied
    /// majorant bricks, cut by the kept region when the scene clips — or `None` when
    /// nothing can. Photons from lights with extent aim at it, so a sky's photons do not
    /// cross empty space around a small or opened volume.
    pub fn scattering_sphere(&self) -> Option<Sphere> {
        self.scattering_sphere
    }

    /// The kept part of the box when the scene clips the volume (`[clip]`).
    pub fn clip_region(&self) -> Option<&ClipRegion> {
        self.clip_region.as_ref()
    }

    /// Extinction σt at `p` (grey).
    #[inline]
    pub fn sigma_t(&self, p: Vec3) -> f32 {
        self.sigma_t_base * self.density(p)
    }

    /// σt at a point of a ray's clipped interval (inside the box up to rounding), without
    /// the outside test: the hot path of marching. The samples of one marched ray come in
    /// order, and `cursor` keeps the corners of the cell the last one fell in (at the
    /// thesis's steps several samples share a cell; the same value to the bit as reading
    /// them again).
    #[inline]
    pub(crate) fn sigma_t_marched(&self, cursor: &mut CellCursor, p: Vec3) -> f32 {
        let d = match self.reconstruction {
            Reconstruction::Trilinear => cursor.trilinear(&self.density, p),
            Reconstruction::Nearest => self.density.nearest(p),
        };
        self.sigma_t_base * d
    }

    /// How density is reconstructed between voxels.
    pub fn reconstruction(&self) -> Reconstruction {
        self.reconstruction
    }

    /// σt per unit density: `σt(x) = sigma_t_base · density(x)`.
    pub fn sigma_t_base(&self) -> f32 {
        self.sigma_t_base
    }

    /// Single-scattering albedo σs/σt per channel (constant over the medium).
    pub fn albedo(&self) -> Vec3 {
        self.albedo
    }

    /// Albedo at `p`: [`Self::albedo`] times the colour transfer function's colour there
    /// (just [`Self::albedo`] for grey media).
    #[inline]
    pub fn albedo_at(&self, p: Vec3) -> Vec3 {
        match &self.colour {
            None => self.albedo,
            Some(rgb) => {
                let c = rgb.each_ref().map(|g| g.sample(p, self.reconstruction));
                self.albedo * Vec3::from(c)
            }
        }
    }

    /// Whether the albedo varies with a colour transfer function.
    pub fn has_colour(&self) -> bool {
        self.colour.is_some()
    }

    /// Mean of the albedo's channels: the Russian-roulette survival probability (§5.1).
    pub fn mean_albedo(&self) -> f32 {
        self.mean_albedo
    }

    /// Scattering σs at `p`.
    #[inline]
    pub fn sigma_s(&self, p: Vec3) -> Vec3 {
        self.albedo * self.sigma_t(p)
    }

    /// Emission source per unit length at `p`: `Le_base · d(p)`, times the colour transfer
    /// function's colour at `p` with `emission_colour`.
    #[inline]
    pub fn emission(&self, p: Vec3) -> Vec3 {
        let base = self.emission * self.density(p);
        match (&self.colour, self.emission_colour) {
            (Some(rgb), true) => {
                base * Vec3::from(rgb.each_ref().map(|g| g.sample(p, self.reconstruction)))
            }
            _ => base,
        }
    }

    /// Whether the medium emits at all.
    pub fn has_emission(&self) -> bool {
        self.emission != Vec3::ZERO
    }

    /// The phase function.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The fraction of the sphere of radius `r` around `center` that holds medium
    /// (σt > 0), estimated at 32 fixed, evenly spread points plus the centre. Used to
    /// normalise photon-map estimates by the volume photons can actually occupy.
    ///
    /// A point is answered from the empty cells' bit where the trilinear reconstruction
    /// would read eight zero corners, else from the compact copy of the grid: the points'
    /// corners lie far apart in a grid larger than the processor's caches, and the bit is
    /// one load, the compact corners a quarter of the memory.
    pub fn occupancy(&self, center: Vec3, r: f32) -> f32 {
        if self.reconstruction == Reconstruction::Nearest {
            let points = ball_points();
            let at = |i: usize| {
                if i == 0 {
                    center
                } else {
                    center + points[i - 1] * r
                }
            };
            let inside = (0..=points.len())
                .filter(|&i| self.density(at(i)) > 0.0)
                .count();
            return inside as f32 / (points.len() + 1) as f32;
        }
        // Three passes, so that neither arithmetic nor memory waits on a branch: every
        // point's cell and fractions, axis by axis over all 33 points (loops the compiler
        // vectorises; the same operations as `Grid::trilinear_cell` on `center + q·r`, so
        // the same values); then the empty-cell bits of the points inside the box (outside
        // it the density is 0), keeping the cells that are not empty; then their corners.
        // The count is the same as asking `density(p) > 0` point by point.
        const N: usize = BALL_POINTS + 1;
        let by_axis = ball_points_by_axis();
        let (bounds, dims, scale) = (self.bounds(), self.density.dims(), self.density.scale());
        let mut in_box = [true; N];
        let mut cell = [[0i32; N]; 3];
        let mut fraction = [[0.0f32; N]; 3];
        for a in 0..3 {
            let (lo, hi, s) = (bounds.min[a], bounds.max[a], scale[a]);
            let (top, last_lower) = ((dims[a] - 1) as f32, dims[a].saturating_sub(2) as i32);
            for i in 0..N {
                let p = center[a] + by_axis[a][i] * r;
                in_box[i] &= p >= lo && p <= hi;
                // `clamp(0, top)` for the finite coordinates a ball around a sample has.
                let f = ((p - lo) * s - 0.5).max(0.0).min(top);
                let lower = (f as i32).min(last_lower);
                cell[a][i] = lower;
                fraction[a][i] = f - lower as f32;
            }
        }
        if let Some(region) = &self.clip_region {
            for (i, kept) in in_box.iter_mut().enumerate() {
                let q = Vec3::new(by_axis[0][i], by_axis[1][i], by_axis[2][i]);
                *kept &= region.contains(center + q * r);
            }
        }
        let empty = self.empty_cells();
        let mut pending = [0u8; N];
        let mut n_pending = 0;
        for i in 0..N {
            let c = [0, 1, 2].map(|a| cell[a][i] as i64);
            pending[n_pending] = i as u8;
            n_pending += usize::from(in_box[i] && !empty.is_empty(c));
        }
        let inside = pending[..n_pending]
            .iter()
            .map(|&i| {
                let i = i as usize;
                let c = [0, 1, 2].map(|a| cell[a][i] as usize);
                let f = [0, 1, 2].map(|a| fraction[a][i]);
                usize::from(self.trilinear_compact(c, f) > 0.0)
            })
            .sum::<usize>();
        inside as f32 / N as f32
    }

    /// The interpolation [`Grid::trilinear_clamped`] makes in `cell` at `fraction` (as
    /// [`Grid::trilinear_cell`] gives them), its corners read from the compact copy when
    /// there is one: the same value to the bit.
    #[inline]
    fn trilinear_compact(&self, cell: [usize; 3], fraction: [f32; 3]) -> f32 {
        let (base, step) = self.density.cell_corners(cell);
        let corners = match self.compact_density() {
            Some(CompactDensity::Byte(bytes)) => bytes.corners(base, step),
            Some(CompactDensity::Word(words)) => words.corners(base, step),
            None => self.density.values().corners(base, step),
        };
        trilinear_corners(&corners, fraction)
    }

    /// The majorant bricks.
    pub fn majorants(&self) -> &MajorantGrid {
        &self.majorants
    }

    /// Builds now what the first shadow ray would otherwise build (the empty-cell bits and
    /// the compact density the exact optical depth reads), so that a render timed after
    /// this call measures its per-ray cost alone (`sweep plan`'s pilot renders).
    pub fn prepare(&self) {
        self.empty_cells();
        self.compact_density();
    }

    /// The density grid's empty cells (built on first use).
    fn empty_cells(&self) -> &empty_cells::EmptyCells {
        self.empty_cells
            .get_or_init(|| empty_cells::EmptyCells::build(&self.density))
    }

    /// The density grid's compact copy (built on first use), when it has at most 65 536
    /// distinct values.
    fn compact_density(&self) -> Option<&CompactDensity> {
        self.compact_density
            .get_or_init(|| CompactDensity::build(&self.density))
            .as_ref()
    }

    /// The σ mapping's outcome on this volume.
    pub fn report(&self) -> &SigmaReport {
        &self.report
    }

    /// The σ mapping.
    pub fn mapping(&self) -> &SigmaMapping {
        &self.mapping
    }

    /// How the volume's raw values were scaled to densities.
    pub fn normalization(&self) -> &NormalizationRecord {
        &self.normalization
    }

    /// The transfer function, described.
    pub fn transfer_description(&self) -> &str {
        &self.transfer
    }

    /// The ray's parametric interval inside the medium: the volume box, or the kept region
    /// when the scene clips (convex, so one interval). Every integrator bounds its eye rays,
    /// shadow rays and photon flights by it, so no collision is sampled where the clip
    /// removed the medium.
    #[inline]
    pub fn clip(&self, ray: &Ray) -> Option<(f32, f32)> {
        match &self.clip_region {
            Some(region) => region.interval(ray),
            None => self.bounds().intersect(ray),
        }
    }

    /// Majorant segments of `ray` over `[t_min, t_max]`.
    pub fn segments(&self, ray: &Ray, t_min: f32, t_max: f32) -> MajorantSegments<'_> {
        self.majorants.segments(ray, t_min, t_max)
    }
}

/// The sphere around the occupied bricks' box cut by the kept region
/// ([`Medium::scattering_sphere`]): around the corners of that convex polytope.
fn scattering_sphere(majorants: &MajorantGrid, clip: Option<&ClipRegion>) -> Option<Sphere> {
    let occupied = majorants.occupied_bounds()?;
    let corners: Vec<Vec3> = match clip {
        None => (0..8)
            .map(|i| {
                let pick = |bit: usize, a: usize| {
                    if i >> bit & 1 == 0 {
                        occupied.min[a]
                    } else {
                        occupied.max[a]
                    }
                };
                Vec3::new(pick(0, 0), pick(1, 1), pick(2, 2))
            })
            .collect(),
        Some(region) => region
            .within(occupied)?
            .faces()
            .into_iter()
            .flatten()
            .collect(),
    };
    Sphere::enclosing(&corners)
}

/// Media for unit tests: procedural phantoms with the thesis's σ mapping.
#[cfg(test)]
pub(crate) mod test_media {
    use glam::Vec3;

    use super::{Medium, MediumSettings, SigmaMapping, Split};
    use crate::math::{Ray, Rng};
    use crate::volume::{PhantomParams, Volume};

    /// A ray from a random point of the unit box in a random direction, and its interval
    /// inside `m`'s box.
    pub(crate) fn random_ray(m: &Medium, rng: &mut Rng) -> (Ray, f32, f32) {
        let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let direction = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
        let ray = Ray::new(origin, direction.normalize());
        let (t0, t1) = m.clip(&ray).expect("a ray from inside the box");
        (ray, t0, t1)
    }

    /// The phantom `name` at `res`³ voxels (optional densities), σt(d_min) = `t`, albedo 0.8.
    pub(crate) fn phantom_medium(
        name: &str,
        res: usize,
        densities: Option<[f32; 2]>,
        t: f32,
    ) -> Medium {
        let mut p = PhantomParams::named(name, res);
        p.densities = densities;
        let v = Volume::from_phantom(&p).unwrap();
        Medium::create(
            &v,
            &MediumSettings {
                mapping: SigmaMapping::Thesis {
                    t,
                    split: Split::Albedo(0.8),
                },
                ..Default::default()
            },
        )
        .unwrap()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::test_media::phantom_medium as medium;
    use crate::math::Ray;

    #[test]
    fn occupancy_counts_the_points_where_the_density_is_positive() {
        // Spheres all over the box and a little beyond, on phantoms with empty space.
        let mut rng = crate::math::Rng::stream(3, crate::math::Domain::Misc, 0);
        let points = super::ball_points();
        for name in ["foot", "engine", "sphere"] {
            let m = medium(name, 24, None, 10.0);
            let mut partial = 0;
            for _ in 0..2_000 {
                let centre =
                    Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - Vec3::splat(0.1);
                let r = 0.2 * rng.uniform();
                let at = std::iter::once(centre).chain(points.iter().map(|u| centre + *u * r));
                let positive = at.clone().filter(|p| m.density(*p) > 0.0).count();
                let share = m.occupancy(centre, r);
                assert_eq!(share, positive as f32 / 33.0, "{name} at {centre}, r {r}");
                partial += usize::from(share > 0.0 && share < 1.0);
                // The compact corners interpolate to the grid's value, to the bit.
                for p in at.filter(|p| m.bounds().contains(*p)) {
                    let (cell, fraction) = m.density.trilinear_cell(p);
                    assert_eq!(
                        m.trilinear_compact(cell, fraction).to_bits(),
                        m.density.trilinear_clamped(p).to_bits(),
                        "{name} at {p}"
                    );
                }
            }
            // Spheres across the medium's edges, so both answers and both passes are taken.
            assert!(partial > 200, "{name}: {partial}");
        }
    }

    #[test]
    fn segments_cover_the_interval_in_order() {
        let m = medium("sphere", 32, None, 10.0);
        let ray = Ray::new(Vec3::new(-0.5, 0.31, 0.47), Vec3::new(1.0, 0.23, 0.11));
        let (t0, t1) = m.clip(&ray).unwrap();
        let segs: Vec<_> = m.segments(&ray, t0, t1).collect();
        assert!(!segs.is_empty());
        assert_eq!(segs[0].t_min, t0);
        assert!((segs.last().unwrap().t_max - t1).abs() < 1e-5);
        for w in segs.windows(2) {
            assert_eq!(w[0].t_max, w[1].t_min);
        }
        // Majorants bound σt at many points along the ray.
        for s in &segs {
            for k in 0..16 {
                let t = s.t_min + (s.t_max - s.t_min) * (k as f32 + 0.5) / 16.0;
                assert!(m.sigma_t(ray.at(t)) <= s.sigma_maj * (1.0 + 1e-5));
            }
        }
    }
}
