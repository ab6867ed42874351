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
        Some([-1.0, -2.0, 2.0]),
        "placed by the Translate in its attribute block"
    );
    assert_eq!(spot.target, Some([0.5, 0.5, 0.5]));
    assert_eq!((spot.cone_angle, spot.beam_width), (Some(25.0), Some(20.0)));
    assert_eq!(spot.falloff, Some(SpotFalloff::Pbrt));
    assert_eq!(spot.intensity, Some(Intensity::Grey(40.0)));
    assert_eq!(
        point.position,
        Some([2.0, 0.5, 2.0]),
        "AttributeEnd restored the identity"
    );
    assert_eq!(point.intensity, Some(Intensity::Rgb([1.0, 2.0, 3.0])));
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
        Some(Intensity::Grey(1.0)),
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

/// Runs the import on a thread of its own: a regression that loops or reads forever fails
/// after 30 s instead of stalling the test run.
fn import_within_30s(path: &Path, output_dir: &Path) -> Result<PbrtImport> {
    let (tx, rx) = std::sync::mpsc::channel();
    let (path, output_dir) = (path.to_path_buf(), output_dir.to_path_buf());
    std::thread::spawn(move || {
        let _ = tx.send(import_pbrt(&path, &output_dir));
    });
    rx.recv_timeout(std::time::Duration::from_secs(30))
        .unwrap_or_else(|_| panic!("the import did not return within 30 s"))
}

/// `t.pbrt`: `first` (Include lines) before the thesis-style scene, in the thesis folder.
fn including(first: &str) -> (tempfile::TempDir, PathBuf) {
    let (dir, _) = thesis_dir();
    let path = write(dir.path(), "t.pbrt", &format!("{first}\n{THESIS_STYLE}"));
    (dir, path)
}

#[test]
fn include_fan_out_is_bounded_and_names_the_chain() {
    // f0 … f14, each including the next four times: 4^14 splices if nothing bounds them.
    let dir = tempfile::tempdir().unwrap();
    for i in 0..14 {
        write(
            dir.path(),
            &format!("f{i}.pbrt"),
            &format!("Include \"f{}.pbrt\"\n", i + 1).repeat(4),
        );
    }
    write(dir.path(), "f14.pbrt", "WorldBegin\n");
    let e = import_within_30s(&dir.path().join("f0.pbrt"), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("1000000 tokens") && e.contains("64 MiB"),
        "the limits are named: {e}"
    );
    assert!(
        e.contains("f0.pbrt:1 → ") && e.contains(" → f1.pbrt:") && e.contains("Include \"f"),
        "the chain is named: {e}"
    );
}

#[test]
fn include_cycles_name_the_chain() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "a.pbrt", "WorldBegin\nInclude \"b.pbrt\"\n");
    write(dir.path(), "b.pbrt", "\n\nInclude \"sub/../a.pbrt\"\n");
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    let e = import_within_30s(&dir.path().join("a.pbrt"), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("b.pbrt:3:1: Include \"sub/../a.pbrt\"")
            && e.contains("a.pbrt:2 → ")
            && e.contains("b.pbrt:3 → ")
            && e.contains("includes itself"),
        "{e}"
    );
}

#[test]
fn deep_includes_name_the_chain() {
    let dir = tempfile::tempdir().unwrap();
    for i in 0..20 {
        write(
            dir.path(),
            &format!("d{i}.pbrt"),
            &format!("Include \"d{}.pbrt\"\n", i + 1),
        );
    }
    let e = import_within_30s(&dir.path().join("d0.pbrt"), dir.path())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("d16.pbrt:1:1: Include \"d17.pbrt\": Includes nest more than 16 deep")
            && e.contains("d0.pbrt:1 → d1.pbrt:1 → d2.pbrt:1")
            && e.ends_with("d16.pbrt:1 → d17.pbrt"),
        "{e}"
    );
}

#[test]
fn includes_of_devices_fifos_folders_and_huge_files_are_refused_at_their_line() {
    let (dir, _) = thesis_dir();
    let huge = dir.path().join("huge.pbrt");
    // Sparse: 1 GiB long without a block written; reading it whole was the bug.
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(1 << 30)
        .unwrap();
    let fifo = dir.path().join("pipe.pbrt");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    std::fs::create_dir(dir.path().join("folder.pbrt")).unwrap();
    write(
        dir.path(),
        "inner.pbrt",
        "WorldBegin\nInclude \"/dev/zero\"\n",
    );
    for (include, needles) in [
        (
            "/dev/zero",
            &["t.pbrt:1:1", "/dev/zero", "character device"][..],
        ),
        ("huge.pbrt", &["t.pbrt:1:1", "1073741824 bytes", "16 MiB"]),
        ("pipe.pbrt", &["t.pbrt:1:1", "FIFO"]),
        ("folder.pbrt", &["t.pbrt:1:1", "a folder"]),
        ("gone.pbrt", &["t.pbrt:1:1", "gone.pbrt"]),
        (
            "inner.pbrt",
            &[
                "inner.pbrt:2:1",
                "character device",
                "t.pbrt:1 → inner.pbrt:2 → /dev/zero",
            ],
        ),
    ] {
        let path = write(
            dir.path(),
            "t.pbrt",
            &format!("Include \"{include}\"\n{THESIS_STYLE}"),
        );
        let e = import_within_30s(&path, dir.path())
            .unwrap_err()
            .to_string();
        for needle in needles {
            assert!(
                e.contains(needle),
                "Include {include}: `{needle}` not in: {e}"
            );
        }
    }
}

