//! The jobs' options declared once, as flags (ripgrep's `crates/core/flags`): each option's name,
//! default, domain and help live here and nowhere else. The `pomc` command flattens these
//! structs into its subcommands; the Python binding parses its keywords with the same structs
//! ([`from_keywords`]) and lists them with [`keyword_defaults`]. Each struct turns itself into the
//! library's settings in one place (`apply`, `settings`, `params`); the library itself has no
//! argument parser.

#![warn(missing_docs)]

use std::path::PathBuf;

use glam::DVec3;

use pomc::choice::Choice;
use pomc::colour::ColourSpace;
use pomc::input::Convention;
pub use pomc::jobs::parse_vec3;
use pomc::jobs::{BuildSettings, CameraKind, CameraSettings};
use pomc::layer_io::ReadLimits;
use pomc::layering::{BuildOptions, Classify, EdgeOptions, FillColour};
use pomc::mapping::layout::CubeLayout;
use pomc::mapping::MappingKind;
use pomc::mesh::{self, normals::NormalWeighting, simplify::SimplifyOptions, MeshOptions};
use pomc::prepare::{DepthKind, KnownDistance, Preset, Refine, UnknownDepth};
use pomc::render::stereo::Orientation;
use pomc::render::StereoLayout;
use pomc::scene::BakeSettings;

/// How the depth is read and prepared (`pomc build` and `pomc prepare`).
#[derive(clap::Args, Clone, Debug)]
pub struct DepthArgs {
    /// Encoding of an 8/16-bit colour image: auto (sRGB for PNG/JPEG, linear for EXR/HDR), srgb or
    /// linear. Layers are linear; sRGB is decoded on read.
    #[arg(long, value_parser = choice::<ColourSpace>(), default_value = "auto")]
    pub colour_space: ColourSpace,
    /// Dataset preset for the depth encoding.
    #[arg(long, value_parser = choice::<Preset>())]
    pub preset: Option<Preset>,
    /// Metres per stored depth unit (16-bit PNG); overrides the preset.
    #[arg(long, value_parser = Range::POSITIVE.parser())]
    pub depth_scale: Option<f64>,
    /// Stored depth value meaning "unknown" (0, NaN and negatives always are).
    #[arg(long, value_parser = Range::FINITE.parser())]
    pub depth_invalid: Option<f64>,
    /// What the depth values are: metric (ray, z) or relative (inverse, nearness: give
    /// --camera-height or --depth-range).
    #[arg(long, value_parser = choice::<DepthKind>(), default_value = "ray")]
    pub depth_kind: DepthKind,
    /// Nearest and farthest distance (m) of relative depth: NEAR,FAR.
    #[arg(long, value_name = "NEAR,FAR", value_parser = parse_range, allow_hyphen_values = true)]
    pub depth_range: Option<(f64, f64)>,
    /// Camera height above a level floor (m): relative depth is made metric by fitting the floor.
    #[arg(long, value_name = "H", value_parser = Range::POSITIVE.parser())]
    pub camera_height: Option<f64>,
    /// One distance you know: pixel X,Y of the colour image is METRES away along its ray; gives the
    /// scale of depth of unknown unit, or of inverse depth taken as having no shift.
    #[arg(long, value_name = "X,Y,METRES", value_parser = parse_known_distance)]
    pub known_distance: Option<KnownDistance>,
    /// Settle soft depth edges onto colour edges and smooth depth noise: auto (mode's filter when
    /// the edges measure soft; noise smoothed when noisy), mode (the filter on any depth), ramps
    /// (mode, then short blurred ramps to a side), on (the older snap), off.
    #[arg(long, value_parser = choice::<Refine>(), default_value = "auto")]
    pub refine: Refine,
    /// What unknown depth means: complete (a surface, completed from around it) or sky (nothing there).
    #[arg(long, value_parser = choice::<UnknownDepth>(), default_value = "complete")]
    pub unknown_depth: UnknownDepth,
    /// Largest input accepted, in pixels (width × height), checked from the file headers before
    /// decoding; the default, 268435456 (2^28), takes a 16384 × 8192 equirect.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1 << 34))]
    pub max_pixels: Option<u64>,
}

