//! A scene for another renderer: Mitsuba 3, so that a peer renders exactly what volphot
//! renders ([`export_mitsuba`]).
//!
//! Conventions, each checked against Mitsuba 3.9.1's sources and renders and pinned by the
//! tests below:
//! * the grid is the *transferred* density (the transfer function applied per voxel, as
//!   volphot does before interpolating), written as a `.vol` file: `VOL`, version 3,
//!   encoding 1 (float32), resolution, 1 channel, the box, then the values with x fastest;
//!   `sigma_t = scale · grid` with `scale` = volphot's σt per unit density;
//! * Mitsuba places voxel `i` at `(i + ½)/n` of the box, interpolates between centres and
//!   clamps beyond them — volphot's reconstruction exactly; the file's box is ignored by
//!   Mitsuba, so the grid's `to_world` maps the unit cube onto the volume box, and the
//!   medium's boundary is a `null` cube on the same box;
//! * the camera's `fov` is vertical (`fov_axis = "y"`; Mitsuba's default is x), its film
//!   uses a box filter (default: Gaussian) and float32;
//! * spot lights give both angles explicitly (Mitsuba's `beam_width` defaults to 0.75 ×
//!   cutoff, volphot's to 0.8 × cone); both fall off linearly in angle from the beam width
//!   to the cutoff, and `intensity` is radiant intensity on the axis in W/sr;
//! * `volpath` with `max_depth` 2 renders single scattering (one medium vertex plus next-
//!   event estimation), −1 everything; `$max_depth`, `$spp` and `$seed` are parameters of
//!   the XML (`mi.load_file(path, max_depth=2)`);
//! * coordinates are volphot's, except for a clipped volume: its export is centred on the
//!   volume and scaled to [`CLIPPED_EXPORT_SIZE`] (the image is the same), so that
//!   Mitsuba's ray-spawn offset skips less of the medium behind a cut face.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::{AreaLight, AreaShape, Light, LightKind, Scene, SceneParams};
use crate::error::{Error, Result};
use crate::math::Aabb;
use crate::medium::Medium;
use crate::util::write_atomic;
use crate::volume::Reconstruction;

/// The files [`export_mitsuba`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MitsubaExport {
    /// The scene (Mitsuba XML, version 3.0.0).
    pub scene: PathBuf,
    /// The density grid it reads.
    pub grid: PathBuf,
    /// The environment maps it reads (PFM), one per environment light.
    pub maps: Vec<PathBuf>,
    /// The clipped region's boundary (OBJ) that holds the medium, with `[clip]`.
    pub clip: Option<PathBuf>,
}

/// Writes `scene` for Mitsuba 3 into `dir` as `NAME.xml` and `NAME.vol`.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use std::path::Path;
/// use volphot::{Scene, SceneParams, SearchPath, export_mitsuba};
/// let toml = "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[three_point]\n";
/// let params = SceneParams::from_toml(toml, Path::new("inline.toml"))?;
/// let scene = Scene::from_params(&params, Path::new("."), &SearchPath::new(vec![]))?;
/// let dir = std::env::temp_dir().join(format!("volphot-export-doc-{}", std::process::id()));
/// let files = export_mitsuba(&scene, &dir, "sphere")?;
/// assert!(std::fs::read_to_string(&files.scene)?.contains("<string name=\"fov_axis\" value=\"y\"/>"));
/// assert_eq!(std::fs::metadata(&files.grid)?.len(), 48 + 4 * 8 * 8 * 8);
/// # std::fs::remove_dir_all(dir)?;
/// # Ok(())
/// # }
/// ```
pub fn export_mitsuba(scene: &Scene, dir: &Path, name: &str) -> Result<MitsubaExport> {
    check_exportable(scene)?;
    let frame = ExportFrame::of(scene);
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let grid = dir.join(format!("{name}.vol"));
    let xml = dir.join(format!("{name}.xml"));
    write_atomic(&grid, &vol_bytes(scene))?;
    let mut env_files = Vec::new();
    let mut maps = Vec::new();
    for (i, light) in scene.lights().iter().enumerate() {
        env_files.push(match light {
            Light::Environment(e) => {
                let file = format!("{name}-env{i}.pfm");
                let (w, h, texels) =
                    mitsuba_texels(e).map_err(|e| e.within(&format!("lights[{i}]")))?;
                crate::util::write_pfm(&dir.join(&file), w, h, &texels)?;
                maps.push(dir.join(&file));
                Some(file)
            }
            _ => None,
        });
    }
    let clip = match scene.medium().clip_region() {
        Some(region) => {
            let bounds = scene.medium().bounds();
            let margin = CUBE_MARGIN * bounds.extent().max_element();
            let path = dir.join(format!("{name}-clip.obj"));
            write_atomic(
                &path,
                clip_obj(&region.with_margin_on(bounds, margin), frame).as_bytes(),
            )?;
            Some(path)
        }
        None => None,
    };
    let clip_file = clip.as_ref().map(|_| format!("{name}-clip.obj"));
    let text = scene_xml(
        scene,
        frame,
        &format!("{name}.vol"),
        &env_files,
        clip_file.as_deref(),
    );
    write_atomic(&xml, text.as_bytes())?;
    Ok(MitsubaExport {
        scene: xml,
        grid,
        maps,
        clip,
    })
}