#[test]
fn foreign_files_are_named_never_quoted() {
    for (name, content) in [
        ("passwd", &b"root:x:0:0:SECRET:/root:/bin/bash\n"[..]),
        // Reads as pbrt tokens (a word and a string): it was listed as "not mapped", with
        // its content, on stderr and in the written TOML.
        ("token.env", b"API_TOKEN \"SECRET\"\n"),
        ("blob", b"\x7fELF\x02SECRET\xff\xfe"),
    ] {
        let (dir, path) = including(&format!("Include \"{name}\""));
        std::fs::write(dir.path().join(name), content).unwrap();
        let shown = match import_within_30s(&path, dir.path()) {
            Ok(import) => format!("{}{:?}", import.to_toml(), import.notes),
            Err(e) => e.to_string(),
        };
        assert!(!shown.contains("SECRET"), "{name}: content quoted: {shown}");
        assert!(
            shown.contains(&format!("t.pbrt:1:1: Include \"{name}\"")) && shown.contains(name),
            "{name}: the Include and the file are named: {shown}"
        );
        assert!(
            shown.contains("not a pbrt scene file") || shown.contains("not UTF-8"),
            "{name}: what was expected: {shown}"
        );
    }
}

#[test]
fn a_transferfile_that_is_not_a_pgm_is_named_not_quoted() {
    let (dir, _) = thesis_dir();
    std::fs::write(
        dir.path().join("voldata/verylowcut.pgm"),
        "root:x:0:0:SECRET:/root:/bin/bash\n",
    )
    .unwrap();
    let path = write(dir.path(), "t.pbrt", THESIS_STYLE);
    let e = import_within_30s(&path, dir.path())
        .unwrap_err()
        .to_string();
    assert!(!e.contains("SECRET"), "{e}");
    assert!(
        e.contains("t.pbrt:24:1")
            && e.contains("transferfile")
            && e.contains("verylowcut.pgm")
            && e.contains("\"P2\" or \"P5\""),
        "{e}"
    );
}

#[test]
fn a_missing_transferfile_is_flagged_at_import() {
    let import = import_text(THESIS_STYLE).unwrap();
    let note = import
        .notes
        .iter()
        .find(|n| n.contains("transferfile"))
        .unwrap_or_else(|| panic!("no note: {:?}", import.notes));
    assert!(
        note.contains("voldata/verylowcut.pgm")
            && note.contains("t.pbrt:24")
            && note.contains("kind = \"points\""),
        "the resolved path, the statement and an alternative: {note}"
    );
    assert!(import.to_toml().contains("# note: transferfile"));
}

/// A mistake written into the thesis-style scene (`from` → `to`), where its error must be
/// located and what the message must say.
type Mistake<'a> = (&'a str, &'a str, &'a str, &'a [&'a str]);

fn assert_located(mistakes: &[Mistake]) {
    for (from, to, at, needles) in mistakes {
        assert!(THESIS_STYLE.contains(from), "{from}");
        let e = import_text(&THESIS_STYLE.replacen(from, to, 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("{at}: ")), "{to}: not at {at}: {e}");
        for needle in needles.iter() {
            assert!(e.contains(needle), "{to}: `{needle}` not in: {e}");
        }
    }
}

#[test]
fn non_finite_numbers_are_named_where_written() {
    assert_located(&[
        (
            "\"color sigma_a\" [1 1 1]",
            "\"color sigma_a\" [NaN 1 1]",
            "t.pbrt:30:22",
            &["\"color sigma_a\"", "`NaN` is not a finite number"],
        ),
        (
            "\"color sigma_a\" [1 1 1]",
            "\"color sigma_a\" [1 inf 1]",
            "t.pbrt:30:24",
            &["\"color sigma_a\"", "`inf` is not a finite number"],
        ),
        (
            "\"color sigma_s\" [10 10 10]",
            "\"color sigma_s\" [10 1e999 10]",
            "t.pbrt:31:25",
            &["\"color sigma_s\"", "`1e999` is not a finite number"],
        ),
        (
            "  Translate 0 0 1",
            "  Rotate nan 0 0 1",
            "t.pbrt:18:10",
            &["Rotate", "argument 1", "`nan` is not a finite number"],
        ),
        (
            "  Translate 0 0 1",
            "  Translate 0 -inf 1",
            "t.pbrt:18:15",
            &["Translate", "argument 2", "`-inf` is not a finite number"],
        ),
        (
            "\"float coneangle\" 25",
            "\"float coneangle\" nan",
            "t.pbrt:20:25",
            &["\"float coneangle\"", "`nan` is not a finite number"],
        ),
    ]);
}