impl DepthArgs {
    /// Set what these options stand for in `s` (the other fields are left as they are).
    pub fn apply(&self, s: &mut BuildSettings) {
        let mut enc = self.preset.map(Preset::encoding).unwrap_or_default();
        if let Some(scale) = self.depth_scale {
            enc.scale = Some(scale);
        }
        if let Some(invalid) = self.depth_invalid {
            enc.invalid = Some(invalid);
        }
        enc.kind = self.depth_kind;
        enc.range = self.depth_range;
        enc.camera_height = self.camera_height;
        enc.known_distance = self.known_distance;
        s.colour_space = self.colour_space;
        s.depth = enc;
        s.prepare.refine = self.refine;
        s.prepare.unknown = self.unknown_depth;
        s.limits = self.max_pixels.map(ReadLimits::with_max_pixels).unwrap_or_default();
    }
}

/// How the layers are built and stored (`pomc build`, besides its inputs and output).
#[derive(clap::Args, Clone, Debug)]
pub struct LayeringArgs {
    /// Normals EXR (N.X,N.Y,N.Z or R,G,B, panorama frame); estimated from depth when absent.
    #[arg(long)]
    pub normals_in: Option<PathBuf>,
    /// Azimuth convention of the input, recorded in the manifest's LocalToWorld.
    #[arg(long, value_parser = choice::<Convention>(), default_value = "thesis")]
    pub convention: Convention,
    /// Position of the panorama centre in the world, metres: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub center: Option<DVec3>,
    /// Freedom radius (m): cameras within it see no holes.
    #[arg(long, default_value_t = BuildOptions::default().freedom_radius, value_parser = Range::POSITIVE.parser())]
    pub freedom_radius: f64,
    /// Relative depth jump between neighbours that separates surfaces.
    #[arg(long, default_value_t = EdgeOptions::default().jump, value_parser = Range::POSITIVE.parser())]
    pub jump: f64,
    /// Normal angle (degrees) that closes regions where depth is continuous but the surface folds.
    #[arg(long, default_value_t = EdgeOptions::default().fold_deg.unwrap_or(35.0), value_parser = Range::ANGLE.parser())]
    pub fold_deg: f64,
    /// Extra fill band (pixels) beyond the parallax band of the freedom radius.
    #[arg(long, default_value_t = BuildOptions::default().margin_px, value_parser = Range::NON_NEGATIVE.parser())]
    pub fill_margin: f64,
    /// How the fill behind occluders is coloured.
    #[arg(long, value_parser = choice::<FillColour>(), default_value = "exemplar")]
    pub fill_colour: FillColour,
    /// Do not split at folds (depth discontinuities only).
    #[arg(long)]
    pub no_fold: bool,
    /// Split layers by depth at these distances (m), e.g. 2,5 (thesis 6.2.4.1).
    #[arg(long, value_delimiter = ',', value_parser = Range::POSITIVE.parser())]
    pub depth_bands: Vec<f64>,
    /// Layer classification: by depth only, or also floor / ceiling / walls (thesis 6.2.4.2).
    #[arg(long, value_parser = choice::<Classify>(), default_value = "depth")]
    pub classify: Classify,
    /// Write normals into the layers.
    #[arg(long)]
    pub normals: bool,
    /// Keep far content in the finite layers (no infinity layer).
    #[arg(long)]
    pub no_infinity: bool,
    /// Keep mixed pixels (depth between a nearer and a farther neighbour across jumps to both, as an
    /// anti-aliased depth pass makes at edges) instead of treating them as unknown.
    #[arg(long)]
    pub keep_mixed: bool,
    /// Depth edges spread over a few pixels (resized or network-estimated depth) are cut at their
    /// steepest step: the in-between pixels join the far side. Off by default: the limb of a near
    /// curved object looks the same and would be cut (docs/build.md, "Soft depth edges").
    #[arg(long, conflicts_with = "keep_mixed")]
    pub soft_edges: bool,
    /// Store every layer as a full canvas (no patch packing).
    #[arg(long)]
    pub no_pack: bool,
}

