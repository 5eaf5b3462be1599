use super::*;
use clap::Parser;
use pomc::jobs::ViewCamera;

/// One struct of options parsed alone from `argv` (without a program name).
fn parse<A: clap::Args + clap::FromArgMatches>(argv: &[&str]) -> Result<A, clap::Error> {
    #[derive(clap::Parser)]
    struct One<A: clap::Args> {
        #[command(flatten)]
        args: A,
    }
    One::<A>::try_parse_from(std::iter::once("pomc").chain(argv.iter().copied())).map(|o| o.args)
}

fn kw(pairs: &[(&str, Keyword)]) -> Vec<(String, Keyword)> {
    pairs.iter().map(|(k, v)| (k.to_string(), v.clone())).collect()
}

fn text(s: &str) -> Keyword {
    Keyword::Value(s.into())
}

/// The library's `Default`s are what the commands do without options.
#[test]
fn no_options_are_the_library_defaults() {
    let build: BuildArgs = parse(&[]).unwrap();
    assert_eq!(format!("{:?}", build.settings()), format!("{:?}", BuildSettings::default()));
    let mesh: MeshArgs = parse(&[]).unwrap();
    assert_eq!(mesh.params(), MeshOptions::default());
    assert_eq!(parse::<MeshArgs>(&["--no-simplify"]).unwrap().params(), MeshOptions::quadtree());
}

#[test]
fn mesh_tolerances_turn_off_as_the_flags_say() {
    let p = parse::<MeshArgs>(&["--max-error", "0", "--max-angle", "0"]).unwrap().params();
    assert_eq!((p.max_error, p.max_angle_deg, p.simplify), (None, None, None));
    assert!(parse::<MeshArgs>(&["--uniform", "4"]).unwrap().params().simplify.is_none());
    assert!(!parse::<MeshArgs>(&["--no-greedy"]).unwrap().params().simplify.unwrap().greedy);
    assert!(parse::<MeshArgs>(&["--uniform", "0"]).is_err());
}

/// Keywords go through the command line's declarations: the same values, ranges and errors.
#[test]
fn keywords_parse_as_the_command_line_does() {
    let k = kw(&[
        ("jump", text("0.1")),
        ("no_fold", Keyword::Flag(true)),
        ("depth_kind", text("inverse")),
        ("depth_range", text("0.5,20")),
        ("depth_bands", text("2,5")),
        ("normals", Keyword::Flag(false)),
    ]);
    let a: BuildArgs = from_keywords("build", &k).unwrap();
    let s = a.settings();
    assert_eq!(s.options.segment.edges.jump, 0.1);
    assert_eq!(s.options.segment.edges.fold_deg, None);
    assert_eq!(s.depth.kind, DepthKind::Inverse);
    assert_eq!(s.depth.range, Some((0.5, 20.0)));
    assert_eq!(s.options.depth_bands, vec![2.0, 5.0]);
    assert!(!s.options.normals_out);
    let cli: BuildArgs = parse(&[
        "--jump",
        "0.1",
        "--no-fold",
        "--depth-kind",
        "inverse",
        "--depth-range",
        "0.5,20",
        "--depth-bands",
        "2,5",
    ])
    .unwrap();
    assert_eq!(format!("{:?}", cli.settings()), format!("{:?}", s));

    // A flag only declared as `--no-NAME` takes its positive name as a keyword.
    let m: MeshArgs = from_keywords("mesh", &kw(&[("simplify", Keyword::Flag(false))])).unwrap();
    assert_eq!(m.params(), MeshOptions::quadtree());
    let m: MeshArgs = from_keywords("mesh", &kw(&[("greedy", Keyword::Flag(true))])).unwrap();
    assert_eq!(m.params(), MeshOptions::default());
    // A flag's truth as text (a NumPy bool, an integer); an unset option keeps its default.
    let m: MeshArgs =
        from_keywords("mesh", &kw(&[("simplify", text("0")), ("residual", Keyword::Unset)])).unwrap();
    assert_eq!(m.params(), MeshOptions::quadtree());
    let b: BuildArgs =
        from_keywords("build", &kw(&[("normals", text("True")), ("no_pack", text("1"))])).unwrap();
    assert!(b.settings().options.normals_out && !b.settings().save.pack);
}

#[test]
fn bad_keywords_are_refused_with_the_reason() {
    let err = |pairs: &[(&str, Keyword)]| from_keywords::<BuildArgs>("build", &kw(pairs)).unwrap_err();
    let e = err(&[("jump", text("-1"))]);
    assert!(e.contains("jump") && e.contains("> 0"), "{e}");
    let e = err(&[("depth_kind", text("metric"))]);
    assert!(e.contains("metric") && e.contains("ray"), "{e}");
    let e = err(&[("jumps", Keyword::Unset)]);
    assert!(e.contains("unknown build option `jumps`"), "{e}");
    let e = err(&[("jumps", text("1"))]);
    assert!(e.contains("unknown build option `jumps`") && e.contains("fill_margin"), "{e}");
    let e = err(&[("jump", Keyword::Flag(true))]);
    assert!(e.contains("takes a value"), "{e}");
    let e = err(&[("no_pack", text("yes"))]);
    assert!(e.contains("True or False"), "{e}");
    let e = err(&[("soft_edges", Keyword::Flag(true)), ("keep_mixed", Keyword::Flag(true))]);
    assert!(e.contains("cannot be used with"), "{e}");
    let e = err(&[("depth_range", text("5,1"))]);
    assert!(e.contains("NEAR < FAR"), "{e}");
}

