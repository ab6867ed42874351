//! Which kind of TOML file a verb was given, for the error when it is the other kind: an
//! experiment file has `scene`, `[axes]`, `[set]`, `[tune]`, … at its top level and is run
//! by `sweep run` (or `sweep tune`); a scene file has `[volume]`, `[camera]`,
//! `[integrator]`, … and is rendered by `sweep render`. Asked only once a file failed to
//! read as the kind the verb takes, so a file of the right kind never pays for it.

use std::path::Path;

use anyhow::Result;
use toml::{Table, Value};
use volphot::SceneParams;

/// Top-level keys only an experiment file has.
const EXPERIMENT_KEYS: &[&str] = &[
    "scene",
    "axes",
    "set",
    "tune",
    "zip",
    "exclude",
    "quality",
    "reference",
    "compare",
    "plots",
    "sheets",
    "max_cells",
    "name",
    "description",
];

/// Top-level keys only a scene file has.
const SCENE_KEYS: &[&str] = &[
    "volume",
    "transfer",
    "sigma",
    "phase",
    "camera",
    "three_point",
    "lights",
    "integrator",
    "film",
];

/// What a file holds, told by its top-level keys.
#[derive(Debug, Clone, PartialEq, Eq)]
enum FileKind {
    /// An experiment; `tune` when it has a `[tune]` section.
    Experiment { tune: bool },
    /// A scene.
    Scene,
}

/// The kind of file `text` is and the keys that tell it (`[axes]`, `` `scene` ``), or
/// `None` when it is not TOML or has keys of both kinds or of neither.
fn kind(text: &str) -> Option<(FileKind, String)> {
    let table: Table = text.parse().ok()?;
    let present = |keys: &[&str]| -> Vec<String> {
        keys.iter()
            .filter_map(|k| match table.get(*k)? {
                Value::Table(_) => Some(format!("[{k}]")),
                Value::Array(a) if a.iter().all(Value::is_table) && !a.is_empty() => {
                    Some(format!("[[{k}]]"))
                }
                _ => Some(format!("`{k}`")),
            })
            .collect()
    };
    let (experiment, scene) = (present(EXPERIMENT_KEYS), present(SCENE_KEYS));
    match (experiment.is_empty(), scene.is_empty()) {
        (false, true) => Some((
            FileKind::Experiment {
                tune: table.contains_key("tune"),
            },
            first_few(&experiment),
        )),
        (true, false) => Some((FileKind::Scene, first_few(&scene))),
        _ => None,
    }
}

/// The first three keys, and `…` when there are more.
fn first_few(keys: &[String]) -> String {
    let mut text = keys[..keys.len().min(3)].join(", ");
    if keys.len() > 3 {
        text += ", …";
    }
    text
}

/// The error for a scene file given where an experiment file belongs, if `text` is one.
pub(crate) fn scene_given_for_experiment(path: &Path, text: &str) -> Option<anyhow::Error> {
    let (FileKind::Scene, keys) = kind(text)? else {
        return None;
    };
    let p = path.display();
    Some(anyhow::anyhow!(
        "{p} is a scene file (it has {keys}), not an experiment file; render it with `sweep render {p}`, or name it as the `scene` of an experiment file to sweep it"
    ))
}

/// The error for an experiment file given where a scene file belongs, if `text` is one.
fn experiment_given_for_scene(path: &Path, text: &str) -> Option<anyhow::Error> {
    let (FileKind::Experiment { tune }, keys) = kind(text)? else {
        return None;
    };
    let p = path.display();
    let verb = if tune {
        format!("search it with `sweep tune {p}`")
    } else {
        format!("run it with `sweep run {p}`")
    };
    Some(anyhow::anyhow!(
        "{p} is an experiment file (it has {keys}), not a scene file; {verb}"
    ))
}

/// Reads a scene file as [`volphot::load_params`] does; a file that does not read as a
/// scene but as an experiment says so, with the verb that takes it.
pub(crate) fn load_scene(path: &Path) -> Result<(SceneParams, String)> {
    volphot::load_params(path).map_err(|e| {
        volphot::read_text_capped(path, volphot::TEXT_INPUT_CAP, "scene file")
            .ok()
            .and_then(|text| experiment_given_for_scene(path, &text))
            .unwrap_or_else(|| e.into())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn files_are_told_apart_by_their_top_level_keys() {
        let scene = "[volume]\nphantom = { name = \"sphere\" }\n[camera]\nfov = 30\n";
        assert_eq!(
            kind(scene),
            Some((FileKind::Scene, "[volume], [camera]".into()))
        );
        let grid = "name = \"x\"\nscene = \"s.toml\"\n[set]\nx = 1\n[axes]\n\"sigma.t\" = [1, 2]\n";
        assert_eq!(
            kind(grid),
            Some((
                FileKind::Experiment { tune: false },
                "`scene`, [axes], [set], …".into()
            ))
        );
        assert_eq!(
            kind("scene = \"s.toml\"\n[tune]\nseed = 1\n").map(|k| k.0),
            Some(FileKind::Experiment { tune: true })
        );
        // Both kinds, neither, or not TOML: nothing to tell.
        assert_eq!(kind("scene = \"s.toml\"\n[volume]\nx = 1\n"), None);
        assert_eq!(kind("other = 1\n"), None);
        assert_eq!(kind("[[[\n"), None);
    }
}