impl LayeringArgs {
    /// Set what these options stand for in `s` (the other fields are left as they are).
    pub fn apply(&self, s: &mut BuildSettings) {
        s.normals_in.clone_from(&self.normals_in);
        s.convention = self.convention;
        s.center = self.center;
        let o = &mut s.options;
        o.freedom_radius = self.freedom_radius;
        o.depth_bands.clone_from(&self.depth_bands);
        o.normals_out = self.normals;
        o.infinity = !self.no_infinity;
        o.drop_mixed = !self.keep_mixed;
        o.soft_edges = self.soft_edges;
        o.classify = self.classify;
        o.margin_px = self.fill_margin;
        o.fill_colour = self.fill_colour;
        o.segment.edges.jump = self.jump;
        o.segment.edges.fold_deg = (!self.no_fold).then_some(self.fold_deg);
        s.save.pack = !self.no_pack;
    }
}

/// Every option of `pomc build` besides its input and output paths.
#[derive(clap::Args, Clone, Debug)]
pub struct BuildArgs {
    #[command(flatten)]
    #[allow(missing_docs)]
    pub depth: DepthArgs,
    #[command(flatten)]
    #[allow(missing_docs)]
    pub layering: LayeringArgs,
}

impl BuildArgs {
    /// The library settings these options stand for (no options: `BuildSettings::default()`).
    pub fn settings(&self) -> BuildSettings {
        let mut s = BuildSettings::default();
        self.depth.apply(&mut s);
        self.layering.apply(&mut s);
        s
    }
}

/// Every option of `pomc scene` besides its input and output paths.
#[derive(clap::Args, Clone, Debug)]
pub struct SceneArgs {
    /// Position of the panorama centre in pomc's world (+Z up; glTF's x, −z, y), metres: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,0,0")]
    pub center: DVec3,
    /// Freedom radius (m): what no eye within it sees is left out.
    #[arg(long, default_value_t = BakeSettings::default().freedom_radius, value_parser = Range::POSITIVE.parser())]
    pub freedom_radius: f64,
    /// Canvas width, pixels (equirect W × W/2, cube map W × 2W/3).
    #[arg(long, default_value_t = BakeSettings::default().width as u64, value_parser = clap::value_parser!(u64).range(6..=98304))]
    pub width: u64,
    /// Mapping of the layers.
    #[arg(long, value_parser = choice::<MappingKind>(), default_value = "equirect")]
    pub mapping: MappingKind,
    /// Rays per pixel for the colour (anti-aliasing); depth and normals come from the pixel centre.
    #[arg(long, default_value_t = BakeSettings::default().samples, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub samples: u32,
    /// Environment map for the sky: an equirect image (HDR, EXR, PNG, JPEG).
    #[arg(long)]
    pub sky: Option<PathBuf>,
    /// Sky colour without --sky, linear R,G,B.
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3, default_value = "0,0,0")]
    pub sky_colour: DVec3,
    /// Renders of the scene from the centre (equirect EXR, HDR, PNG, JPEG at the canvas width, e.g.
    /// Cycles' panorama camera), repeated or comma-separated: the k-th colours each ray's k-th hit
    /// (the first: what the centre sees; then renders with the surfaces before peeled away).
    #[arg(long, value_name = "IMAGE", value_delimiter = ',')]
    pub colour: Vec<PathBuf>,
    /// Azimuth convention of the --sky map and the --colour renders (blender for Blender's).
    #[arg(long, value_parser = choice::<Convention>(), default_value = "thesis", alias = "sky-convention")]
    pub convention: Convention,
    /// Do not write normals.
    #[arg(long)]
    pub no_normals: bool,
    /// Largest scene accepted, triangles.
    #[arg(long, default_value_t = BakeSettings::default().max_triangles as u64, value_parser = clap::value_parser!(u64).range(1..))]
    pub max_triangles: u64,
    /// Store every layer as a full canvas (no patch packing).
    #[arg(long)]
    pub no_pack: bool,
}

