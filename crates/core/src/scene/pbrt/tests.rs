use super::*;

/// A scene in the thesis's style (§7.1.1, §7.2.1) with the statements around it that a
/// pbrt-v1 file of the time had.
const THESIS_STYLE: &str = r#"# foot, thesis Fig. 16 style
LookAt -1.2 -1.6 1.8   0.5 0.5 0.5   0 0 1
Camera "perspective" "float fov" [30]
Film "image" "integer xresolution" [128] "integer yresolution" [96]
    "string filename" ["foot.exr"]
Sampler "bestcandidate" "integer pixelsamples" [2]
PixelFilter "gaussian"
SurfaceIntegrator "directlighting"
VolumeIntegrator "volphotonmap" "integer volumephotons" [40000]
                    "integer nused" [150]
                    "float maxdist" .5
                    "float stepsize" .0005
                    "bool emission" ["false"]
                    "bool single" ["true"]
                    "bool multiple" ["true"]
WorldBegin
AttributeBegin
  Translate 0 0 1
  LightSource "spot" "color I" [40 40 40] "point from" [-1 -2 1] "point to" [0.5 0.5 -0.5]
      "float coneangle" 25 "float conedeltaangle" 5
AttributeEnd
LightSource "point" "color I" [1 2 3] "point from" [2 0.5 2]
Shape "sphere" "float radius" 5
Volume "rawvolumegrid"
    "integer nx" 4 "integer ny" 3 "integer nz" 2
    "point p0" [ .0 .0 .0 ] "point p1" [ 1 1 .5 ]
    "string rawfile" "voldata/foot.raw"
    "bool transfer" ["true"]
    "string transferfile" ["voldata/verylowcut.pgm"]
    "color sigma_a" [1 1 1]
    "color sigma_s" [10 10 10]
    "color Le" [0 0 0]
    "integer bits" 8
WorldEnd
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, text).unwrap();
    path
}

fn thesis_dir() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("voldata")).unwrap();
    std::fs::write(dir.path().join("voldata/foot.raw"), vec![7u8; 24]).unwrap();
    let path = write(dir.path(), "foot.pbrt", THESIS_STYLE);
    (dir, path)
}

fn import_text(text: &str) -> Result<PbrtImport> {
    let (dir, _) = thesis_dir();
    let path = write(dir.path(), "t.pbrt", text);
    import_pbrt(&path, dir.path())
}

#[test]
fn thesis_style_scene_maps_every_parameter() {
    let (dir, path) = thesis_dir();
    let out = dir.path().join("out");
    let import = import_pbrt(&path, &out).unwrap();
    let p = &import.params;
    assert_eq!(p.camera.eye, [-1.2, -1.6, 1.8]);
    assert_eq!(p.camera.look_at, [0.5, 0.5, 0.5]);
    assert_eq!(
        p.camera.fov, 30.0,
        "landscape film: pbrt's fov is already vertical"
    );
    assert_eq!(p.camera.resolution, [128, 96]);
    let i = &p.integrator;
    assert_eq!(
        (i.volume_photons, i.nused, i.maxdist, i.stepsize),
        (40000, 150, 0.5, 0.0005)
    );
    assert_eq!(
        (i.emission, i.single, i.multiple, i.spp),
        (false, true, true, 2)
    );
    let v = &p.volume;
    assert_eq!(v.file.as_deref(), Some(Path::new("../voldata/foot.raw")));
    assert_eq!((v.dims, v.voxel), (Some([4, 3, 2]), Some(VoxelType::U8)));
    assert_eq!(v.bounds.unwrap().p1, [1.0, 1.0, 0.5]);
    assert_eq!(v.normalize, Some(NormalizeKind::TypeRange));
    assert_eq!(p.transfer.kind, TransferKind::Pgm);
    assert_eq!(
        p.transfer.file.as_deref(),
        Some(Path::new("../voldata/verylowcut.pgm"))
    );
    assert_eq!(p.sigma.mapping, MappingKind::Explicit);
    assert_eq!(
        (p.sigma.sigma_a, p.sigma.sigma_s),
        (Some([1.0; 3]), Some([10.0; 3]))
    );
    assert_eq!(p.sigma.emission, None, "Le = 0 is no emission");
    let [spot, point] = p.lights.as_slice() else {
        panic!("{:?}", p.lights)
    };
    assert_eq!(
        spot.position,
        [-1.0, -2.0, 2.0],
        "placed by the Translate in its attribute block"
    );
    assert_eq!(spot.target, Some([0.5, 0.5, 0.5]));
    assert_eq!((spot.cone_angle, spot.beam_width), (Some(25.0), Some(20.0)));
    assert_eq!(spot.falloff, Some(SpotFalloff::Pbrt));
    assert_eq!(spot.intensity, Intensity::Grey(40.0));
    assert_eq!(
        point.position,
        [2.0, 0.5, 2.0],
        "AttributeEnd restored the identity"
    );
    assert_eq!(point.intensity, Intensity::Rgb([1.0, 2.0, 3.0]));
    let lines: Vec<(usize, &str)> = import
        .unmapped
        .iter()
        .map(|u| (u.line, u.what.as_str()))
        .collect();
    assert_eq!(
        lines,
        [
            (4, "Film \"image\": \"string filename\""),
            (6, "Sampler \"bestcandidate\""),
            (7, "PixelFilter \"gaussian\""),
            (8, "SurfaceIntegrator \"directlighting\""),
            (23, "Shape \"sphere\""),
        ]
    );
}

