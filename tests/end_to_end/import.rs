//! `sweep import` of the thesis's pbrt-v1 scenes: a hand-written thesis-style file (§7.1.1,
//! §7.2.1, with a PGM transfer function, an attribute-block spot light and lines pbrt-v1
//! had but volphot has no use for) imports to a scene that renders bit-identically to the
//! same scene written by hand in TOML; bad files fail naming the line and write nothing;
//! the thesis's own foot scene finds the registered foot.

use std::path::Path;

use volphot::test_util::{real_data_dir, skip};
use volphot_tests::{run_ok, sweep};

const THESIS_SCENE: &str = r#"# A thesis-style scene (Henrich 2006, §7.1.1 and §7.2.1)
LookAt 0.5 -1.6 0.9   0.5 0.5 0.5   0 0 1
Camera "perspective" "float fov" [34]
Film "image" "integer xresolution" [20] "integer yresolution" [20]
    "string filename" ["ball.exr"]
VolumeIntegrator "volphotonmap" "integer volumephotons" [3000]
                    "integer nused" [30]
                    "float maxdist" .2
                    "float stepsize" .01
                    "bool emission" ["false"]
                    "bool single" ["true"]
                    "bool multiple" ["true"]
WorldBegin
AttributeBegin
  Translate 0 0 0.5
  LightSource "spot" "color I" [6 6 6] "point from" [0.5 -1.2 0.5] "point to" [0.5 0.5 0]
      "float coneangle" 30 "float conedeltaangle" 10
AttributeEnd
LightSource "point" "color I" [1 1.5 2] "point from" [1.8 0.5 1.2]
Shape "disk" "float radius" 3
Volume "rawvolumegrid"
    "integer nx" 12 "integer ny" 12 "integer nz" 12
    "point p0" [ .0 .0 .0 ] "point p1" [ 1 1 1 ]
    "string rawfile" "voldata/ball.raw"
    "bool transfer" ["true"]
    "string transferfile" ["voldata/cut.pgm"]
    "color sigma_a" [1 1 1]
    "color sigma_s" [10 10 10]
    "color Le" [0 0 0]
    "integer bits" 8
WorldEnd
"#;

/// The same scene written by hand for volphot (paths relative to `scenes/`).
const HAND_WRITTEN: &str = r#"
[volume]
file = "../voldata/ball.raw"
dims = [12, 12, 12]
voxel = "u8"
normalize = "type-range"
box = { p0 = [0, 0, 0], p1 = [1, 1, 1] }
[transfer]
kind = "pgm"
file = "../voldata/cut.pgm"
[sigma]
mapping = "explicit"
sigma_a = [1, 1, 1]
sigma_s = [10, 10, 10]
[camera]
eye = [0.5, -1.6, 0.9]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 34
resolution = [20, 20]
[[lights]]
type = "spot"
position = [0.5, -1.2, 1.0]
target = [0.5, 0.5, 0.5]
intensity = 6
cone_angle = 30
beam_width = 20
falloff = "pbrt"
[[lights]]
type = "point"
position = [1.8, 0.5, 1.2]
intensity = [1, 1.5, 2]
[integrator]
volume_photons = 3000
nused = 30
maxdist = 0.2
stepsize = 0.01
"#;

/// A ball of rising density and a PGM that cuts densities below 1/4 (the thesis's
/// `verylowcut.pgm` idea).
fn write_data(dir: &Path) {
    let data = dir.join("voldata");
    std::fs::create_dir_all(&data).unwrap();
    let voxels: Vec<u8> = (0..12 * 12 * 12)
        .map(|i| {
            let (x, y, z) = (i % 12, (i / 12) % 12, i / 144);
            let r = [x, y, z]
                .map(|c| (c as f32 - 5.5).powi(2))
                .iter()
                .sum::<f32>()
                .sqrt();
            (255.0 * (1.0 - r / 6.0).max(0.0)) as u8
        })
        .collect();
    std::fs::write(data.join("ball.raw"), voxels).unwrap();
    let cut: Vec<u8> = (0..256 * 256)
        .map(|i| if i % 256 < 64 { 0 } else { (i % 256) as u8 })
        .collect();
    std::fs::write(data.join("cut.pgm"), volphot::write_pgm(256, 256, &cut)).unwrap();
}

fn render(scene: &Path, out: &Path) -> Vec<u8> {
    run_ok(
        sweep()
            .arg("render")
            .arg(scene)
            .arg("-o")
            .arg(out)
            .args(["--threads", "1", "-q"]),
    );
    let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
    std::fs::read(out.join(format!("{stem}.pfm"))).unwrap()
}