impl SceneArgs {
    /// The library settings these options stand for (no options: `BakeSettings::default()`).
    pub fn settings(&self) -> BakeSettings {
        let mut s = BakeSettings {
            center: self.center,
            freedom_radius: self.freedom_radius,
            width: self.width as usize,
            mapping: self.mapping,
            samples: self.samples,
            sky: self.sky.clone(),
            sky_colour: self.sky_colour.as_vec3().to_array(),
            colour: self.colour.clone(),
            convention: self.convention,
            normals: !self.no_normals,
            max_triangles: usize::try_from(self.max_triangles).unwrap_or(usize::MAX),
            ..BakeSettings::default()
        };
        s.save.pack = !self.no_pack;
        s
    }
}

/// The mesher's options (`pomc mesh`; `0` turns a tolerance off).
#[derive(clap::Args, Clone, Debug, PartialEq)]
pub struct MeshArgs {
    /// Radius (m, panorama-local) of the sky dome the infinitely far samples (the infinity layer) are
    /// meshed on; default 10 × the panorama's farthest finite depth (1000 m when it has none).
    #[arg(long, value_name = "R", value_parser = Range::POSITIVE.parser())]
    pub sky_radius: Option<f64>,
    /// Maximum relative distance along each pixel's ray between mesh and depth (0 disables).
    #[arg(long, default_value_t = mesh::DEFAULT_MAX_ERROR, value_parser = Range::NON_NEGATIVE.parser())]
    pub max_error: f64,
    /// Thesis normal test: split where neighbouring normals differ by more than DEG degrees.
    #[arg(long, value_name = "DEG", value_parser = Range::OPEN_ANGLE.parser())]
    pub feature_angle: Option<f64>,
    /// Thesis residual threshold (mean sub-feature normal variation of a node).
    #[arg(long, default_value_t = mesh::DEFAULT_RESIDUAL, value_parser = Range::POSITIVE.parser())]
    pub residual: f64,
    /// Weighting of normals estimated from depth when the layer has no N.* channels: area or angle.
    #[arg(long, value_parser = choice::<NormalWeighting>(), default_value = "area")]
    pub normal_weighting: NormalWeighting,
    /// Cap on a node's angular extent, degrees (texture distortion; 0 disables).
    #[arg(long, default_value_t = mesh::DEFAULT_MAX_ANGLE_DEG, value_name = "DEG", value_parser = Range::ANGLE_OR_OFF.parser())]
    pub max_angle: f64,
    /// Uniform 4-8 baseline with leaves of at most STEP cells a side (overrides the other tests).
    #[arg(long, value_name = "STEP", value_parser = clap::value_parser!(u32).range(1..))]
    pub uniform: Option<u32>,
    /// Output the raw quadtree mesh: skip the error-bounded edge-collapse stage (which runs by default
    /// with the same --max-error and --max-angle, unless --uniform or --max-error 0).
    #[arg(long)]
    pub no_simplify: bool,
    /// Simplify clean cube faces with quadtree + collapses too, instead of greedy insertion (which is
    /// faster and gives fewer triangles; faces with a domain border or a depth jump always take the
    /// quadtree).
    #[arg(long)]
    pub no_greedy: bool,
}

impl MeshArgs {
    /// The mesher's parameters: simplification runs unless turned off, uniform, or without a
    /// tolerance.
    pub fn params(&self) -> MeshOptions {
        let max_angle_deg = (self.max_angle > 0.0).then_some(self.max_angle);
        MeshOptions {
            max_error: (self.max_error > 0.0).then_some(self.max_error),
            feature_angle_deg: self.feature_angle,
            residual_threshold: self.residual,
            normal_weighting: self.normal_weighting,
            max_angle_deg,
            uniform: self.uniform,
            simplify: (!self.no_simplify && self.uniform.is_none() && self.max_error > 0.0).then_some(
                SimplifyOptions { max_error: self.max_error, max_angle_deg, greedy: !self.no_greedy },
            ),
        }
    }
}