#[test]
fn the_toml_reads_back_as_the_same_scene() {
    let (dir, path) = thesis_dir();
    let import = import_pbrt(&path, dir.path()).unwrap();
    let text = import.to_toml();
    let back = SceneParams::from_toml(&text, Path::new("x.toml")).unwrap();
    assert_eq!(back, import.params, "{text}");
    assert!(
        text.contains("# not mapped:") && text.contains(":23: Shape \"sphere\""),
        "{text}"
    );
    assert!(
        !text.contains("free_path"),
        "only the keys the file set: {text}"
    );
}

#[test]
fn portrait_films_convert_the_shorter_axis_fov() {
    let scene = THESIS_STYLE.replace(
        "[128] \"integer yresolution\" [96]",
        "[50] \"integer yresolution\" [100]",
    );
    let p = import_text(&scene).unwrap().params;
    let expected = 2.0 * ((15f64.to_radians()).tan() * 2.0).atan().to_degrees();
    assert!(
        (p.camera.fov as f64 - expected).abs() < 1e-4,
        "{}",
        p.camera.fov
    );
    let no_fov = THESIS_STYLE.replace("\"float fov\" [30]", "");
    assert_eq!(
        import_text(&no_fov).unwrap().params.camera.fov,
        90.0,
        "pbrt-v1's default"
    );
}

#[test]
fn composed_camera_transforms_give_the_same_rays() {
    // Rotating the world by 90° about z before the LookAt turns the eye from -y to +x.
    let scene = THESIS_STYLE.replace(
        "LookAt -1.2 -1.6 1.8   0.5 0.5 0.5   0 0 1",
        "LookAt 0 -3 0  0 0 0  0 0 1\nRotate 90 0 0 1",
    );
    let c = import_text(&scene).unwrap().params.camera;
    let eye = DVec3::from(c.eye.map(f64::from));
    let dir = (DVec3::from(c.look_at.map(f64::from)) - eye).normalize();
    assert!((eye - DVec3::new(-3.0, 0.0, 0.0)).length() < 1e-5, "{eye}");
    assert!((dir - DVec3::X).length() < 1e-5, "{dir}");
    let mirrored = THESIS_STYLE.replace("LookAt -1.2", "Scale -1 1 1\nLookAt -1.2");
    let import = import_text(&mirrored).unwrap();
    assert!(
        import.unmapped.iter().any(|u| u.reason.contains("mirrors")),
        "{:?}",
        import.unmapped
    );
}