/// What Mitsuba's volumetric path tracer cannot render the same way is refused, naming the
/// key.
fn check_exportable(scene: &Scene) -> Result<()> {
    let base = scene.params().sigma.emission.unwrap_or([0.0; 3]);
    let emits = scene.integrator().emission && base != [0.0; 3];
    if emits {
        return Err(Error::parameter(
            "integrator.emission",
            "true",
            "false for Mitsuba: its heterogeneous medium does not emit",
        ));
    }
    for (i, light) in scene.lights().iter().enumerate() {
        if let super::Light::Spot(s) = light
            && s.falloff_shape() != super::SpotFalloff::Linear
        {
            return Err(pbrt_falloff_refused(i, s, light));
        }
        if let Light::Environment(e) = light
            && e.sun().is_some()
        {
            return Err(Error::parameter(
                format!("lights[{i}].sun_direction"),
                "(a sun)",
                "no sun for the Mitsuba export: Mitsuba has no emitter for a disc of the sky; export the sky without its sun",
            ));
        }
    }
    if scene.medium().has_colour() {
        return Err(Error::parameter(
            "transfer",
            scene.medium().transfer_description(),
            "a grey transfer function for the Mitsuba export (a per-voxel colour albedo is not exported)",
        ));
    }
    Ok(())
}

/// Why a spot light with pbrt-v1's falloff is not exported, and what switching it to
/// Mitsuba's linear falloff would change, measured on this light. The export refuses
/// rather than approximate: a peer comparison is only worth its numbers when both
/// renderers render the same scene, so the user switches the falloff in a copy of the
/// scene that volphot renders too.
fn pbrt_falloff_refused(i: usize, spot: &super::SpotLight, light: &super::Light) -> Error {
    let params = light.params();
    // The angles as written (they come back from radians with a rounding error).
    let degrees = |a: Option<f32>| (a.unwrap_or_default() as f64 * 1e4).round() / 1e4;
    let (beam, cone) = (degrees(params.beam_width), degrees(params.cone_angle));
    // Both falloffs are 1 inside the beam; they differ over the band out to the cone.
    let inside = 2.0 * std::f64::consts::PI * (1.0 - beam.to_radians().cos());
    let pbrt = spot.solid_angle_weight() as f64;
    let linear = spot
        .with_falloff(super::SpotFalloff::Linear)
        .solid_angle_weight() as f64;
    let band = (linear - inside) / (pbrt - inside).max(f64::MIN_POSITIVE);
    Error::parameter(
        format!("lights[{i}].falloff"),
        "\"pbrt\"",
        format!(
            "\"linear\" for Mitsuba, whose spot light's falloff is linear in the angle from `beam_width` to `cone_angle`; pbrt-v1's falloff (the thesis's scenes, `sweep import`) is quartic in cos θ over that band (pbrt's `conedeltaangle`): ((cos θ − cos θc)/(cos θw − cos θc))⁴, darker towards the rim. For this light (beam_width {beam}°, cone_angle {cone}°) the linear falloff sends {band:.1}× the band's light and {whole:+.0} % of the light's whole output (∫ falloff dω = {linear:.4} sr against {pbrt:.4} sr), so Mitsuba would light the volume brighter at the spot's rim than volphot renders it. To compare the renderers, set `falloff = \"linear\"` on this light in a copy of the scene and render that copy with volphot as well",
            whole = 100.0 * (linear / pbrt - 1.0),
        ),
    )
}