/// How a view is seen: its camera and, for stereo, the eyes (`pomc render`).
#[derive(clap::Args, Clone, Debug, PartialEq)]
pub struct CameraArgs {
    /// Output camera.
    #[arg(long, value_parser = choice::<CameraKind>(), default_value = "perspective")]
    pub camera: CameraKind,
    /// Eye position in the world, metres: x,y,z (default: the panorama centre).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<DVec3>,
    /// Point looked at, world: x,y,z (default: the centre of the panorama image, eye − 1,0,0 in the
    /// panorama's frame; +X is the image's left/right seam).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look_at: Option<DVec3>,
    /// Up direction, world: x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,0,1")]
    pub up: DVec3,
    /// Horizontal field of view, degrees (perspective).
    #[arg(long, default_value_t = 60.0, value_parser = Range::OPEN_ANGLE.parser())]
    pub fov: f64,
    /// Output size WxH, the whole image (default 960x540 perspective, 2048x1024 equirect; ods: each
    /// eye as wide as the panorama, 2:1; vr180: each eye half as wide, square).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Stereo layout: tb (top-bottom, left eye on top) or sbs (side by side, left eye left); default
    /// tb for ods, sbs for vr180.
    #[arg(long, value_parser = choice::<StereoLayout>())]
    pub stereo_layout: Option<StereoLayout>,
    /// Interpupillary distance of stereo cameras, metres.
    #[arg(long, value_name = "M", default_value_t = 0.064, value_parser = Range::NON_NEGATIVE.parser())]
    pub ipd: f64,
    /// Stereo fades to mono between these elevations, degrees (Blender's pole merge): FROM,TO.
    #[arg(long, value_name = "FROM,TO", default_value = "60,75", value_parser = parse_pole_merge)]
    pub pole_merge: (f64, f64),
    /// Keep the full eye separation up to the poles.
    #[arg(long)]
    pub no_pole_merge: bool,
    /// --camera cube: a stereo cube map (each eye's rays as --camera ods's).
    #[arg(long)]
    pub stereo: bool,
    /// Face layout of --camera cube: canonical (POMC 3×2), ffmpeg-c3x2, openexr-vstrip or py360-horizon.
    #[arg(long, value_name = "LAYOUT", default_value_t = CubeLayout::Canonical)]
    pub cube_layout: CubeLayout,
    /// Columns of stereo panoramas: world (the axes of --camera equirect) or player (as 360° players
    /// and headsets show them: centre column towards --look-at, moving right turns right; use it
    /// for videos).
    #[arg(long, value_parser = choice::<Orientation>(), default_value = "world")]
    pub orientation: Orientation,
}

impl CameraArgs {
    /// The library's camera settings these options stand for.
    pub fn settings(&self) -> CameraSettings {
        CameraSettings {
            camera: self.camera,
            eye: self.eye,
            look_at: self.look_at,
            up: self.up,
            fov: self.fov,
            size: self.size,
            stereo_layout: self.stereo_layout,
            ipd: self.ipd,
            pole_merge: (!self.no_pole_merge).then_some(self.pole_merge),
            stereo: self.stereo,
            cube_layout: self.cube_layout,
            orientation: self.orientation,
        }
    }
}

/// A parser of a [`Choice`]'s names, each listed in `--help` with its one-line help.
pub fn choice<T: Choice + Send + Sync>() -> impl clap::builder::TypedValueParser<Value = T> {
    let values = T::VALUES.iter().map(|(v, name, _)| {
        let value = clap::builder::PossibleValue::new(*name);
        match v.help() {
            help if help.is_empty() => value,
            help => value.help(help),
        }
    });
    let parser = clap::builder::PossibleValuesParser::new(values);
    clap::builder::TypedValueParser::try_map(parser, |name: String| {
        T::from_name(&name).ok_or_else(|| format!("`{name}` is not one of the values"))
    })
}

/// A keyword's value as a binding holds it: a flag's truth, or a value in the command line's
/// syntax (`0.1`, `1,2,3`, `ray`).
#[derive(Clone, Debug, PartialEq)]
pub enum Keyword {
    /// `True` or `False`: the flag of that name is given or not; for a name whose flag is only
    /// `--no-NAME`, its negation.
    Flag(bool),
    /// A value, as text (for a flag: `True`, `False`, `true`, `false`, `1` or `0`).
    Value(String),
    /// No value (Python's `None`): the option keeps its default; the name must still be one.
    Unset,
}

/// A flag's truth written as text by a binding (a NumPy bool, an integer).
fn truth(text: &str) -> Option<bool> {
    match text {
        "True" | "true" | "1" => Some(true),
        "False" | "false" | "0" => Some(false),
        _ => None,
    }
}