#[test]
fn sixteen_bit_threshold_and_included_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("w.raw"), vec![0u8; 16]).unwrap();
    write(
        dir.path(),
        "lights.pbrt",
        "LightSource \"point\" \"point from\" [0 0 3]\n",
    );
    let path = write(
        dir.path(),
        "w.pbrt",
        "WorldBegin\nInclude \"lights.pbrt\"\nVolume \"rawvolumegrid\" \"integer nx\" 2 \"integer ny\" 2 \"integer nz\" 2\n \"string rawfile\" \"w.raw\" \"bool transfer\" [\"false\"] \"string transferfile\" \"t.pgm\" \"integer bits\" 16 \"integer threshold\" 40000\nWorldEnd\n",
    );
    let import = import_pbrt(&path, dir.path()).unwrap();
    assert!(
        import
            .unmapped
            .iter()
            .any(|u| u.what.contains("transferfile") && u.reason.contains("is false")),
        "a table the file switches off is named: {:?}",
        import.unmapped
    );
    let p = import.params;
    assert_eq!(
        (p.transfer.kind, p.transfer.threshold),
        (TransferKind::Threshold, Some(40000.0))
    );
    assert_eq!(p.volume.voxel, Some(VoxelType::U16));
    assert_eq!(
        p.lights[0].intensity,
        Intensity::Grey(1.0),
        "pbrt-v1's default I"
    );
}

#[test]
fn a_missing_thesis_file_stands_for_the_registered_dataset() {
    let scene = THESIS_STYLE
        .replace(
            "\"integer nx\" 4 \"integer ny\" 3 \"integer nz\" 2",
            "\"integer nx\" 256 \"integer ny\" 256 \"integer nz\" 256",
        )
        .replace("voldata/foot.raw", "geometry/voldata/foot.raw");
    let import = import_text(&scene).unwrap();
    assert_eq!(import.params.volume.dataset.as_deref(), Some("foot"));
    assert!(
        import
            .notes
            .iter()
            .any(|n| n.contains("registered dataset `foot`"))
    );
}

#[test]
fn bad_files_are_errors_naming_file_line_and_value() {
    for (from, to, line, needle) in [
        (
            "\"integer bits\" 8",
            "\"integer bits\" 12",
            24,
            "expected 8 or 16",
        ),
        ("\"integer nx\" 4 ", "", 24, "\"integer nx\" is missing"),
        (
            "\"float conedeltaangle\" 5",
            "\"float conedeltaangle\" 30",
            19,
            "conedeltaangle",
        ),
        (
            "\"integer nused\" [150]",
            "\"float nused\" [150]",
            9,
            "\"float nused\" = [150]: expected one \"integer\"",
        ),
        (
            "\"bool single\" [\"true\"]",
            "\"bool single\" [\"yes\"]",
            9,
            "\"bool\" \"true\" or \"false\"",
        ),
        (
            "Shape \"sphere\"",
            "Rotate 30 1 0 0\nShape \"sphere\"",
            25,
            "rotates or mirrors the volume",
        ),
        (
            "AttributeEnd",
            "AttributeEnd\nAttributeEnd",
            22,
            "no matching",
        ),
        ("\"float maxdist\" .5", "\"float maxdist\" -1", 9, "maxdist"),
        (
            "\"string rawfile\" \"voldata/foot.raw\"",
            "",
            24,
            "rawfile\" is missing",
        ),
    ] {
        assert!(THESIS_STYLE.contains(from), "{from}");
        let e = import_text(&THESIS_STYLE.replace(from, to)).unwrap_err();
        let Error::Scene {
            line: l,
            message,
            file,
            ..
        } = &e
        else {
            panic!("{e}")
        };
        assert!(file.ends_with("t.pbrt"));
        assert_eq!(
            (*l, message.contains(needle)),
            (line, true),
            "{from} → {to}: {e}"
        );
    }
    let no_volume = THESIS_STYLE.replace("Volume \"rawvolumegrid\"", "Volume \"homogeneous\"");
    let e = import_text(&no_volume).unwrap_err().to_string();
    assert!(
        e.contains("t.pbrt") && e.contains("nothing to render"),
        "{e}"
    );
    let e = import_text("WorldBegin\nVolume \"rawvolumegrid\" \"integer nx\" 1 \"integer ny\" 1 \"integer nz\" 1 \"string rawfile\" \"v.raw\"\n").unwrap_err();
    assert!(e.to_string().contains("needs at least one light"), "{e}");
}

#[test]
fn relative_paths_walk_up_from_the_output_folder() {
    assert_eq!(
        relative_to(Path::new("/a/b/c.raw"), Path::new("/a/d/e")),
        Path::new("../../b/c.raw")
    );
    assert_eq!(
        relative_to(Path::new("/a/./b/../c.raw"), Path::new("/a")),
        Path::new("c.raw")
    );
}
