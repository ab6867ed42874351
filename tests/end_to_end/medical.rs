//! Medical data through the real `sweep render`: a DICOM folder rendered with a Slicer
//! preset records the series in its sidecar and comes out in colour; a series with a
//! missing slice fails naming the gap and writes nothing.

use std::path::Path;

use volphot::test_util::dicom::{SliceSpec, write_slice};
use volphot_tests::{run_ok, sweep};

/// 16×16×16 CT: a bone ball (700 HU) in soft tissue (40 HU) in air; `skip` leaves a slice out.
fn write_series(dir: &Path, skip: Option<usize>) {
    std::fs::create_dir_all(dir).unwrap();
    for z in 0..16 {
        if Some(z) == skip {
            continue;
        }
        let words: Vec<u16> = (0..256)
            .map(|i| {
                let (x, y) = ((i % 16) as f32 - 7.5, (i / 16) as f32 - 7.5);
                let r = (x * x + y * y + (z as f32 - 7.5).powi(2)).sqrt();
                let hu: i16 = if r < 4.0 {
                    700
                } else if r < 7.0 {
                    40
                } else {
                    -1000
                };
                hu as u16
            })
            .collect();
        let spec = SliceSpec::ct("2.25.60", &format!("2.25.60.{z}"), z as f64, [16, 16]);
        write_slice(&dir.join(format!("s{z:02}.dcm")), &spec, &words).unwrap();
    }
}

const SCENE: &str = r#"
[volume]
dicom = "series"
[transfer]
preset = "CT-Bone"
[camera]
eye = [0.5, -1.8, 0.5]
look_at = [0.5, 0.5, 0.5]
up = [0, 0, 1]
fov = 36
[[lights]]
type = "point"
position = [0.5, -1.0, 1.5]
intensity = 5
[integrator]
volume_photons = 2000
stepsize = 0.01
"#;

#[test]
fn a_dicom_folder_renders_in_colour_and_records_its_series() {
    let tmp = tempfile::tempdir().unwrap();
    write_series(&tmp.path().join("series"), None);
    let scene = tmp.path().join("ct.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = tmp.path().join("out");
    run_ok(sweep().arg("render").arg(&scene).arg("-o").arg(&out).args([
        "--resolution",
        "16x16",
        "--threads",
        "1",
        "-q",
    ]));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ct.json")).unwrap()).unwrap();
    let acquisition = &json["volume"]["acquisition"];
    assert_eq!(acquisition["series_uid"], "2.25.60", "{json}");
    assert_eq!(acquisition["slices"], 16);
    assert_eq!(acquisition["orientation"]["kind"], "axis-aligned");
    let film = volphot::Film::read_exr(&out.join("ct.exr")).unwrap();
    let (mut red, mut blue) = (0.0f64, 0.0f64);
    for v in film.layer(volphot::Layer::Single) {
        red += f64::from(v.x);
        blue += f64::from(v.z);
    }
    assert!(
        red > 0.0 && red > 1.05 * blue,
        "CT-Bone's warm colour: red {red}, blue {blue}"
    );
}

#[test]
fn a_series_with_a_missing_slice_fails_naming_the_gap_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    write_series(&tmp.path().join("series"), Some(7));
    let scene = tmp.path().join("ct.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = tmp.path().join("out");
    let output = sweep()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(["--resolution", "8x8", "-q"])
        .output()
        .unwrap();
    assert!(!output.status.success());
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(
        err.contains("gap of 2.0000 mm") && err.contains("s08.dcm"),
        "{err}"
    );
    let written = std::fs::read_dir(&out).map(|d| d.count()).unwrap_or(0);
    assert_eq!(written, 0, "nothing written");
}