/// The transferred density grid as a Mitsuba `.vol` file.
fn vol_bytes(scene: &Scene) -> Vec<u8> {
    let grid = scene.medium().density_grid();
    let [nx, ny, nz] = grid.dims();
    let bounds = grid.bounds();
    let mut bytes = Vec::with_capacity(48 + 4 * grid.values().len());
    bytes.extend_from_slice(b"VOL");
    bytes.push(3);
    bytes.extend_from_slice(&1i32.to_le_bytes());
    for n in [nx, ny, nz, 1] {
        bytes.extend_from_slice(&(n as i32).to_le_bytes());
    }
    for v in bounds
        .min
        .to_array()
        .into_iter()
        .chain(bounds.max.to_array())
    {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    // volphot's grid is x fastest, as the format wants.
    for v in grid.values() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes
}

/// Three numbers as Mitsuba writes them: `x, y, z` (shortest round-trip decimals).
fn triple(v: [f32; 3]) -> String {
    format!("{}, {}, {}", v[0], v[1], v[2])
}

/// The largest extent of a clipped volume's box in its export (see [`ExportFrame`]).
pub const CLIPPED_EXPORT_SIZE: f32 = 100.0;

/// Where the export places volphot's world in Mitsuba's: `p ↦ scale · (p − centre)`; the
/// identity unless the medium is clipped. A clipped medium is held by its region's mesh,
/// whose cut faces lie where the medium is not empty beyond, and a camera ray entering
/// through one skips Mitsuba's ray-spawn offset, about `(1 + max|p|)·0.9·10⁻⁴`, of it: on
/// the opened foot at σt 80 that darkened Mitsuba's image by a percent (docs/peer.md).
/// Centred on the volume and scaled to [`CLIPPED_EXPORT_SIZE`], the skipped optical depth
/// is `σt·ε·(1/scale + max|p − centre|)` in volphot's units instead of `σt·ε·(1 + max|p|)`,
/// a fifth of it on that cut. Lengths scale by `scale`, σt by `1/scale` and a delta
/// light's intensity by `scale²` (its irradiance falls as `1/r²`); radiance and
/// directions do not change, so the image does not.
#[derive(Debug, Clone, Copy)]
struct ExportFrame {
    centre: Vec3,
    scale: f32,
}

impl ExportFrame {
    fn of(scene: &Scene) -> Self {
        let bounds = scene.medium().bounds();
        match scene.medium().clip_region() {
            Some(_) => ExportFrame {
                centre: bounds.center(),
                scale: CLIPPED_EXPORT_SIZE / bounds.extent().max_element(),
            },
            None => ExportFrame {
                centre: Vec3::ZERO,
                scale: 1.0,
            },
        }
    }

    fn point(self, p: Vec3) -> Vec3 {
        (p - self.centre) * self.scale
    }

    fn point_array(self, p: [f32; 3]) -> [f32; 3] {
        self.point(Vec3::from(p)).to_array()
    }
}

/// The scene as Mitsuba 3 XML.
fn scene_xml(
    scene: &Scene,
    frame: ExportFrame,
    grid_file: &str,
    env_files: &[Option<String>],
    clip_mesh: Option<&str>,
) -> String {
    let mut x = String::new();
    let extended = scene.lights().iter().any(|l| !l.is_delta());
    integrator_xml(&mut x, scene.params(), extended);
    sensor_xml(&mut x, scene, frame);
    medium_xml(&mut x, scene.medium(), grid_file, frame);
    match clip_mesh {
        Some(file) => clip_mesh_xml(&mut x, file),
        None => bounding_cube_xml(&mut x, scene.medium().bounds(), frame),
    }
    for (i, light) in scene.lights().iter().enumerate() {
        emitter_xml(&mut x, light, env_files[i].as_deref(), frame);
    }
    let _ = writeln!(x, "</scene>");
    x
}

/// The scene's opening, its defaults (`spp`, `max_depth`, `seed`) and the `volpath`
/// integrator.
fn integrator_xml(x: &mut String, p: &SceneParams, hide_emitters: bool) {
    let _ = writeln!(x, "<scene version=\"3.0.0\">");
    let _ = writeln!(
        x,
        "    <!-- Written by volphot {} (sweep export); conventions: volphot's scene/export.rs. -->",
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        x,
        "    <default name=\"spp\" value=\"{}\"/>",
        p.integrator.reference_spp
    );
    let _ = writeln!(x, "    <default name=\"max_depth\" value=\"-1\"/>");
    let _ = writeln!(
        x,
        "    <default name=\"seed\" value=\"{}\"/>",
        p.integrator.seed
    );
    let _ = writeln!(x, "    <integrator type=\"volpath\">");
    let _ = writeln!(
        x,
        "        <integer name=\"max_depth\" value=\"$max_depth\"/>"
    );
    if hide_emitters {
        // volphot's camera rays do not see area lights or the environment.
        let _ = writeln!(
            x,
            "        <boolean name=\"hide_emitters\" value=\"true\"/>"
        );
    }
    let _ = writeln!(x, "    </integrator>");
}

/// The heterogeneous medium: the σt grid file over the volume's box, scaled by
/// `sigma_t_base`, with the albedo and phase function.
fn medium_xml(x: &mut String, medium: &Medium, grid_file: &str, frame: ExportFrame) {
    let bounds = medium.bounds();
    let _ = writeln!(x, "    <medium type=\"heterogeneous\" id=\"medium\">");
    let _ = writeln!(x, "        <volume type=\"gridvolume\" name=\"sigma_t\">");
    let _ = writeln!(
        x,
        "            <string name=\"filename\" value=\"{}\"/>",
        xml_attribute(grid_file)
    );
    let filter = match medium.reconstruction() {
        Reconstruction::Trilinear => "trilinear",
        Reconstruction::Nearest => "nearest",
    };
    let _ = writeln!(
        x,
        "            <string name=\"filter_type\" value=\"{filter}\"/>"
    );
    let _ = writeln!(x, "            <transform name=\"to_world\">");
    let _ = writeln!(
        x,
        "                <scale value=\"{}\"/>",
        triple((bounds.extent() * frame.scale).to_array())
    );
    let _ = writeln!(
        x,
        "                <translate value=\"{}\"/>",
        triple(frame.point(bounds.min).to_array())
    );
    let _ = writeln!(x, "            </transform>");
    let _ = writeln!(x, "        </volume>");
    let _ = writeln!(
        x,
        "        <float name=\"scale\" value=\"{}\"/>",
        medium.sigma_t_base() / frame.scale
    );
    let _ = writeln!(
        x,
        "        <rgb name=\"albedo\" value=\"{}\"/>",
        triple(medium.albedo().to_array())
    );
    match medium.phase().g() {
        0.0 => {
            let _ = writeln!(x, "        <phase type=\"isotropic\"/>");
        }
        g => {
            let _ = writeln!(
                x,
                "        <phase type=\"hg\"><float name=\"g\" value=\"{g}\"/></phase>"
            );
        }
    }
    let _ = writeln!(x, "    </medium>");
}

/// How far the null cube reaches past the volume's box, as a share of its largest extent.
/// A camera ray that crosses the cube is spawned again a little past its face (Mitsuba's
/// `spawn_ray` offsets the origin by about 1.5·10⁻⁴ for unit-sized scenes) and samples the
/// medium only from there: with the cube on the box's faces, the first 0.04 voxel of dense
/// bone touching a face was never scattered in, and the real foot at σt(d_min) 80 came out
/// 0.37 % darker in Mitsuba than in volphot. The grid keeps the box's extent (outside it the
/// medium is empty), so a larger cube changes nothing else.
pub const CUBE_MARGIN: f32 = 0.01;

/// A clipped volume's region as an OBJ mesh (each convex face a fan of triangles, wound
/// counter-clockwise seen from outside, so its normals point out of the medium).
fn clip_obj(region: &crate::medium::ClipRegion, frame: ExportFrame) -> String {
    let mut obj = String::from("# volphot: the clipped region that holds the medium\n");
    let mut base = 1;
    for face in region.faces() {
        for v in face.iter().map(|&v| frame.point(v)) {
            let _ = writeln!(obj, "v {} {} {}", v.x, v.y, v.z);
        }
        for i in 1..face.len() - 1 {
            let _ = writeln!(obj, "f {} {} {}", base, base + i, base + i + 1);
        }
        base += face.len();
    }
    obj
}

/// The clipped region holds the medium: a null BSDF on its boundary, the geometric clip
/// exactly (the grid itself is the whole volume's). A face on a cut plane meets Mitsuba's
/// ray-spawn offset, which [`ExportFrame`] shrinks; the faces on the volume's box are
/// pushed out by [`CUBE_MARGIN`] as the cube's are.
fn clip_mesh_xml(x: &mut String, file: &str) {
    let _ = writeln!(x, "    <shape type=\"obj\">");
    let _ = writeln!(
        x,
        "        <string name=\"filename\" value=\"{}\"/>",
        xml_attribute(file)
    );
    let _ = writeln!(x, "        <boolean name=\"face_normals\" value=\"true\"/>");
    let _ = writeln!(x, "        <bsdf type=\"null\"/>");
    let _ = writeln!(x, "        <ref name=\"interior\" id=\"medium\"/>");
    let _ = writeln!(x, "    </shape>");
}

/// The cube that holds the medium: a null BSDF a little past the volume's box.
fn bounding_cube_xml(x: &mut String, bounds: Aabb, frame: ExportFrame) {
    let margin = CUBE_MARGIN * bounds.extent().max_element();
    let (centre, half) = (
        frame.point(bounds.center()),
        (bounds.extent() * 0.5 + Vec3::splat(margin)) * frame.scale,
    );
    let _ = writeln!(x, "    <shape type=\"cube\">");
    let _ = writeln!(x, "        <transform name=\"to_world\">");
    let _ = writeln!(
        x,
        "            <scale value=\"{}\"/>",
        triple(half.to_array())
    );
    let _ = writeln!(
        x,
        "            <translate value=\"{}\"/>",
        triple(centre.to_array())
    );
    let _ = writeln!(x, "        </transform>");
    let _ = writeln!(x, "        <bsdf type=\"null\"/>");
    let _ = writeln!(x, "        <ref name=\"interior\" id=\"medium\"/>");
    let _ = writeln!(x, "    </shape>");
}

fn sensor_xml(x: &mut String, scene: &Scene, frame: ExportFrame) {
    let c = &scene.params().camera;
    let _ = writeln!(x, "    <sensor type=\"perspective\">");
    let _ = writeln!(x, "        <float name=\"fov\" value=\"{}\"/>", c.fov);
    let _ = writeln!(x, "        <string name=\"fov_axis\" value=\"y\"/>");
    let _ = writeln!(
        x,
        "        <float name=\"near_clip\" value=\"{}\"/>",
        1e-4 * frame.scale
    );
    let _ = writeln!(x, "        <transform name=\"to_world\">");
    let _ = writeln!(
        x,
        "            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>",
        triple(frame.point_array(c.eye)),
        triple(frame.point_array(c.look_at)),
        triple(c.up)
    );
    let _ = writeln!(x, "        </transform>");
    let _ = writeln!(x, "        <film type=\"hdrfilm\">");
    let _ = writeln!(
        x,
        "            <integer name=\"width\" value=\"{}\"/>",
        c.resolution[0]
    );
    let _ = writeln!(
        x,
        "            <integer name=\"height\" value=\"{}\"/>",
        c.resolution[1]
    );
    let _ = writeln!(
        x,
        "            <string name=\"pixel_format\" value=\"rgb\"/>"
    );
    let _ = writeln!(
        x,
        "            <string name=\"component_format\" value=\"float32\"/>"
    );
    let _ = writeln!(x, "            <rfilter type=\"box\"/>");
    let _ = writeln!(x, "        </film>");
    let _ = writeln!(x, "        <sampler type=\"independent\">");
    let _ = writeln!(
        x,
        "            <integer name=\"sample_count\" value=\"$spp\"/>"
    );
    let _ = writeln!(x, "            <integer name=\"seed\" value=\"$seed\"/>");
    let _ = writeln!(x, "        </sampler>");
    let _ = writeln!(x, "    </sensor>");
}

fn emitter_xml(x: &mut String, light: &Light, env_file: Option<&str>, frame: ExportFrame) {
    match light {
        Light::Point(_) | Light::Spot(_) => delta_emitter_xml(x, &light.params(), frame),
        Light::Area(a) => area_emitter_xml(x, a, frame),
        Light::Environment(e) => {
            let _ = writeln!(x, "    <emitter type=\"envmap\">");
            let file = env_file.expect("an environment's map file");
            let _ = writeln!(
                x,
                "        <string name=\"filename\" value=\"{}\"/>",
                xml_attribute(file)
            );
            let _ = writeln!(x, "        <transform name=\"to_world\">");
            let [c0, c1, c2] = e.to_world_columns();
            let _ = writeln!(
                x,
                "            <matrix value=\"{} 0  {} 0  {} 0  0 0 0 1\"/>",
                row(c0.x, c1.x, c2.x),
                row(c0.y, c1.y, c2.y),
                row(c0.z, c1.z, c2.z)
            );
            let _ = writeln!(x, "        </transform>");
            let _ = writeln!(x, "    </emitter>");
        }
    }
}

/// The environment volphot samples (a sky's bake or a file's texels, times `scale`) as
/// Mitsuba's `envmap` reads it. volphot looks texels up nearest, row `j` covering
/// `θ ∈ [j, j + 1]·π/H`; Mitsuba interpolates bilinearly with row `j` centred at
/// `θ = j·π/(H − 1)` (and columns centred as volphot's). So the map is written `k` times
/// finer (`k` ≤ 4, at most 4096 columns) with `k·H + 1` rows, each the volphot texel at its
/// own centre — and a row that falls exactly on the edge of two texel rows the mean of the
/// two: Mitsuba then blends from one texel row to the other symmetrically about the edge,
/// over a `k`-th of a texel on each side, and each band's integral and centroid are
/// volphot's. (The nearest texel there, the lower one, put the whole blend on the zenith
/// side: the map moved `1/(2k)` of a texel towards the zenith, and lost light wherever a
/// bright row lay below a dark one — 0.9 % of a map with a bright patch.)
///
/// A texel that the scale makes infinite is refused, naming `scale` (loading keeps every
/// environment within 1e20 W/m²/sr, so only a light built otherwise can get here).
fn mitsuba_texels(env: &super::EnvironmentLight) -> Result<(usize, usize, Vec<Vec3>)> {
    let map = env.map();
    let (w, h) = (map.width(), map.height());
    let k = (4096 / w).clamp(1, 4);
    let (wk, hk) = (w * k, h * k + 1);
    if let Some(i) = map
        .texels()
        .iter()
        .position(|t| !(*t * env.scale()).is_finite())
    {
        return Err(Error::parameter(
            "scale",
            format!("{:?}", env.scale().to_array()),
            format!(
                "a scale that keeps every texel finite for the Mitsuba export: texel (column {}, row {}) = {:?} becomes {:?}",
                i % w,
                i / w,
                map.texels()[i].to_array(),
                (map.texels()[i] * env.scale()).to_array()
            ),
        ));
    }
    let texel = |row: usize, col: usize| map.texels()[row * w + col / k] * env.scale();
    // Row `r` lies at `r/k` texel rows from the zenith: inside texel row `r/k`, or on the
    // edge of rows `r/k − 1` and `r/k` when `k` divides it (the poles excepted).
    let texels = (0..hk)
        .flat_map(|r| {
            let (source, on_edge) = ((r / k).min(h - 1), r % k == 0 && r > 0 && r < hk - 1);
            (0..wk).map(move |col| {
                if on_edge {
                    (texel(source - 1, col) + texel(source, col)) * 0.5
                } else {
                    texel(source, col)
                }
            })
        })
        .collect();
    Ok((wk, hk, texels))
}

/// `text` as the value of an XML attribute in double quotes: `&`, `<`, `>`, `"` and `'`
/// as entities (a scene file may be named `a"b<c>&d.toml`, and the export's file names
/// come from it).
fn xml_attribute(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// One row of a 3×3 block of a Mitsuba `matrix` value.
fn row(a: f32, b: f32, c: f32) -> String {
    format!("{a} {b} {c}")
}

/// A rectangle (`[-1, 1]²`, normal `+z` in Mitsuba) or disk (unit radius) shape placed by
/// a matrix, with an `area` emitter and a `null` BSDF: volphot's area lights neither block
/// nor reflect light.
fn area_emitter_xml(x: &mut String, a: &AreaLight, frame: ExportFrame) {
    let (shape, [sx, sy]) = match a.shape() {
        AreaShape::Rect => ("rectangle", [a.extent()[0] / 2.0, a.extent()[1] / 2.0]),
        AreaShape::Disc => ("disk", [a.extent()[0], a.extent()[0]]),
    };
    let (u, v, n, c) = (
        a.width_axis() * (sx * frame.scale),
        a.height_axis() * (sy * frame.scale),
        a.normal(),
        frame.point(a.centre()),
    );
    let _ = writeln!(x, "    <shape type=\"{shape}\">");
    let _ = writeln!(x, "        <transform name=\"to_world\">");
    let _ = writeln!(
        x,
        "            <matrix value=\"{} {}  {} {}  {} {}  0 0 0 1\"/>",
        row(u.x, v.x, n.x),
        c.x,
        row(u.y, v.y, n.y),
        c.y,
        row(u.z, v.z, n.z),
        c.z
    );
    let _ = writeln!(x, "        </transform>");
    let _ = writeln!(x, "        <bsdf type=\"null\"/>");
    let _ = writeln!(x, "        <emitter type=\"area\">");
    let _ = writeln!(
        x,
        "            <rgb name=\"radiance\" value=\"{}\"/>",
        triple(a.radiance().to_array())
    );
    let _ = writeln!(x, "        </emitter>");
    let _ = writeln!(x, "    </shape>");
}

fn delta_emitter_xml(x: &mut String, light: &super::LightParams, frame: ExportFrame) {
    let intensity = light.intensity.expect("a delta light's intensity").rgb();
    let intensity = triple((intensity * (frame.scale * frame.scale)).to_array());
    let position = frame.point_array(light.position.expect("a delta light's position"));
    match light.kind {
        LightKind::Spot => {
            let target = frame.point(Vec3::from(light.target.expect("a spot light has a target")));
            // Any up vector not parallel to the axis: Mitsuba's spot is symmetric about it.
            let axis = (target - Vec3::from(position)).normalize();
            let up = if axis.z.abs() < 0.9 { Vec3::Z } else { Vec3::X };
            let _ = writeln!(x, "    <emitter type=\"spot\">");
            let _ = writeln!(x, "        <transform name=\"to_world\">");
            let _ = writeln!(
                x,
                "            <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>",
                triple(position),
                triple(target.to_array()),
                triple(up.to_array())
            );
            let _ = writeln!(x, "        </transform>");
            let cone = light.cone_angle.expect("a spot light has a cone angle");
            let beam = light.beam_width.expect("a spot light has a beam width");
            let _ = writeln!(x, "        <float name=\"cutoff_angle\" value=\"{cone}\"/>");
            let _ = writeln!(x, "        <float name=\"beam_width\" value=\"{beam}\"/>");
        }
        _ => {
            let _ = writeln!(x, "    <emitter type=\"point\">");
            let _ = writeln!(
                x,
                "        <point name=\"position\" value=\"{}\"/>",
                triple(position)
            );
        }
    }
    let _ = writeln!(x, "        <rgb name=\"intensity\" value=\"{intensity}\"/>");
    let _ = writeln!(x, "    </emitter>");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util;

    fn exported() -> (tempfile::TempDir, Scene, MitsubaExport) {
        let scene = test_util::scene(
            "[volume]\nphantom = { name = \"sphere\", resolution = [8, 6, 5] }\n[camera]\nfov = 37\nresolution = [24, 16]\n[[lights]]\ntype = \"spot\"\nposition = [0.5, -1.5, 0.5]\ntarget = [0.5, 0.5, 0.5]\nintensity = [3, 4, 5]\ncone_angle = 25\nbeam_width = 10\n[[lights]]\ntype = \"point\"\nposition = [2, 0.5, 0.5]\nintensity = 7\n",
        );
        let dir = tempfile::tempdir().unwrap();
        let files = export_mitsuba(&scene, dir.path(), "peer").unwrap();
        (dir, scene, files)
    }

    #[test]
    fn the_grid_is_the_transferred_density_x_fastest_with_the_box() {
        let (_dir, scene, files) = exported();
        let bytes = std::fs::read(&files.grid).unwrap();
        let grid = scene.medium().density_grid();
        let [nx, ny, nz] = grid.dims();
        assert_eq!(&bytes[..4], b"VOL\x03");
        let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(
            [int(4), int(8), int(12), int(16), int(20)],
            [1, nx as i32, ny as i32, nz as i32, 1]
        );
        assert_eq!(
            [float(24), float(36)],
            [grid.bounds().min.x, grid.bounds().max.x]
        );
        assert_eq!(bytes.len(), 48 + 4 * nx * ny * nz);
        // Voxel (x, y, z) at ((z·ny + y)·nx + x): Mitsuba's order.
        for (x, y, z) in [
            (0, 0, 0),
            (nx - 1, 0, 0),
            (1, ny - 1, 2),
            (nx - 1, ny - 1, nz - 1),
        ] {
            let at = 48 + 4 * ((z * ny + y) * nx + x);
            assert_eq!(float(at), grid.voxel(x, y, z), "({x}, {y}, {z})");
        }
    }

    #[test]
    fn the_xml_pins_mitsubas_pitfalls() {
        let (_dir, scene, files) = exported();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        for expected in [
            "<string name=\"fov_axis\" value=\"y\"/>",
            "<float name=\"fov\" value=\"37\"/>",
            "<rfilter type=\"box\"/>",
            "<string name=\"component_format\" value=\"float32\"/>",
            "<integrator type=\"volpath\">",
            "<integer name=\"max_depth\" value=\"$max_depth\"/>",
            "<string name=\"filter_type\" value=\"trilinear\"/>",
            "<string name=\"filename\" value=\"peer.vol\"/>",
            "<float name=\"cutoff_angle\" value=\"25\"/>",
            "<float name=\"beam_width\" value=\"10\"/>",
            "<rgb name=\"intensity\" value=\"3, 4, 5\"/>",
            "<point name=\"position\" value=\"2, 0.5, 0.5\"/>",
            "<bsdf type=\"null\"/>",
            "<phase type=\"isotropic\"/>",
        ] {
            assert!(xml.contains(expected), "missing {expected} in\n{xml}");
        }
        let scale = format!(
            "<float name=\"scale\" value=\"{}\"/>",
            scene.medium().sigma_t_base()
        );
        assert!(xml.contains(&scale), "{xml}");
    }

    /// The real foot at σt(d_min) 80 was 0.37 % darker in Mitsuba: its camera rays restart
    /// about 1.5·10⁻⁴ past the null cube's face, so the cube must reach well past the box
    /// (where the medium is empty) for no dense voxel at a face to be skipped.
    #[test]
    fn the_null_cube_reaches_past_the_box_by_more_than_a_ray_offset() {
        let (_dir, scene, files) = exported();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        let cube = &xml[xml.find("<shape type=\"cube\">").unwrap()..];
        let scale = cube
            .split("<scale value=\"")
            .nth(1)
            .and_then(|s| s.split('"').next())
            .unwrap();
        let half: Vec<f32> = scale.split(", ").map(|v| v.parse().unwrap()).collect();
        let bounds = scene.medium().bounds();
        // Mitsuba's `offset_p`: (1 + max|p|) · 1500 · 2⁻²⁴ along the normal.
        let reach = bounds.max.abs().max(bounds.min.abs()).max_element();
        let offset = (1.0 + reach) * 1500.0 / (1u32 << 24) as f32;
        for (axis, h) in half.iter().enumerate() {
            let past = h - 0.5 * bounds.extent()[axis];
            assert!(
                past > 10.0 * offset,
                "axis {axis}: the cube reaches {past} past the box"
            );
        }
        // The grid itself keeps the box.
        assert!(xml.contains("<string name=\"filename\" value=\"peer.vol\"/>"));
    }

    #[test]
    fn emitting_media_are_refused_naming_the_key() {
        let scene = test_util::scene(&format!(
            "{}[sigma]\nemission = [1, 1, 1]\n[integrator]\nemission = true\n",
            test_util::SMALL_SCENE
        ));
        let dir = tempfile::tempdir().unwrap();
        let err = export_mitsuba(&scene, dir.path(), "x")
            .unwrap_err()
            .to_string();
        assert!(err.contains("integrator.emission"), "{err}");
    }

    /// `∫ falloff dω` of a spot light's band between `beam` and `cone` degrees, numerically:
    /// pbrt-v1's quartic in cos θ, or Mitsuba's linear in the angle.
    fn band_integral(beam: f64, cone: f64, pbrt: bool) -> f64 {
        let (tw, tc) = (beam.to_radians(), cone.to_radians());
        let n = 100_000;
        (0..n)
            .map(|k| {
                let t = tw + (tc - tw) * (k as f64 + 0.5) / n as f64;
                let f = if pbrt {
                    ((t.cos() - tc.cos()) / (tw.cos() - tc.cos())).powi(4)
                } else {
                    (tc - t) / (tc - tw)
                };
                2.0 * std::f64::consts::PI * f * t.sin() * (tc - tw) / n as f64
            })
            .sum()
    }

    #[test]
    fn a_pbrt_falloff_is_refused_saying_what_linear_would_change() {
        let scene = test_util::scene(
            "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[[lights]]\ntype = \"point\"\nposition = [2, 0.5, 0.5]\nintensity = 7\n[[lights]]\ntype = \"spot\"\nposition = [0.5, -1.5, 0.5]\ntarget = [0.5, 0.5, 0.5]\nintensity = 3\ncone_angle = 30\nbeam_width = 20\nfalloff = \"pbrt\"\n",
        );
        let dir = tempfile::tempdir().unwrap();
        let err = export_mitsuba(&scene, dir.path(), "x")
            .unwrap_err()
            .to_string();
        for expected in [
            "lights[1].falloff",
            "quartic in cos θ",
            "conedeltaangle",
            "linear in the angle",
            "falloff = \"linear\"",
        ] {
            assert!(err.contains(expected), "lacks `{expected}`: {err}");
        }
        // What switching changes, measured on this light: the band's light and the whole.
        let (pbrt, linear) = (
            band_integral(20.0, 30.0, true),
            band_integral(20.0, 30.0, false),
        );
        let core = 2.0 * std::f64::consts::PI * (1.0 - 20f64.to_radians().cos());
        let band = format!("{:.1}×", linear / pbrt);
        let whole = format!("{:.0} %", 100.0 * ((core + linear) / (core + pbrt) - 1.0));
        assert!(err.contains(&band), "lacks the band's ratio {band}: {err}");
        assert!(
            err.contains(&whole),
            "lacks the whole light's change {whole}: {err}"
        );
        assert!(!dir.path().join("x.xml").exists(), "nothing written");
    }

    /// A clipped volume's export is centred on the volume and scaled to
    /// [`CLIPPED_EXPORT_SIZE`]: points move, σt shrinks, a delta light's intensity grows by
    /// the scale's square; an unclipped export keeps volphot's coordinates.
    #[test]
    fn a_clipped_export_is_centred_and_scaled_so_the_cut_keeps_its_medium() {
        let lights = "[camera]\neye = [0.5, -2, 0.5]\nlook_at = [0.5, 0.5, 0.5]\nup = [0, 0, 1]\n[[lights]]\ntype = \"point\"\nposition = [2, 0.5, 0.5]\nintensity = 7\n[[lights]]\ntype = \"disc\"\nposition = [0.5, 0.5, 3]\nnormal = [0, 0, -1]\nradius = 0.5\nradiance = 4\n";
        let volume = "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n";
        let clipped = test_util::scene(&format!(
            "{volume}{lights}[clip]\nplane = {{ normal = [0, 1, 0], offset = 0.5 }}\n"
        ));
        let whole = test_util::scene(&format!("{volume}{lights}"));
        let dir = tempfile::tempdir().unwrap();
        let files = export_mitsuba(&clipped, dir.path(), "cut").unwrap();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        let s = CLIPPED_EXPORT_SIZE;
        for expected in [
            // The camera: (eye − centre)·s; near_clip scaled.
            format!("origin=\"0, {}, 0\"", -2.5 * s),
            "target=\"0, 0, 0\"".to_string(),
            format!("<float name=\"near_clip\" value=\"{}\"/>", 1e-4 * s),
            // The grid over the box, σt per unit of the scaled world.
            format!("<scale value=\"{s}, {s}, {s}\"/>"),
            format!("<translate value=\"{0}, {0}, {0}\"/>", -0.5 * s),
            format!(
                "<float name=\"scale\" value=\"{}\"/>",
                clipped.medium().sigma_t_base() / s
            ),
            // The point light moved, its intensity × s²; the disc's radiance kept.
            format!("value=\"{}, 0, 0\"", 1.5 * s),
            format!(
                "<rgb name=\"intensity\" value=\"{0}, {0}, {0}\"/>",
                7.0 * s * s
            ),
            "<rgb name=\"radiance\" value=\"4, 4, 4\"/>".to_string(),
        ] {
            assert!(xml.contains(&expected), "lacks `{expected}`: {xml}");
        }
        // The mesh: every vertex within the scaled box and its margin, the cut at y = 0.
        let obj = std::fs::read_to_string(files.clip.unwrap()).unwrap();
        let vertices: Vec<Vec3> = obj
            .lines()
            .filter_map(|l| l.strip_prefix("v "))
            .map(|l| {
                let v: Vec<f32> = l.split(' ').map(|x| x.parse().unwrap()).collect();
                Vec3::new(v[0], v[1], v[2])
            })
            .collect();
        let reach = 0.5 * s + CUBE_MARGIN * s + 1e-3;
        assert!(vertices.iter().all(|v| v.abs().max_element() <= reach));
        assert!(vertices.iter().any(|v| v.y.abs() < 1e-3), "the cut face");
        assert!(
            vertices.iter().all(|v| v.y >= -1e-3),
            "only what the clip keeps"
        );
        // Unclipped: volphot's own coordinates, as before.
        let files = export_mitsuba(&whole, dir.path(), "whole").unwrap();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        assert!(xml.contains("origin=\"0.5, -2, 0.5\""), "{xml}");
        assert!(xml.contains("<float name=\"near_clip\" value=\"0.0001\"/>"));
        assert!(xml.contains("<rgb name=\"intensity\" value=\"7, 7, 7\"/>"));
    }

    /// Area lights become shapes with an `area` emitter and a `null` BSDF placed by a
    /// matrix whose columns are the half extents and the normal; an environment becomes an
    /// `envmap` reading a PFM of exactly the texels volphot samples, with `to_world`'s
    /// columns the map's axes; camera rays hide them both, as volphot's do.
    #[test]
    fn area_and_environment_lights_export_as_mitsuba_emitters() {
        let scene = test_util::scene(
            "[volume]\nphantom = { name = \"sphere\", resolution = [8, 8, 8] }\n[[lights]]\ntype = \"rect\"\nposition = [0.5, 0.5, 2]\nnormal = [0, 0, -1]\nup = [0, 1, 0]\nsize = [2, 1]\nradiance = [1, 2, 3]\n[[lights]]\ntype = \"disc\"\nposition = [3, 0.5, 0.5]\ntarget = [0.5, 0.5, 0.5]\nradius = 0.25\nradiance = 4\n[[lights]]\ntype = \"sky\"\nzenith = 1\nhorizon = 0.5\nground = 0.1\nrotation = 90\n",
        );
        let dir = tempfile::tempdir().unwrap();
        let files = export_mitsuba(&scene, dir.path(), "peer").unwrap();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        assert!(
            xml.contains("<boolean name=\"hide_emitters\" value=\"true\"/>"),
            "{xml}"
        );
        assert!(xml.contains("<shape type=\"rectangle\">"), "{xml}");
        assert!(xml.contains("<shape type=\"disk\">"), "{xml}");
        // The two lights' and the medium's boundary cube's.
        assert_eq!(xml.matches("<bsdf type=\"null\"/>").count(), 3);
        assert!(
            xml.contains("<rgb name=\"radiance\" value=\"1, 2, 3\"/>"),
            "{xml}"
        );
        // The rectangle: width along −x (height × normal), height along y, normal −z.
        assert!(
            xml.contains("<matrix value=\"-1 0 0 0.5  0 0.5 0 0.5  0 0 -1 2  0 0 0 1\"/>"),
            "{xml}"
        );
        assert!(xml.contains("<emitter type=\"envmap\">"), "{xml}");
        assert_eq!(files.maps, vec![dir.path().join("peer-env2.pfm")]);
        let Light::Environment(env) = &scene.lights()[2] else {
            panic!("the sky")
        };
        // Four times finer, one more row: the poles and each texel's centre keep volphot's
        // values (Mitsuba's bilinear lookup there returns them).
        let (w, h, texels) = crate::util::read_pfm(&files.maps[0]).unwrap();
        let (mw, mh) = (env.map().width(), env.map().height());
        assert_eq!((w, h), (4 * mw, 4 * mh + 1));
        let ours = |row: usize, col: usize| env.map().texels()[row * mw + col];
        assert_eq!(texels[0], ours(0, 0));
        assert_eq!(texels[(h - 1) * w + w - 1], ours(mh - 1, mw - 1));
        assert_eq!(texels[(4 * 5 + 2) * w + 4 * 7 + 1], ours(5, 7));
        // The spot-only export is unchanged: no hide_emitters there.
        let (_dir, _, spot) = exported();
        let spot_xml = std::fs::read_to_string(&spot.scene).unwrap();
        assert!(!spot_xml.contains("hide_emitters"));
        assert!(spot.maps.is_empty());
    }

    /// Checks that `xml` is well formed as far as the export writes it: tags balanced,
    /// every attribute value double-quoted without `<`, `"` or a bare `&`.
    fn well_formed(xml: &str) -> std::result::Result<(), String> {
        let mut open: Vec<&str> = Vec::new();
        let mut rest = xml;
        while let Some(at) = rest.find('<') {
            rest = &rest[at + 1..];
            if let Some(comment) = rest.strip_prefix("!--") {
                let end = comment.find("-->").ok_or("unclosed comment")?;
                rest = &comment[end + 3..];
                continue;
            }
            let end = rest.find('>').ok_or("unclosed tag")?;
            let tag = &rest[..end];
            rest = &rest[end + 1..];
            if let Some(name) = tag.strip_prefix('/') {
                if open.pop() != Some(name) {
                    return Err(format!("</{name}> closes nothing open"));
                }
                continue;
            }
            let (body, empty) = match tag.strip_suffix('/') {
                Some(b) => (b, true),
                None => (tag, false),
            };
            let name = body.split_whitespace().next().ok_or("empty tag")?;
            let mut attributes = body[name.len()..].trim();
            while !attributes.is_empty() {
                let (_, after) = attributes
                    .split_once("=\"")
                    .ok_or(format!("attribute in <{tag}>"))?;
                let close = after.find('"').ok_or("unclosed value")?;
                let value = &after[..close];
                let entities = ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"];
                let bare = value
                    .match_indices('&')
                    .any(|(i, _)| !entities.iter().any(|e| value[i..].starts_with(e)));
                if value.contains('<') || bare {
                    return Err(format!("value `{value}` in <{tag}>"));
                }
                attributes = after[close + 1..].trim();
            }
            if !empty {
                open.push(name);
            }
        }
        if open.is_empty() {
            Ok(())
        } else {
            Err(format!("unclosed {open:?}"))
        }
    }

    /// A scene file named `a"b<c>&d.toml` exports as `a"b<c>&d.xml` whose file names are
    /// escaped attribute values: the XML stays well formed.
    #[test]
    fn file_names_with_markup_characters_are_escaped_in_the_xml() {
        let scene = test_util::scene(
            "[volume]\nphantom = { name = \"sphere\", resolution = [4, 4, 4] }\n[three_point]\n[[lights]]\ntype = \"sky\"\n[clip]\nplane = { normal = [1, 0, 0], offset = 0.5 }\n",
        );
        let dir = tempfile::tempdir().unwrap();
        let name = "a\"b<c>&d";
        let files = export_mitsuba(&scene, dir.path(), name).unwrap();
        let xml = std::fs::read_to_string(&files.scene).unwrap();
        well_formed(&xml).unwrap_or_else(|e| panic!("{e}:\n{xml}"));
        for file in [
            "a&quot;b&lt;c&gt;&amp;d.vol",
            "a&quot;b&lt;c&gt;&amp;d-env3.pfm",
            "a&quot;b&lt;c&gt;&amp;d-clip.obj",
        ] {
            assert!(xml.contains(&format!("value=\"{file}\"")), "{file}:\n{xml}");
        }
        assert!(dir.path().join("a\"b<c>&d-env3.pfm").is_file());
        assert!(well_formed("<a b=\"x\"y\"/>").is_err() && well_formed("<a b=\"&\"/>").is_err());
    }
}