#[test]
fn a_thesis_pbrt_scene_imports_and_renders_as_the_hand_written_scene() {
    let tmp = tempfile::tempdir().unwrap();
    write_data(tmp.path());
    let pbrt = tmp.path().join("ball.pbrt");
    std::fs::write(&pbrt, THESIS_SCENE).unwrap();
    let imported = tmp.path().join("scenes/imported.toml");
    let output = run_ok(sweep().arg("import").arg(&pbrt).arg("-o").arg(&imported));
    let stderr = String::from_utf8_lossy(&output.stderr);
    for line in [
        "ball.pbrt:4: Film \"image\": \"string filename\"",
        "ball.pbrt:20: Shape \"disk\"",
    ] {
        assert!(stderr.contains(line), "{line} not named:\n{stderr}");
    }
    assert_eq!(stderr.matches("not mapped:").count(), 2, "{stderr}");
    let hand = tmp.path().join("scenes/hand.toml");
    std::fs::write(&hand, HAND_WRITTEN).unwrap();
    let a = render(&imported, &tmp.path().join("out-imported"));
    let b = render(&hand, &tmp.path().join("out-hand"));
    assert!(a.len() > 20 * 20 * 12, "a 20×20 RGB PFM");
    assert!(
        a == b,
        "the imported scene renders differently from the hand-written one"
    );

    // An existing output is kept unless --force.
    let before = std::fs::read(&imported).unwrap();
    let again = sweep()
        .arg("import")
        .arg(&pbrt)
        .arg("-o")
        .arg(&imported)
        .output()
        .unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    assert_eq!(std::fs::read(&imported).unwrap(), before);
}

