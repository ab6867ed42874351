//! Procedural phantoms: deterministic volumes at any resolution, so that the project runs and
//! tests anywhere without the real CT/MRI files.
//!
//! Anatomical stand-ins (`engine`, `foot`, `head`) are quantised to 8-bit levels like the
//! thesis's data, so the smallest non-zero density `d_min` (§8.1.2) behaves as with real
//! scans. Analytic test volumes (`constant`, `slab`, `two-slab`, `sphere`) hold exact values
//! for closed-form tests. `orientation` is asymmetric on purpose: it pins axis conventions.
//!
//! Every shape is defined in normalised grid coordinates `q ∈ [0,1]³` at voxel centres.

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Normalization, Placement, Volume, VolumeSource};
use crate::error::{Error, Result};

/// Names accepted by [`generate`].
pub const PHANTOM_NAMES: &[&str] = &[
    "constant",
    "slab",
    "two-slab",
    "sphere",
    "engine",
    "foot",
    "head",
    "orientation",
];

/// Parameters of a phantom. Only `name` and `resolution` apply to every phantom; the
/// analytic ones read `density`, `densities`, `range` and `radius`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhantomParams {
    /// One of `constant`, `slab`, `two-slab`, `sphere`, `engine`, `foot`, `head`, `orientation`.
    pub name: String,
    /// Voxels along x, y, z.
    #[serde(default = "default_resolution")]
    pub resolution: [usize; 3],
    /// `constant`, `slab`, `sphere`: the density inside (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<f32>,
    /// `two-slab`: densities of the `x < ½` and `x ≥ ½` halves (default `[0.25, 1]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub densities: Option<[f32; 2]>,
    /// `slab`: the x range `[lo, hi]` that holds medium (default `[0.25, 0.75]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<[f32; 2]>,
    /// `sphere`: radius in normalised units (default 0.4), centred in the box.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
}

fn default_resolution() -> [usize; 3] {
    [96, 96, 96]
}

impl PhantomParams {
    /// A phantom with a cubic resolution and default parameters.
    pub fn named(name: &str, resolution: usize) -> Self {
        PhantomParams {
            name: name.to_string(),
            resolution: [resolution; 3],
            density: None,
            densities: None,
            range: None,
            radius: None,
        }
    }

    /// Stable textual form of the parameters, recorded as provenance.
    pub fn describe(&self) -> String {
        let [x, y, z] = self.resolution;
        let mut s = format!("resolution={x}x{y}x{z}");
        if let Some(d) = self.density {
            s += &format!(", density={d}");
        }
        if let Some([a, b]) = self.densities {
            s += &format!(", densities=[{a}, {b}]");
        }
        if let Some([a, b]) = self.range {
            s += &format!(", range=[{a}, {b}]");
        }
        if let Some(r) = self.radius {
            s += &format!(", radius={r}");
        }
        s
    }

    /// Checks the name, the grid (and that it fits in memory), the values, and that only
    /// the keys this phantom takes are given.
    fn validate(&self) -> Result<()> {
        if !PHANTOM_NAMES.contains(&self.name.as_str()) {
            return Err(Error::parameter(
                "name",
                format!("\"{}\"", self.name),
                format!("one of {}", PHANTOM_NAMES.join(", ")),
            ));
        }
        self.validate_resolution()?;
        self.validate_values()?;
        self.validate_keys()
    }

    /// Three voxel counts in [2, 1024] whose working memory fits in the budget.
    fn validate_resolution(&self) -> Result<()> {
        if self.resolution.iter().any(|&n| !(2..=1024).contains(&n)) {
            return Err(Error::parameter(
                "resolution",
                format!("{:?}", self.resolution),
                "three voxel counts in [2, 1024]",
            ));
        }
        let voxels = self.resolution.iter().map(|&n| n as u64).product::<u64>();
        let bytes = voxels * crate::util::WORKING_BYTES_PER_VOXEL;
        let budget = crate::util::memory_budget_bytes();
        if bytes > budget {
            return Err(Error::parameter(
                "resolution",
                format!("{:?}", self.resolution),
                format!(
                    "a grid whose {} MiB of working memory fits in the {} MiB available",
                    bytes >> 20,
                    budget >> 20
                ),
            ));
        }
        Ok(())
    }

