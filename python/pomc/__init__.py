"""pomc: layered omnidirectional RGB-D panoramas (POMC) from Python.

Calls the Rust library directly (no subprocesses); heavy calls release the GIL.

    import numpy as np, pomc
    pano = pomc.build(colour, depth, freedom_radius=0.9)   # H×W×3 uint8/uint16/float32, H×W float32 metres
    pano.save("out")
    report = pano.validate()
    colour, depth, mask = pano.render(eye=(0.2, 0, 0), look_at=(0.2, 1, 0))
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import _pomc
from ._pomc import PomcError

__all__ = [
    "build",
    "build_files",
    "open",
    "Panorama",
    "Layer",
    "Report",
    "Issue",
    "PomcError",
    "BUILD_OPTIONS",
    "pack",
    "prepare_depth",
    "scene",
    "unpack",
    "SCENE_OPTIONS",
    "MESH_OPTIONS",
    "RENDER_OPTIONS",
    "render_files",
    "save_colour",
]

#: Options :func:`build` and :func:`build_files` take as named parameters, not in ``**options``.
_NAMED = ("freedom_radius", "convention", "center")


def _defaults(job: str) -> Dict[str, Any]:
    """The options of ``pomc JOB`` as keywords, with the command's defaults as Python values (the
    library declares them once; ``_pomc.option_defaults`` lists them)."""
    out: Dict[str, Any] = {}
    for key, text in _pomc.option_defaults(job):
        # `scene` takes the convention of its maps as an ordinary option (build names it).
        if (key in _NAMED and not (job == "scene" and key == "convention")) or (
            job == "render" and key in ("eye", "look_at")
        ):
            continue
        value: Any = text
        if text in ("true", "false"):
            value = text == "true"
        else:
            try:
                value = float(text) if text is not None else None
            except ValueError:
                pass
        if key.startswith("no_") and value is False and job == "mesh":
            key, value = key[3:], True  # `simplify=False` is `--no-simplify`
        out[key] = value
    return out


#: Keyword options of :func:`build`, with the values ``pomc build`` uses by default.
BUILD_OPTIONS: Dict[str, Any] = _defaults("build")

#: Keyword options of :meth:`Panorama.mesh` and :meth:`Panorama.export_mesh`, with the values
#: ``pomc mesh`` uses by default (``simplify`` and ``greedy`` are the negations of
#: ``--no-simplify`` and ``--no-greedy``; 0 turns ``max_error`` and ``max_angle`` off).
MESH_OPTIONS: Dict[str, Any] = _defaults("mesh")

#: Keyword options of :func:`scene`, with the values ``pomc scene`` uses by default.
SCENE_OPTIONS: Dict[str, Any] = _defaults("scene")

#: Camera keyword options of :meth:`Panorama.render`, with the values ``pomc render`` uses by
#: default (``size`` is a (width, height) pair; ``eye`` and ``look_at`` are its arguments).
RENDER_OPTIONS: Dict[str, Any] = _defaults("render")


def _usage(message: str) -> PomcError:
    err = PomcError(message)
    err.code = "CLI_USAGE"
    return err


@dataclass(frozen=True)
class Issue:
    """One validation finding."""

    code: str
    severity: str
    message: str
    location: str


@dataclass(frozen=True)
class Report:
    """What :meth:`Panorama.validate` found (the JSON of ``pomc validate --json``)."""

    valid: bool
    errors: int
    warnings: int
    issues: List[Issue] = field(default_factory=list)


@dataclass(frozen=True)
class Layer:
    """One layer as full-canvas arrays: colour H×W×3 float32 linear, depth H×W float32 metres
    along the ray (inf: infinitely far, NaN: unknown), mask H×W bool (inside the layer)."""

    name: str
    role: Optional[str]
    order: int
    colour: np.ndarray
    depth: np.ndarray
    mask: np.ndarray


class Panorama:
    """A layered panorama held in memory (from :func:`build` or :func:`open`)."""

    def __init__(self, inner: "_pomc.Panorama") -> None:
        self._inner = inner

    def __len__(self) -> int:
        return len(self._inner)

    def __repr__(self) -> str:
        where = f" at {self.path}" if self.path else ""
        return f"<pomc.Panorama: {len(self)} layers, freedom radius {self.freedom_radius} m{where}>"

    @property
    def path(self) -> Optional[str]:
        """Directory the panorama was read from or last saved to."""
        p = self._inner.path
        return None if p is None else os.fspath(p)

    @property
    def freedom_radius(self) -> float:
        return self._inner.freedom_radius

    @property
    def manifest_xml(self) -> str:
        """The manifest (``panorama.xml``) as text."""
        return self._inner.manifest_xml()

    @property
    def layers(self) -> List[Layer]:
        """Every layer, in manifest order, as full-canvas numpy arrays (packed layers unpacked)."""
        out = []
        for k in range(len(self._inner)):
            name, role, order = self._inner.layer_info(k)
            colour, depth, mask = self._inner.layer_arrays(k)
            out.append(Layer(name, role, order, colour, depth, mask))
        return out

    def save(self, directory: "os.PathLike[str] | str") -> None:
        """Write the panorama into ``directory`` (manifest + one OpenEXR per layer, atomically)."""
        _pomc.Panorama.save_into(self._inner, os.fspath(directory))

    def validate(self) -> Report:
        """Check the panorama against the POMC 1 spec, as ``pomc validate``."""
        raw = json.loads(self._inner.validate_json())
        issues = [Issue(i["code"], i["severity"], i["message"], i["location"]) for i in raw["issues"]]
        return Report(raw["valid"], raw["errors"], raw["warnings"], issues)

    def render(
        self,
        eye: Optional[Sequence[float]] = None,
        look_at: Optional[Sequence[float]] = None,
        *,
        method: str = "splat",
        **camera: Any,
    ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Render a view as ``pomc render`` (world frame, metres): colour H×W×3 float32 linear,
        depth H×W float32 (distance from the eye; -1 in holes), mask H×W bool (covered).
        :func:`save_colour` writes the colour as ``pomc render -o`` does (PNG sRGB, EXR linear).

        ``eye`` defaults to the panorama centre, ``look_at`` to the centre of the panorama image.
        Camera options are ``pomc render``'s, see :data:`RENDER_OPTIONS`: ``camera``
        ("perspective", "equirect", "ods", "vr180" or "cube", with ``stereo`` and
        ``cube_layout``), ``up``, ``fov`` (horizontal degrees), ``size`` ((width, height) of the
        whole image), and for stereo ``stereo_layout`` ("tb" or "sbs"),
        ``ipd`` (metres), ``pole_merge`` ((from, to) degrees) and ``no_pole_merge``."""
        if method not in ("splat", "mesh"):
            raise _usage(f"method must be 'splat' or 'mesh', got {method!r}")
        size = camera.get("size")
        if size is not None and not isinstance(size, str):
            camera["size"] = f"{int(size[0])}x{int(size[1])}"
        colour, depth, mask, _ = self._inner.render(
            None if eye is None else _vec3("eye", eye),
            None if look_at is None else _vec3("look_at", look_at),
            method,
            camera,
        )
        return colour, depth, mask

    def mesh(self, layer: Optional[int] = None, **options: Any) -> List[Dict[str, Any]]:
        """Mesh every layer (painter's order) or one, as ``pomc mesh``: a list of dicts with
        ``name``, ``layer``, ``vertices`` (N×3, panorama-local metres), ``triangles`` (M×3),
        ``uv`` (N×2, canvas coordinates) and ``sky_radius`` (the sky dome's, for the infinity
        layer). Options: every ``pomc mesh`` option, see :data:`MESH_OPTIONS` for names and
        defaults."""
        return self._inner.mesh(layer, options)

    def export_mesh(self, path: "os.PathLike[str] | str", **options: Any) -> List[str]:
        """Write every layer's mesh into one scene file (.glb, .obj + .mtl + textures, .ply) as
        ``pomc mesh PANO -o PATH``; returns the files written. Also ``local=True`` for
        panorama-local coordinates."""
        local = bool(options.pop("local", False))
        files = self._inner.export_mesh(os.fspath(path), options, local=local)
        return [os.fspath(f) for f in files]