/// Options given as keywords (each an option's long name with `_` for `-`), parsed and checked by
/// the same declarations as the command line. The error names the keyword and what it takes.
pub fn from_keywords<A: clap::Args + clap::FromArgMatches>(
    what: &str,
    keywords: &[(String, Keyword)],
) -> Result<A, String> {
    let mut cmd = command::<A>().no_binary_name(true);
    let takes_value = |long: &str| {
        cmd.get_arguments().find(|a| a.get_long() == Some(long)).map(|a| a.get_action().takes_values())
    };
    let mut argv = Vec::new();
    for (key, value) in keywords {
        let long = key.replace('_', "-");
        let negation = format!("no-{long}");
        let (flag, negated) = match (takes_value(&long), takes_value(&negation)) {
            (Some(takes), _) => (!takes, false),
            (None, Some(false)) => (true, true),
            _ => {
                let known: Vec<String> = keyword_defaults::<A>().into_iter().map(|(k, _)| k).collect();
                return Err(format!("unknown {what} option `{key}`; known: {}", known.join(", ")));
            }
        };
        let on = match (value, flag) {
            (Keyword::Unset, _) => continue,
            (Keyword::Value(text), false) => {
                argv.push(format!("--{long}={text}"));
                continue;
            }
            (Keyword::Flag(_), false) => return Err(format!("{key} takes a value, not True or False")),
            (Keyword::Flag(on), true) => *on,
            (Keyword::Value(text), true) => {
                truth(text).ok_or_else(|| format!("{key} is True or False, not `{text}`"))?
            }
        };
        if on != negated {
            argv.push(format!("--{}", if negated { &negation } else { &long }));
        }
    }
    let matches = cmd.try_get_matches_from_mut(argv).map_err(|e| clap_message(&e))?;
    A::from_arg_matches(&matches).map_err(|e| clap_message(&e))
}

/// The options of `A` alone, built (no help flag: it is no option of a job).
fn command<A: clap::Args>() -> clap::Command {
    let mut cmd = A::augment_args(clap::Command::new("pomc").disable_help_flag(true));
    cmd.build();
    cmd
}

/// A clap error on one line, without its `error: ` prefix, usage and help hint.
fn clap_message(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !(l.is_empty() || l.starts_with("Usage:") || l.starts_with("For more information")))
        .collect();
    let line = lines.join(" ");
    line.strip_prefix("error: ").unwrap_or(&line).to_string()
}

/// Each option as a keyword (`_` for `-`) with its default as the command line shows it (`None`
/// without one; `false` for a flag), in declaration order.
pub fn keyword_defaults<A: clap::Args>() -> Vec<(String, Option<String>)> {
    command::<A>()
        .get_arguments()
        .filter_map(|a| {
            let long = a.get_long()?;
            let default = a.get_default_values().first().map(|v| v.to_string_lossy().into_owned());
            Some((long.replace('-', "_"), default))
        })
        .collect()
}

/// Comma-separated numbers (spaces allowed after commas); `what` names them in the error.
fn numbers(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("expected {what}, got `{s}`"))
}

/// An image size `WxH` (positive integers; the camera checks the limits).
pub fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("expected WxH (e.g. 1920x1080), got `{s}`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    match (w.trim().parse::<usize>(), h.trim().parse::<usize>()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(bad()),
    }
}

/// `FROM,TO` elevations in degrees with `0 ≤ FROM < TO ≤ 90`.
fn parse_pole_merge(s: &str) -> Result<(f64, f64), String> {
    let v = numbers(s, "two elevations FROM,TO in degrees")?;
    match v.as_slice() {
        [from, to] if *from >= 0.0 && to > from && *to <= 90.0 => Ok((*from, *to)),
        _ => Err(format!("expected FROM,TO in degrees with 0 ≤ FROM < TO ≤ 90, got `{s}`")),
    }
}

/// `NEAR,FAR` distances (m): two finite numbers with `0 < NEAR < FAR`.
fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let v = numbers(s, "two distances NEAR,FAR in metres")?;
    match v.as_slice() {
        [near, far] if *near > 0.0 && far > near && far.is_finite() => Ok((*near, *far)),
        _ => Err(format!("expected NEAR,FAR in metres with 0 < NEAR < FAR, got `{s}`")),
    }
}