#[test]
fn a_bad_pbrt_file_names_the_line_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    write_data(tmp.path());
    let pbrt = tmp.path().join("bad.pbrt");
    std::fs::write(
        &pbrt,
        THESIS_SCENE.replace("\"integer bits\" 8", "\"integer bits\" 12"),
    )
    .unwrap();
    let out = tmp.path().join("bad.toml");
    let run = sweep()
        .arg("import")
        .arg(&pbrt)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        stderr.contains("bad.pbrt:21:")
            && stderr.contains("\"integer bits\" = 12: expected 8 or 16"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn the_thesis_foot_scene_finds_the_registered_foot() {
    let Some(data) = real_data_dir() else {
        skip(
            "the_thesis_foot_scene_finds_the_registered_foot",
            "real datasets not found (set VOLPHOT_DATA)",
        );
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let pbrt = tmp.path().join("foot.pbrt");
    let scene = THESIS_SCENE
        .replace(
            "\"integer nx\" 12 \"integer ny\" 12 \"integer nz\" 12",
            "\"integer nx\" 256 \"integer ny\" 256 \"integer nz\" 256",
        )
        .replace("voldata/ball.raw", "geometry/voldata/foot.raw")
        .replace(
            "\"bool transfer\" [\"true\"]",
            "\"bool transfer\" [\"false\"]",
        )
        .replace("    \"string transferfile\" [\"voldata/cut.pgm\"]\n", "");
    std::fs::write(&pbrt, scene).unwrap();
    let toml = tmp.path().join("foot.toml");
    let output = run_ok(sweep().arg("import").arg(&pbrt).arg("-o").arg(&toml));
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("registered dataset `foot`"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        std::fs::read_to_string(&toml)
            .unwrap()
            .contains("dataset = \"foot\"")
    );
    let out = tmp.path().join("out");
    run_ok(
        sweep()
            .arg("render")
            .arg(&toml)
            .arg("-o")
            .arg(&out)
            .args(["--threads", "2", "-q"])
            .env("VOLPHOT_DATA", &data),
    );
    let film = volphot::Film::read_exr(&out.join("foot.exr")).unwrap();
    for layer in [volphot::Layer::Single, volphot::Layer::Multiple] {
        let sum: f64 = film.layer(layer).iter().map(|v| f64::from(v.x)).sum();
        assert!(
            sum > 0.0 && sum.is_finite(),
            "{layer:?}: the foot is lit ({sum})"
        );
    }
}

/// `sweep import FILE -o FILE.toml` in `dir`, killed after 30 s (a hang is a failure).
fn import_within_30s(dir: &Path, file: &str) -> (std::process::Output, std::path::PathBuf) {
    let out = dir.join(format!("{file}.toml"));
    let output = crate::reliability::output_within(
        sweep()
            .arg("import")
            .arg(dir.join(file))
            .arg("-o")
            .arg(&out),
        30,
    );
    (output, out)
}

#[test]
fn include_graphs_devices_and_foreign_files_fail_fast_naming_the_chain() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    write_data(dir);
    // f0 … f14, each including the next four times: 4^14 splices if nothing bounds them.
    for i in 0..14 {
        let line = format!("Include \"f{}.pbrt\"\n", i + 1);
        std::fs::write(dir.join(format!("f{i}.pbrt")), line.repeat(4)).unwrap();
    }
    std::fs::write(dir.join("f14.pbrt"), THESIS_SCENE).unwrap();
    std::fs::write(dir.join("a.pbrt"), "Include \"b.pbrt\"\n").unwrap();
    std::fs::write(dir.join("b.pbrt"), "Include \"a.pbrt\"\n").unwrap();
    // Sparse: 1 GiB long without a block written.
    let huge = std::fs::File::create(dir.join("huge.pbrt")).unwrap();
    huge.set_len(1 << 30).unwrap();
    // Reads as pbrt tokens, so it used to be listed, content and all, as "not mapped".
    std::fs::write(dir.join("token.env"), "API_TOKEN \"SECRET\"\n").unwrap();
    std::fs::write(dir.join("voldata/secret.pgm"), "root:x:0:0:SECRET:/root\n").unwrap();
    let scene_with = |name: &str, first: &str, scene: &str| {
        std::fs::write(dir.join(name), format!("{first}\n{scene}")).unwrap();
    };
    scene_with("zero.pbrt", "Include \"/dev/zero\"", THESIS_SCENE);
    scene_with("sparse.pbrt", "Include \"huge.pbrt\"", THESIS_SCENE);
    scene_with("token.pbrt", "Include \"token.env\"", THESIS_SCENE);
    let foreign_table = THESIS_SCENE.replace("voldata/cut.pgm", "voldata/secret.pgm");
    scene_with("table.pbrt", "", &foreign_table);
    for (file, needles) in [
        (
            "f0.pbrt",
            &[
                "1000000 tokens",
                "64 MiB",
                "f0.pbrt:1 → f1.pbrt:",
                "Include \"f",
            ][..],
        ),
        (
            "a.pbrt",
            &["includes itself", "a.pbrt:1 → b.pbrt:1 → a.pbrt"],
        ),
        (
            "zero.pbrt",
            &["zero.pbrt:1:1", "/dev/zero", "character device"],
        ),
        ("sparse.pbrt", &["sparse.pbrt:1:1", "huge.pbrt", "16 MiB"]),
        (
            "token.pbrt",
            &["token.pbrt:1:1", "token.env", "not a pbrt scene file"],
        ),
        (
            "table.pbrt",
            &["transferfile", "secret.pgm", "\"P2\" or \"P5\""],
        ),
    ] {
        let (output, out) = import_within_30s(dir, file);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{file} imported:\n{stderr}");
        for needle in needles {
            assert!(
                stderr.contains(needle),
                "{file}: `{needle}` not in:\n{stderr}"
            );
        }
        assert!(
            !stderr.contains("SECRET"),
            "{file}: content quoted:\n{stderr}"
        );
        assert!(!out.exists(), "{file}: nothing written");
    }
}

#[test]
fn a_missing_transferfile_is_flagged_at_import_and_named_at_render() {
    let tmp = tempfile::tempdir().unwrap();
    write_data(tmp.path());
    let pbrt = tmp.path().join("gone.pbrt");
    std::fs::write(
        &pbrt,
        THESIS_SCENE.replace("voldata/cut.pgm", "voldata/gone.pgm"),
    )
    .unwrap();
    let toml = tmp.path().join("scenes/gone.toml");
    let output = run_ok(sweep().arg("import").arg(&pbrt).arg("-o").arg(&toml));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: transferfile")
            && stderr.contains("voldata/gone.pgm")
            && stderr.contains("gone.pbrt:21")
            && stderr.contains("kind = \"points\""),
        "the import flags it, with the resolved path and an alternative:\n{stderr}"
    );
    let text = std::fs::read_to_string(&toml).unwrap();
    assert!(text.contains("# note: transferfile"), "{text}");
    let render = sweep()
        .arg("render")
        .arg(&toml)
        .arg("-o")
        .arg(tmp.path().join("out"))
        .args(["--threads", "1", "-q"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&render.stderr);
    assert!(!render.status.success());
    assert!(
        stderr.contains("gone.pgm: does not exist") && stderr.contains("transfer.file"),
        "the render names the key, not only the OS error:\n{stderr}"
    );
}