    /// Densities in [0, 1], a range inside it, a radius in (0, 0.5].
    fn validate_values(&self) -> Result<()> {
        let unit = |key: &str, v: f32| -> Result<()> {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(Error::parameter(key, v, "a density in [0, 1]"))
            }
        };
        if let Some(d) = self.density {
            unit("density", d)?;
        }
        if let Some([a, b]) = self.densities {
            unit("densities", a)?;
            unit("densities", b)?;
        }
        if let Some([lo, hi]) = self.range
            && !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi && hi <= 1.0)
        {
            return Err(Error::parameter(
                "range",
                format!("[{lo}, {hi}]"),
                "0 <= lo < hi <= 1",
            ));
        }
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0 && r <= 0.5)
        {
            return Err(Error::parameter("radius", r, "a radius in (0, 0.5]"));
        }
        Ok(())
    }

    /// Only the keys the named phantom takes.
    fn validate_keys(&self) -> Result<()> {
        let allowed: &[&str] = match self.name.as_str() {
            "constant" => &["density"],
            "slab" => &["density", "range"],
            "two-slab" => &["densities"],
            "sphere" => &["density", "radius"],
            _ => &[],
        };
        for (key, present) in [
            ("density", self.density.is_some()),
            ("densities", self.densities.is_some()),
            ("range", self.range.is_some()),
            ("radius", self.radius.is_some()),
        ] {
            if present && !allowed.contains(&key) {
                return Err(Error::given_without_use(
                    key,
                    format!(
                        "no `{key}` for phantom `{}` (it takes {})",
                        self.name,
                        if allowed.is_empty() {
                            "only `resolution`".to_string()
                        } else {
                            allowed.join(", ")
                        }
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Generates the phantom as a [`Volume`] in the unit box (longest axis 1, centred).
pub fn generate(params: &PhantomParams) -> Result<Volume> {
    params.validate().map_err(|e| e.within("phantom"))?;
    let [nx, ny, nz] = params.resolution;
    let density = params.density.unwrap_or(1.0);
    let shape: Box<dyn Fn(Vec3) -> f32 + Sync> = match params.name.as_str() {
        "constant" => Box::new(move |_| density),
        "slab" => {
            let [lo, hi] = params.range.unwrap_or([0.25, 0.75]);
            Box::new(move |q: Vec3| if q.x >= lo && q.x < hi { density } else { 0.0 })
        }
        "two-slab" => {
            let [a, b] = params.densities.unwrap_or([0.25, 1.0]);
            Box::new(move |q: Vec3| if q.x < 0.5 { a } else { b })
        }
        "sphere" => {
            let r = params.radius.unwrap_or(0.4);
            Box::new(move |q: Vec3| {
                if (q - Vec3::splat(0.5)).length() <= r {
                    density
                } else {
                    0.0
                }
            })
        }
        "engine" => Box::new(|q| quantize(engine(q))),
        "foot" => Box::new(|q| quantize(foot(q))),
        "head" => Box::new(|q| quantize(head(q))),
        "orientation" => Box::new(|q| quantize(orientation(q))),
        _ => unreachable!("validated above"),
    };
    let mut values = vec![0.0f32; nx * ny * nz];
    values
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(z, slice)| {
            for y in 0..ny {
                for x in 0..nx {
                    let q = Vec3::new(
                        (x as f32 + 0.5) / nx as f32,
                        (y as f32 + 0.5) / ny as f32,
                        (z as f32 + 0.5) / nz as f32,
                    );
                    slice[x + nx * y] = shape(q);
                }
            }
        });
    Volume::from_raw_values(
        params.resolution,
        values,
        None,
        Normalization::TypeRange,
        Placement::Spacing([1.0; 3]),
        VolumeSource::Phantom {
            name: params.name.clone(),
            parameters: params.describe(),
        },
    )
}

/// Rounds to the nearest 8-bit level, as stored scans are.
fn quantize(v: f32) -> f32 {
    (v.clamp(0.0, 1.0) * 255.0).round() / 255.0
}

/// Smooth deterministic value noise in `[-1, 1]` (hash of lattice points, trilinear).
fn noise(p: Vec3) -> f32 {
    fn hash(x: i32, y: i32, z: i32) -> f32 {
        let mut h = (x as u32).wrapping_mul(0x8da6_b343)
            ^ (y as u32).wrapping_mul(0xd816_3841)
            ^ (z as u32).wrapping_mul(0xcb1a_b31f);
        h ^= h >> 13;
        h = h.wrapping_mul(0x5bd1_e995);
        h ^= h >> 15;
        (h & 0xffff) as f32 / 32767.5 - 1.0
    }
    let f = p.floor();
    let t = p - f;
    let s = t * t * (Vec3::splat(3.0) - 2.0 * t);
    let (x, y, z) = (f.x as i32, f.y as i32, f.z as i32);
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let c = |dx, dy, dz| hash(x + dx, y + dy, z + dz);
    lerp(
        lerp(
            lerp(c(0, 0, 0), c(1, 0, 0), s.x),
            lerp(c(0, 1, 0), c(1, 1, 0), s.x),
            s.y,
        ),
        lerp(
            lerp(c(0, 0, 1), c(1, 0, 1), s.x),
            lerp(c(0, 1, 1), c(1, 1, 1), s.x),
            s.y,
        ),
        s.z,
    )
}

/// Distance from `p` to the segment `a..b`.
fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).length()
}

/// An engine-like metal block with two cylindrical bores along y, each lined by a denser
/// wall, plus a small oil channel; air is 0 (cf. the `engine` CT scan).
fn engine(q: Vec3) -> f32 {
    let inside_block =
        q.x > 0.12 && q.x < 0.88 && q.y > 0.15 && q.y < 0.85 && q.z > 0.28 && q.z < 0.72;
    if !inside_block {
        return 0.0;
    }
    let mut d = 0.42 + 0.03 * noise(q * 24.0);
    for cx in [0.34f32, 0.66] {
        let r = ((q.x - cx).powi(2) + (q.z - 0.5).powi(2)).sqrt();
        if r < 0.12 {
            return 0.0; // the bore
        }
        if r < 0.145 {
            d = 0.85; // cylinder liner
        }
    }
    // An oil channel along x.
    if ((q.y - 0.25).powi(2) + (q.z - 0.36).powi(2)).sqrt() < 0.025 {
        return 0.0;
    }
    d
}

/// A foot-like set of bones (calcaneus, talus, five metatarsals with phalanges) inside soft
/// tissue. Bones have a dense cortex and a lighter marrow.
fn foot(q: Vec3) -> f32 {
    // Soft tissue: a rounded slab around the bones, toes towards +y.
    let tissue_axis = (Vec3::new(0.5, 0.16, 0.32), Vec3::new(0.5, 0.8, 0.3));
    let td = segment_distance(q, tissue_axis.0, tissue_axis.1);
    let widen = 0.12 + 0.1 * ((q.y - 0.16) / 0.64).clamp(0.0, 1.0);
    let in_tissue = {
        let dx = (q.x - 0.5) / widen;
        let dz = (q.z - 0.32) / 0.14;
        (dx * dx + dz * dz).sqrt() < 1.0 && q.y > 0.08 && q.y < 0.9
    } || td < 0.1;
    let mut d: f32 = if in_tissue {
        0.16 + 0.02 * noise(q * 30.0)
    } else {
        0.0
    };
    let mut bone = |dist: f32, radius: f32| {
        if dist < radius {
            let cortex = dist > radius * 0.65;
            d = d.max(if cortex { 0.9 } else { 0.55 } + 0.03 * noise(q * 40.0));
        }
    };
    bone(
        segment_distance(q, Vec3::new(0.5, 0.12, 0.3), Vec3::new(0.5, 0.26, 0.36)),
        0.06,
    ); // calcaneus
    bone(
        segment_distance(q, Vec3::new(0.5, 0.24, 0.42), Vec3::new(0.5, 0.36, 0.38)),
        0.045,
    ); // talus
    for i in 0..5 {
        let x = 0.37 + 0.065 * i as f32;
        let base = Vec3::new(0.5 + (x - 0.5) * 0.45, 0.38, 0.36);
        let head = Vec3::new(x, 0.64, 0.3);
        let tip = Vec3::new(x + (x - 0.5) * 0.1, 0.82, 0.27);
        bone(segment_distance(q, base, head), 0.022);
        bone(
            segment_distance(q, head + Vec3::new(0.0, 0.02, 0.0), tip),
            0.016,
        );
    }
    d
}

/// A head-like skull shell with skin, brain, two orbits and air-filled sinuses; the face
/// looks towards −y.
fn head(q: Vec3) -> f32 {
    let c = Vec3::new(0.5, 0.52, 0.5);
    let radii = Vec3::new(0.36, 0.42, 0.4);
    let r = ((q - c) / radii).length();
    if r > 1.0 {
        return 0.0;
    }
    let orbit = |x: f32| (q - Vec3::new(x, 0.16, 0.56)).length() < 0.075;
    if orbit(0.38) || orbit(0.62) {
        return 0.05; // orbital fat, nearly transparent
    }
    // Frontal and maxillary sinuses: air pockets behind the face.
    if (q - Vec3::new(0.5, 0.2, 0.68)).length() < 0.05
        || (q - Vec3::new(0.42, 0.2, 0.42)).length() < 0.045
        || (q - Vec3::new(0.58, 0.2, 0.42)).length() < 0.045
    {
        return 0.0;
    }
    if r > 0.95 {
        0.2 + 0.02 * noise(q * 30.0) // skin
    } else if r > 0.85 {
        0.92 + 0.03 * noise(q * 40.0) // skull
    } else {
        0.38 + 0.05 * noise(q * 12.0) // brain
    }
}

/// Asymmetric markers: a big cube towards +x, a sphere towards +y, a thin rod towards +z, so
/// that flipped or swapped axes are visible in an image.
fn orientation(q: Vec3) -> f32 {
    if (q - Vec3::new(0.8, 0.5, 0.5)).abs().max_element() < 0.12 {
        return 1.0;
    }
    if (q - Vec3::new(0.5, 0.8, 0.5)).length() < 0.1 {
        return 0.6;
    }
    if (q.x - 0.5).abs() < 0.04 && (q.y - 0.5).abs() < 0.04 && q.z > 0.55 && q.z < 0.95 {
        return 0.3;
    }
    0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_quantised() {
        let a = generate(&PhantomParams::named("foot", 24)).unwrap();
        let b = generate(&PhantomParams::named("foot", 24)).unwrap();
        assert_eq!(a.grid().values(), b.grid().values());
        for &v in a.grid().values() {
            assert!((v * 255.0 - (v * 255.0).round()).abs() < 1e-4);
        }
        assert!(a.grid().min_positive().unwrap() > 0.0);
    }

    #[test]
    fn engine_has_two_empty_bores() {
        let v = generate(&PhantomParams::named("engine", 64)).unwrap();
        let g = v.grid();
        // Points on the bore axes are air; the block between them is metal.
        let bore = g.trilinear(Vec3::new(0.34, 0.5, 0.5));
        let other_bore = g.trilinear(Vec3::new(0.66, 0.5, 0.5));
        let metal = g.trilinear(Vec3::new(0.5, 0.5, 0.5));
        assert_eq!(bore, 0.0);
        assert_eq!(other_bore, 0.0);
        assert!(metal > 0.3, "{metal}");
    }

    #[test]
    fn head_has_skull_shell_and_orbits() {
        let v = generate(&PhantomParams::named("head", 64)).unwrap();
        let g = v.grid();
        let skull = g.nearest(Vec3::new(0.5, 0.52, 0.5 + 0.9 * 0.4));
        let brain = g.nearest(Vec3::new(0.5, 0.52, 0.5));
        let orbit = g.nearest(Vec3::new(0.38, 0.16, 0.56));
        assert!(skull > 0.8, "{skull}");
        assert!((0.3..0.5).contains(&brain), "{brain}");
        assert!(orbit < 0.1, "{orbit}");
    }

    #[test]
    fn two_slab_is_exact() {
        let mut p = PhantomParams::named("two-slab", 8);
        p.densities = Some([0.2, 0.8]);
        let v = generate(&p).unwrap();
        assert_eq!(v.grid().voxel(3, 0, 0), 0.2);
        assert_eq!(v.grid().voxel(4, 7, 7), 0.8);
    }

    #[test]
    fn bad_parameters_are_named() {
        let mut p = PhantomParams::named("sphere", 8);
        p.radius = Some(0.9);
        let e = generate(&p).unwrap_err().to_string();
        assert!(e.contains("phantom.radius") && e.contains("0.9"), "{e}");
        let e = generate(&PhantomParams::named("teapot", 8))
            .unwrap_err()
            .to_string();
        assert!(e.contains("teapot") && e.contains("engine"), "{e}");
        let mut p = PhantomParams::named("engine", 8);
        p.density = Some(0.5);
        let e = generate(&p).unwrap_err().to_string();
        assert!(e.contains("phantom.density"), "{e}");
    }
}