def save_colour(path: "os.PathLike[str] | str", colour: np.ndarray) -> None:
    """Write a rendered colour (H×W×3, linear, as :meth:`Panorama.render` returns) as
    ``pomc render -o PATH`` does: ``.png`` 8-bit sRGB (clamped, the sRGB transfer function),
    ``.exr`` linear float; written atomically."""
    a = np.asarray(colour)
    if a.ndim != 3 or a.shape[2] != 3:
        raise _usage(f"colour must be H×W×3 (as render returns), got shape {a.shape}")
    _pomc.save_colour(os.fspath(path), np.ascontiguousarray(a, dtype=np.float32))


def _vec3(name: str, v: Sequence[float]) -> List[float]:
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise _usage(f"{name} must be three finite numbers, got {v!r}")
    return [float(x) for x in a]


def open(path: "os.PathLike[str] | str") -> Panorama:  # noqa: A001 (the documented name)
    """Open a panorama directory (or its ``panorama.xml``), reading every layer."""
    return Panorama(_pomc.open(os.fspath(path)))


def _build_options(freedom_radius: float, convention: str, center: Sequence[float], options: Dict[str, Any]) -> Dict[str, Any]:
    """The keyword options of a build (names as ``pomc build``'s, ``-`` as ``_``); the library
    checks them as it checks the command line's."""
    opts = dict(options, freedom_radius=freedom_radius, convention=convention)
    c = _vec3("center", center)
    if any(c):
        opts["center"] = c
    return opts