#[test]
fn keyword_defaults_list_every_option_with_the_command_default() {
    let d = keyword_defaults::<BuildArgs>();
    let get = |k: &str| d.iter().find(|(n, _)| n == k).unwrap_or_else(|| panic!("{k}")).1.clone();
    assert_eq!(get("jump"), Some("0.08".into()));
    assert_eq!(get("depth_kind"), Some("ray".into()));
    assert_eq!(get("no_fold"), Some("false".into()));
    assert_eq!(get("camera_height"), None);
    assert!(d.len() >= 25 && d.iter().all(|(k, _)| k != "help"), "{d:?}");
    let m = keyword_defaults::<MeshArgs>();
    assert_eq!(m.iter().find(|(k, _)| k == "max_error").unwrap().1, Some("0.005".into()));
}

#[test]
fn vectors() {
    assert_eq!(parse_vec3("1,2,3"), Ok(DVec3::new(1.0, 2.0, 3.0)));
    assert_eq!(parse_vec3("-1, 2,-3.5"), Ok(DVec3::new(-1.0, 2.0, -3.5)));
    assert!(parse_vec3("1,2").is_err());
    assert!(parse_vec3("1,2,inf").is_err());
    assert!(parse_vec3("a,b,c").is_err());
    assert!(parse_range("1,1").is_err() && parse_range("0.5,2").is_ok());
    assert!(parse_known_distance("1,2,-3").is_err() && parse_known_distance("1,2,3").is_ok());
}

#[test]
fn ranges_refuse_nan_infinity_and_out_of_domain() {
    let p = Range::POSITIVE.parser();
    assert_eq!(p("0.5"), Ok(0.5));
    for bad in ["0", "-1", "nan", "NaN", "inf", "-inf", "1e400", "x"] {
        let e = p(bad).unwrap_err();
        assert!(e.contains("> 0"), "{bad}: {e}");
    }
    assert!(Range::FRACTION.parser()("1").is_ok() && Range::FRACTION.parser()("1.5").is_err());
    assert!(Range::NON_NEGATIVE.parser()("0").is_ok());
    assert!(Range::OPEN_ANGLE.parser()("180").is_err() && Range::ANGLE.parser()("180").is_ok());
    assert!(Range::FINITE.parser()("-3").is_ok() && Range::FINITE.parser()("nan").is_err());
    assert!(Range::ANGLE.parser()("0").unwrap_err().contains("(0, 180]"));
    assert!(Range::POSITIVE.parser_f32()("1e-50").is_err());
}

#[test]
fn cameras_from_options() {
    let cam = |pairs: &[(&str, Keyword)]| {
        let a: CameraArgs = from_keywords("render", &kw(pairs)).unwrap();
        a.settings().view_camera(DVec3::ZERO, None, DVec3::NEG_X, 1024)
    };
    // Defaults: ODS eyes as wide as the panorama, top-bottom; VR180 eyes half as wide, side by side;
    // a cube map of quarter-width faces.
    assert_eq!(cam(&[("camera", text("ods"))]).unwrap().size(), (1024, 1024));
    assert_eq!(cam(&[("camera", text("ods")), ("stereo_layout", text("sbs"))]).unwrap().size(), (2048, 512));
    assert_eq!(cam(&[("camera", text("vr180"))]).unwrap().size(), (1024, 512));
    assert_eq!(cam(&[("camera", text("cube"))]).unwrap().size(), (768, 512));
    assert_eq!(
        cam(&[("camera", text("cube")), ("stereo", Keyword::Flag(true))]).unwrap().size(),
        (768, 1024)
    );
    let ViewCamera::Stereo(s) = cam(&[("camera", text("ods")), ("orientation", text("player"))]).unwrap()
    else {
        panic!("a stereo camera")
    };
    assert!((s.player_yaw.unwrap() - std::f64::consts::PI).abs() < 1e-12);
    // Sizes that do not split into the eyes or the layout are refused, naming the layout.
    let e = cam(&[("camera", text("cube")), ("size", text("100x100"))]).unwrap_err();
    assert!(e.to_string().contains("canonical cube map"), "{e}");
    assert!(cam(&[("camera", text("ods")), ("size", text("100x101"))]).is_err());
    assert!(cam(&[("camera", text("vr180")), ("size", text("300x100"))]).is_err());
    assert!(cam(&[("camera", text("vr180")), ("size", text("302x151"))]).is_err(), "odd eyes");
    let bad: Result<CameraArgs, _> = from_keywords("render", &kw(&[("pole_merge", text("80,70"))]));
    assert!(bad.unwrap_err().contains("FROM < TO"));
}

/// `CameraSettings::default()` is `pomc render` without camera options.
#[test]
fn camera_defaults_are_the_library_default() {
    let a: CameraArgs = from_keywords("render", &[]).unwrap();
    assert_eq!(a.settings(), pomc::jobs::CameraSettings::default());
    let a: CameraArgs = from_keywords("render", &kw(&[("no_pole_merge", Keyword::Flag(true))])).unwrap();
    assert_eq!(a.settings().pole_merge, None);
}