/// `X,Y,METRES`: a pixel of the colour image and its distance along the ray.
fn parse_known_distance(s: &str) -> Result<KnownDistance, String> {
    let v = numbers(s, "X,Y,METRES (a colour pixel and its distance)")?;
    match v.as_slice() {
        [x, y, m]
            if *x >= 0.0 && *y >= 0.0 && x.is_finite() && y.is_finite() && *m > 0.0 && m.is_finite() =>
        {
            Ok(KnownDistance { x: *x, y: *y, metres: *m })
        }
        _ => Err(format!("expected X,Y,METRES with X, Y ≥ 0 (pixels) and METRES > 0, got `{s}`")),
    }
}

/// The domain of a number option: `lo < x` (or `lo <= x` when `lo_closed`), `x < hi` (or `<=`).
/// NaN and infinities are never in a domain.
#[derive(Clone, Copy, Debug)]
pub struct Range {
    /// Lower bound.
    pub lo: f64,
    /// Whether `lo` itself is in.
    pub lo_closed: bool,
    /// Upper bound.
    pub hi: f64,
    /// Whether `hi` itself is in.
    pub hi_closed: bool,
}

impl Range {
    /// Any finite number.
    pub const FINITE: Range = Range { lo: f64::MIN, lo_closed: true, hi: f64::MAX, hi_closed: true };
    /// A finite number above 0.
    pub const POSITIVE: Range = Range { lo: 0.0, lo_closed: false, hi: f64::MAX, hi_closed: true };
    /// A finite number 0 or above.
    pub const NON_NEGATIVE: Range = Range { lo: 0.0, lo_closed: true, hi: f64::MAX, hi_closed: true };
    /// A fraction in (0, 1].
    pub const FRACTION: Range = Range { lo: 0.0, lo_closed: false, hi: 1.0, hi_closed: true };
    /// An angle in (0, 180] degrees.
    pub const ANGLE: Range = Range { lo: 0.0, lo_closed: false, hi: 180.0, hi_closed: true };
    /// An angle in [0, 180] degrees, where 0 turns a test off.
    pub const ANGLE_OR_OFF: Range = Range { lo: 0.0, lo_closed: true, hi: 180.0, hi_closed: true };
    /// An angle in (0, 180) degrees (a field of view, a feature angle).
    pub const OPEN_ANGLE: Range = Range { lo: 0.0, lo_closed: false, hi: 180.0, hi_closed: false };

    /// Whether `x` is in the domain.
    fn contains(&self, x: f64) -> bool {
        x.is_finite()
            && (if self.lo_closed { x >= self.lo } else { x > self.lo })
            && (if self.hi_closed { x <= self.hi } else { x < self.hi })
    }

    fn describe(&self) -> String {
        match (self.lo == f64::MIN, self.hi == f64::MAX) {
            (true, true) => "a finite number".into(),
            (false, true) => {
                format!("a finite number {} {}", if self.lo_closed { ">=" } else { ">" }, self.lo)
            }
            _ => format!(
                "a number in {}{}, {}{}",
                if self.lo_closed { "[" } else { "(" },
                self.lo,
                self.hi,
                if self.hi_closed { "]" } else { ")" }
            ),
        }
    }

    /// A value parser for this domain (the message names the range).
    pub fn parser(self) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
        move |s: &str| match s.trim().parse::<f64>() {
            Ok(x) if self.contains(x) => Ok(x),
            _ => Err(format!("`{s}` is not {}", self.describe())),
        }
    }

    /// The same for `f32` options (the value must stay in the domain as an `f32`: no overflow to
    /// infinity, no underflow to 0).
    pub fn parser_f32(self) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync + 'static {
        let p = self.parser();
        move |s: &str| {
            let y = p(s)? as f32;
            if self.contains(f64::from(y)) {
                Ok(y)
            } else {
                Err(format!("`{s}` is not {} in single precision", self.describe()))
            }
        }
    }
}

#[cfg(test)]
mod tests;