#[test]
fn quote_parameter_and_character_mistakes_are_named_where_written() {
    assert_located(&[
        (
            "\"float conedeltaangle\" 5",
            "\"float conedeltaangle\"",
            "t.pbrt:20:28",
            &["\"float conedeltaangle\" has no value"],
        ),
        (
            "\"float fov\" [30]",
            "\"float fov\" [30]\n  \"float fov\" [40]",
            "t.pbrt:4:3",
            &["\"float fov\" is given twice", "line 3, column 22"],
        ),
        (
            "\"voldata/foot.raw\"",
            "\"voldata/foot.raw\"\"",
            "t.pbrt:27:40",
            &["stray `\"`"],
        ),
        (
            "\"voldata/foot.raw\"",
            "\"voldata/foot.raw\"\"\"",
            "t.pbrt:27:40",
            &["stray `\"`", "\"string rawfile\""],
        ),
        (
            "\"voldata/foot.raw\"\n    \"bool",
            "\"voldata/foot.raw\"\" \"bool",
            "t.pbrt:27:40",
            &["stray `\"`", "not closed"],
        ),
        (
            "WorldBegin",
            "\u{200b}WorldBegin",
            "t.pbrt:16:1",
            &["U+200B"],
        ),
        (
            "WorldBegin",
            "WorldBegin \u{feff}",
            "t.pbrt:16:12",
            &["U+FEFF", "byte-order mark"],
        ),
    ]);
}

#[test]
fn a_leading_byte_order_mark_is_skipped() {
    let import = import_text(&format!("\u{feff}{THESIS_STYLE}")).unwrap();
    assert_eq!(import.params.camera.fov, 30.0);
}

#[test]
fn unmapped_text_cannot_break_out_of_its_toml_comment() {
    // A string's `\n` escape is a newline: written raw, it would end the comment and make
    // the rest of the line TOML.
    let scene = THESIS_STYLE.replace(
        "Shape \"sphere\"",
        "Shape \"x\\n[film]\\nexposure = 3\\n#\"",
    );
    let import = import_text(&scene).unwrap();
    let text = import.to_toml();
    let back = SceneParams::from_toml(&text, Path::new("x.toml")).unwrap();
    assert_eq!(back, import.params, "{text}");
    assert!(text.contains("Shape \"x\\n[film]"), "{text}");
    let shown = import
        .unmapped
        .iter()
        .map(|u| u.to_string())
        .collect::<String>();
    assert!(!shown.contains('\n'), "{shown}");
}

#[test]
fn a_rawfile_that_is_not_a_regular_file_is_refused_at_import() {
    let (dir, _) = thesis_dir();
    let fifo = dir.path().join("voldata/pipe.raw");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo");
    for (raw, kind) in [
        ("/dev/zero", "character device"),
        ("voldata/pipe.raw", "FIFO"),
        ("voldata", "a folder"),
    ] {
        let scene = THESIS_STYLE.replace("voldata/foot.raw", raw);
        let path = write(dir.path(), "t.pbrt", &scene);
        let e = import_within_30s(&path, dir.path())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.pbrt:24:1")
                && e.contains("rawfile")
                && e.contains(raw)
                && e.contains(kind),
            "{raw}: {e}"
        );
    }
}

#[test]
fn a_constant_infinite_light_becomes_a_one_colour_sky_and_a_map_is_reported() {
    let constant = THESIS_STYLE.replace(
        "LightSource \"point\" \"color I\" [1 2 3] \"point from\" [2 0.5 2]",
        "LightSource \"infinite\" \"color L\" [0.2 0.3 0.4]",
    );
    let import = import_text(&constant).unwrap();
    let sky = &import.params.lights[1];
    assert_eq!(sky.kind, LightKind::Sky);
    let colour = Some(Intensity::Rgb([0.2, 0.3, 0.4]));
    assert_eq!(
        (sky.zenith, sky.horizon, sky.ground),
        (colour, colour, colour)
    );
    let mapped = THESIS_STYLE.replace(
        "LightSource \"point\" \"color I\" [1 2 3] \"point from\" [2 0.5 2]",
        "LightSource \"infinite\" \"string mapname\" \"sky.exr\"",
    );
    let import = import_text(&mapped).unwrap();
    assert_eq!(import.params.lights.len(), 1);
    assert!(
        import
            .unmapped
            .iter()
            .any(|u| u.to_string().contains("mirror image")),
        "{:?}",
        import.unmapped
    );
}
