//! A light built from its scene-file table: each key checked (present where the kind needs
//! it, absent where it has no use, in range), the error naming it — one `create` in pbrt's
//! manner, the `Light` enum's `create_in` calling in.

use std::path::Path;

use glam::Vec3;

use super::incident::{MAX_INTENSITY, validate_intensity};
use super::schema::{
    DEFAULT_GROUND, DEFAULT_HORIZON, DEFAULT_SUN_ANGLE, DEFAULT_ZENITH, Intensity, LightKind,
    LightParams,
};
use crate::error::{Error, Result};
use crate::math::Aabb;
use crate::scene::area::{AreaLight, AreaShape};
use crate::scene::environment::{EnvironmentLight, EnvironmentSource, SkyColours, Sun};
use crate::scene::envmap::EnvironmentMap;

/// What building a light may need from its scene.
#[derive(Debug, Clone, Copy)]
pub struct LightContext<'a> {
    /// The volume's bounds (an environment's photons start on its bounding sphere).
    pub bounds: &'a Aabb,
    /// The scene file's folder (relative `file` paths).
    pub base: &'a Path,
}

/// A key given to a light whose type has no use for it is an error naming it.
pub(super) fn check_keys(params: &LightParams) -> Result<()> {
    let given = [
        ("position", params.position.is_some()),
        ("target", params.target.is_some()),
        ("intensity", params.intensity.is_some()),
        ("cone_angle", params.cone_angle.is_some()),
        ("beam_width", params.beam_width.is_some()),
        ("falloff", params.falloff.is_some()),
        ("normal", params.normal.is_some()),
        ("size", params.size.is_some()),
        ("radius", params.radius.is_some()),
        ("radiance", params.radiance.is_some()),
        ("up", params.up.is_some()),
        ("file", params.file.is_some()),
        ("scale", params.scale.is_some()),
        ("rotation", params.rotation.is_some()),
        ("zenith", params.zenith.is_some()),
        ("horizon", params.horizon.is_some()),
        ("ground", params.ground.is_some()),
        ("sun_direction", params.sun_direction.is_some()),
        ("sun_radiance", params.sun_radiance.is_some()),
        ("sun_angle", params.sun_angle.is_some()),
    ];
    let allowed = params.kind.keys();
    for (key, present) in given {
        if present && !allowed.contains(&key) {
            return Err(Error::given_without_use(
                key,
                format!(
                    "no such key for a {} light (it takes {})",
                    params.kind.name(),
                    allowed.join(", ")
                ),
            ));
        }
    }
    Ok(())
}

pub(super) fn required_point(p: Option<[f32; 3]>, key: &str) -> Result<Vec3> {
    let p = p.ok_or_else(|| Error::parameter(key, "(missing)", "three finite numbers"))?;
    let v = Vec3::from(p);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::parameter(
            key,
            format!("{p:?}"),
            "three finite numbers",
        ))
    }
}

pub(super) fn intensity_of(params: &LightParams) -> Result<Vec3> {
    let i = params
        .intensity
        .ok_or_else(|| Error::parameter("intensity", "(missing)", "W/sr: one number or RGB"))?
        .rgb();
    validate_intensity(i)?;
    Ok(i)
}

/// A rectangle or disc from `position`, `normal` or `target`, `size` or `radius`,
/// `radiance` and (rectangle) `up`.
pub(super) fn area_light(params: &LightParams) -> Result<AreaLight> {
    let centre = required_point(params.position, "position")?;
    let normal = match (params.normal, params.target) {
        (Some(n), None) => Vec3::from(n),
        (None, Some(t)) => Vec3::from(t) - centre,
        (Some(_), Some(_)) => {
            return Err(Error::parameter(
                "target",
                "(given with normal)",
                "either `normal` or `target`, not both",
            ));
        }
        (None, None) => {
            return Err(Error::parameter(
                "normal",
                "(missing)",
                "the emitting side's normal, or a `target` it faces",
            ));
        }
    };
    let (shape, extent) = match params.kind {
        LightKind::Rect => (
            AreaShape::Rect,
            params.size.ok_or_else(|| {
                Error::parameter("size", "(missing)", "[width, height] in world units")
            })?,
        ),
        _ => {
            let r = params
                .radius
                .ok_or_else(|| Error::parameter("radius", "(missing)", "a length > 0"))?;
            (AreaShape::Disc, [r, r])
        }
    };
    let radiance = params
        .radiance
        .ok_or_else(|| Error::parameter("radiance", "(missing)", "W/m²/sr: one number or RGB"))?
        .rgb();
    AreaLight::new(
        shape,
        centre,
        normal,
        params.up.map(Vec3::from),
        extent,
        radiance,
    )
}

/// An environment map or a sky, oriented and scaled, around the scene's bounds.
pub(super) fn environment_light(
    params: &LightParams,
    context: LightContext<'_>,
) -> Result<EnvironmentLight> {
    let (source, map) = if params.kind == LightKind::Environment {
        let file = params.file.as_ref().ok_or_else(|| {
            Error::parameter("file", "(missing)", "an HDR map: .exr, .pfm or .hdr")
        })?;
        // The map's own error (missing, not HDR, a bad texel, a link out of the scene's
        // folder) under the key that named it, so the scene file's line is reported too.
        let map = crate::util::confined(context.base, file, "the scene's folder")
            .and_then(|path| EnvironmentMap::load(&path))
            .map_err(|e| Error::parameter("file", file.display(), e.to_string()))?;
        (EnvironmentSource::File(file.clone()), map)
    } else {
        let colour = |v: Option<Intensity>, key: &str, default: [f32; 3]| -> Result<Vec3> {
            let c = v.map_or(Vec3::from(default), |i| i.rgb());
            if c.is_finite() && c.min_element() >= 0.0 && c.max_element() <= MAX_INTENSITY {
                Ok(c)
            } else {
                Err(Error::parameter(
                    key,
                    format!("{:?}", c.to_array()),
                    "finite radiances >= 0 (W/m²/sr)",
                ))
            }
        };
        let colours = SkyColours {
            zenith: colour(params.zenith, "zenith", DEFAULT_ZENITH)?,
            horizon: colour(params.horizon, "horizon", DEFAULT_HORIZON)?,
            ground: colour(params.ground, "ground", DEFAULT_GROUND)?,
        };
        let map = EnvironmentLight::sky_map(&colours)?;
        (EnvironmentSource::Sky(colours), map)
    };
    let sun = match (params.sun_direction, params.sun_radiance) {
        (Some(d), Some(r)) => Some(Sun::new(
            Vec3::from(d),
            r.rgb(),
            params.sun_angle.unwrap_or(DEFAULT_SUN_ANGLE),
        )?),
        (None, None) if params.sun_angle.is_none() => None,
        _ => {
            return Err(Error::parameter(
                "sun_direction",
                "(sun incomplete)",
                "both `sun_direction` and `sun_radiance` for a sun (`sun_angle` optional)",
            ));
        }
    };
    let scale = params.scale.map_or(Vec3::ONE, |s| s.rgb());
    let up = params.up.map_or(Vec3::Z, Vec3::from);
    EnvironmentLight::new(
        source,
        map,
        scale,
        up,
        params.rotation.unwrap_or(0.0),
        sun,
        context.bounds,
    )
}