def build_files(
    colour: "os.PathLike[str] | str",
    depth: "os.PathLike[str] | str",
    output: "os.PathLike[str] | str",
    *,
    freedom_radius: float = 0.5,
    convention: str = "thesis",
    center: Sequence[float] = (0.0, 0.0, 0.0),
    **options: Any,
) -> Dict[str, Any]:
    """Build from image files straight into ``output``, exactly as ``pomc build --colour C --depth
    D -o OUTPUT`` (the library reads the images; the panorama is written atomically). Returns the
    report ``pomc build --json`` prints: ``layers`` (one entry per layer), ``prepare``, ``stages``,
    ``read_s``, ``build_s``, ``write_s``, ``total_s`` and the build's figures."""
    opts = _build_options(freedom_radius, convention, center, options)
    return json.loads(_pomc.build_files(os.fspath(colour), os.fspath(depth), os.fspath(output), opts))


def scene(
    scene: "os.PathLike[str] | str",
    output: "os.PathLike[str] | str",
    *,
    freedom_radius: float = 0.5,
    center: Sequence[float] = (0.0, 0.0, 0.0),
    **options: Any,
) -> Dict[str, Any]:
    """Make a layered panorama from a 3D scene (``.gltf``, ``.glb``, ``.obj``; +Y up) into
    ``output``, exactly as ``pomc scene SCENE -o OUTPUT``: every surface along every ray from
    ``center`` (pomc's +Z-up world: glTF's x, -z, y) that an eye within ``freedom_radius`` sees.
    Keywords: :data:`SCENE_OPTIONS` (``width``, ``mapping``, ``samples``, ``sky``,
    ``sky_colour``, ``colour``: a list of renders from the centre, the k-th colouring each ray's
    k-th hit, ...). Returns the report (``layers``, ``occupancy``, ``stages``, ``hits``, ...)."""
    opts: Dict[str, Any] = dict(options)
    opts["freedom_radius"] = freedom_radius
    opts["center"] = [float(c) for c in center]
    return json.loads(_pomc.scene_files(os.fspath(scene), os.fspath(output), opts))


def pack(
    input: "os.PathLike[str] | str",
    output: "os.PathLike[str] | str",
    *,
    threshold: float = 0.5,
    padding: int = 0,
) -> Dict[str, Any]:
    """Write the panorama ``input`` again into ``output`` (which may be its own directory) with
    each sparse layer patch-packed when its atlas is at most ``threshold`` of its canvas, exactly as
    ``pomc pack INPUT -o OUTPUT``; ``padding`` pixels of guard band around each patch. Returns the
    report (``layers``: name, packed, canvas, atlas, patches, occupancy, ...; ``timings_s``)."""
    return json.loads(_pomc.repack_files(os.fspath(input), os.fspath(output), True, float(threshold), int(padding)))


def unpack(input: "os.PathLike[str] | str", output: "os.PathLike[str] | str") -> Dict[str, Any]:
    """Write the panorama ``input`` again into ``output`` with every layer on its full canvas,
    exactly as ``pomc unpack INPUT -o OUTPUT``; returns the report as :func:`pack` does."""
    return json.loads(_pomc.repack_files(os.fspath(input), os.fspath(output), False, 0.5, 0))


def render_files(
    pano: "os.PathLike[str] | str",
    output: "os.PathLike[str] | str",
    *,
    eye: Optional[Sequence[float]] = None,
    look_at: Optional[Sequence[float]] = None,
    path: "os.PathLike[str] | str | None" = None,
    method: str = "splat",
    depth: "os.PathLike[str] | str | None" = None,
    mask: "os.PathLike[str] | str | None" = None,
    **camera: Any,
) -> Dict[str, Any]:
    """Render views of the panorama directory ``pano`` into files exactly as ``pomc render PANO -o
    OUTPUT``: one view from ``eye`` (default the centre) towards ``look_at``, or one frame per line
    of the camera path file ``path`` (``EYE [LOOK_AT]``; every output name then needs a run of
    ``#`` for the frame number). ``depth`` and ``mask`` also write the distance (EXR) and the
    coverage (PNG). Camera options as :meth:`Panorama.render`'s. Returns the command's ``--json``
    report (one view's figures and ``stages``, or ``frames`` and their medians)."""
    size = camera.get("size")
    if size is not None and not isinstance(size, str):
        camera["size"] = f"{int(size[0])}x{int(size[1])}"
    if eye is not None:
        camera["eye"] = _vec3("eye", eye)
    if look_at is not None:
        camera["look_at"] = _vec3("look_at", look_at)
    paths = [None if p is None else os.fspath(p) for p in (depth, mask, path)]
    return json.loads(_pomc.render_files(os.fspath(pano), os.fspath(output), *paths, method, camera))


def prepare_depth(
    colour: "os.PathLike[str] | str",
    depth: "os.PathLike[str] | str",
    **options: Any,
) -> "tuple[np.ndarray, Dict[str, Any]]":
    """Read and prepare depth exactly as ``pomc build`` does before layering (``pomc prepare``):
    returns the depth on the colour's grid (H×W float32, metres along the ray, ``inf`` infinitely
    far) and the report (what was resized, completed, smoothed; warnings). Keywords: the depth
    options of :data:`BUILD_OPTIONS` (``depth_kind``, ``depth_range``, ``camera_height``,
    ``refine``, ``unknown_depth``, ``preset``, ``depth_scale``, ``depth_invalid``, ...)."""
    opts = _build_options(0.5, "thesis", (0.0, 0.0, 0.0), options)
    array, report = _pomc.prepare_files(os.fspath(colour), os.fspath(depth), opts)
    return array, json.loads(report)


def build(
    colour: np.ndarray,
    depth: np.ndarray,
    *,
    freedom_radius: float = 0.5,
    convention: str = "thesis",
    center: Sequence[float] = (0.0, 0.0, 0.0),
    **options: Any,
) -> Panorama:
    """Build a layered panorama from a plain RGB-D panorama, as ``pomc build``.

    ``colour``: H×W×3 (or H×W×4: alpha is ignored) uint8 or uint16 (sRGB) or float32 (linear); ``depth``: H×W metres along
    the ray (``inf`` sky, ``nan`` or 0 unknown; integer depth needs ``depth_scale`` or ``preset``).
    A 2:1 canvas is an equirect, 3:2 a cube map. The ``pomc build`` options are keywords (``-`` as
    ``_``; ``normals_in`` is the path of a normals EXR of the same size): see :data:`BUILD_OPTIONS`
    for names and defaults.
    """
    opts = _build_options(freedom_radius, convention, center, options)
    colour = np.asarray(colour)
    if colour.ndim == 3 and colour.shape[2] == 4:
        colour = colour[..., :3]  # RGBA as image libraries load it: the alpha says nothing of depth
    colour = np.ascontiguousarray(colour)
    if colour.dtype not in (np.uint8, np.uint16, np.float32):
        if np.issubdtype(colour.dtype, np.floating):
            colour = colour.astype(np.float32)
        else:
            raise _usage(f"colour must be uint8, uint16 or float32, got {colour.dtype}")
    depth_arr = np.asarray(depth)
    unitless = opts.get("depth_scale") is None and opts.get("preset") is None
    if np.issubdtype(depth_arr.dtype, np.integer) and unitless:
        err = PomcError(
            "integer depth has no unit; give depth_scale (metres per stored unit, e.g. 0.001 for "
            "millimetres) or a dataset preset (matterport3d, stanford2d3ds, structured3d)"
        )
        err.code = "INPUT_DEPTH_SCALE_NEEDED"
        raise err
    if depth_arr.ndim != 2:
        raise _usage(f"depth must be H×W, got shape {depth_arr.shape}")
    depth_arr = np.ascontiguousarray(depth_arr, dtype=np.float32)
    return Panorama(_pomc.build(colour, depth_arr, opts))
