"""Efflorescence location maps (docs/model.md §4.3, paper section 4.3): a height field in [0, 1] that says
where salt fills the pores first (highest first).  Either generated, concentrated along the
mortar joints of a running-bond brick pattern (where brick/mortar migration brings the salt),
or made from a user's photograph of efflorescence: luminance, denoised and normalised with
OpenImageIO.  Maps are float32 (H, W) arrays, top row first, written atomically as EXR
beside the .blend by ``save_map``; ``make_map`` makes an object's map and links it, the
``make`` of this module's record, ``MAP`` (a ``MadeMap``: a map that is made, not baked).
Nothing here needs bpy at import time: only ``default_path`` and ``make_map`` use it.
"""

import os
from typing import TYPE_CHECKING

import numpy as np

from ..common import imageio
from ..core.arguments import whole_number
from ..core.modes.efflorescence import EFFLORESCENCE_MAP
from .registry import MadeMap

if TYPE_CHECKING:
    import bpy

#: The map's name (``Input.map`` of the efflorescence location input, ``pw_<map>_image``).
MAP_NAME = EFFLORESCENCE_MAP.map

#: Rec. 709 luma weights: a photograph's brightness, as the eye sees it.
LUMA = (0.2126, 0.7152, 0.0722)

#: Share of the photograph's darkest and brightest pixels ignored by the normalisation, so a
#: few specular glints or deep shadows do not squash the rest of the range.
CLIP_PERCENT = 1.0


def brick_joint_map(
    size: int = 512,
    *,
    rows: int = 8,
    bricks_per_row: int = 4,
    mortar: float = 0.015,
    reach: float = 0.025,
    noise: float = 0.4,
    seed: int = 0,
) -> np.ndarray:
    """A (size, size) location map for a running-bond brick texture of ``rows`` courses
    (``size`` an int: ValueError naming it otherwise).

    1 on the mortar joints (``mortar`` wide, in texture units), falling off exponentially over
    ``reach`` into each brick, multiplied by smooth noise of strength ``noise`` in [0, 1] so the
    salt does not appear evenly along every joint; normalised to [0, 1].
    """
    size = whole_number("size", size)
    centres = (np.arange(size) + 0.5) / size
    v, u = centres[::-1, None], centres[None, :]  # top row first: v = 1 at the top
    course = np.floor(v * rows)
    across = np.abs(v * rows - course - 0.5)  # 0.5 at a bed joint
    along = np.abs((u * bricks_per_row + 0.5 * (course % 2)) % 1.0 - 0.5)  # 0.5 at a head joint
    to_joint = np.minimum((0.5 - across) / rows, (0.5 - along) / bricks_per_row)
    height = np.exp(-np.maximum(to_joint - mortar / 2, 0.0) / reach)
    return normalise(height * (1.0 - noise + noise * smooth_noise(size, seed)))


def smooth_noise(size: int, seed: int, cells: int = 12) -> np.ndarray:
    """(size, size) value noise in [0, 1]: a random ``cells``² grid resized smoothly (OpenImageIO)."""
    import OpenImageIO as oiio

    grid = np.random.default_rng(seed).random((cells, cells, 1), dtype=np.float32)
    resized = oiio.ImageBufAlgo.resize(_buffer(grid), roi=oiio.ROI(0, size, 0, size, 0, 1, 0, 1))
    return np.clip(resized.get_pixels(oiio.FLOAT)[..., 0], 0.0, 1.0)


def photo_map(photo_path: str | os.PathLike, *, denoise_width: int = 5, size: int | None = None) -> np.ndarray:
    """A location map from a photograph of efflorescence, turned upright as a viewer shows it
    (a camera's Exif orientation), its luminance (Rec. 709 weights of the stored values),
    median-filtered over ``denoise_width`` pixels to remove grain and small specks, resized to
    ``size``² if given, and normalised to [0, 1] between its 1st and 99th percentiles.  Raises
    OSError naming the file if it cannot be read.
    """
    import OpenImageIO as oiio

    size = None if size is None else whole_number("size", size)
    photo = oiio.ImageBuf(os.fspath(photo_path))
    # check before reading pixels: get_pixels of a buffer that failed to open trips an OIIO assertion
    pixels = None if photo.has_error else photo.get_pixels(oiio.FLOAT)
    if photo.has_error or pixels is None:
        raise OSError(f"cannot read photograph {photo_path}: {photo.geterror() or oiio.geterror()}")
    if photo.orientation != 1:  # a camera stores its sensor's rows, and the Exif tag how to turn them
        pixels = oiio.ImageBufAlgo.reorient(photo).get_pixels(oiio.FLOAT)
    channels = pixels.shape[-1]
    colour = pixels[..., :3] if channels >= 3 else pixels[..., :1]
    luminance = (colour @ np.asarray(LUMA, dtype=np.float32))[..., None] if channels >= 3 else colour
    buffer = _buffer(luminance)
    if denoise_width > 1:
        buffer = oiio.ImageBufAlgo.median_filter(buffer, int(denoise_width), int(denoise_width))
    if size is not None:
        buffer = oiio.ImageBufAlgo.resize(buffer, roi=oiio.ROI(0, size, 0, size, 0, 1, 0, 1))
    return normalise(buffer.get_pixels(oiio.FLOAT)[..., 0], CLIP_PERCENT)


def normalise(height: np.ndarray, clip_percent: float = 0.0) -> np.ndarray:
    """``height`` stretched to [0, 1] between its ``clip_percent`` and 100 - ``clip_percent``
    percentiles, NaN taken as the lowest value; a flat field becomes all 0."""
    height = np.asarray(height, dtype=np.float64)
    height = np.nan_to_num(
        height,
        nan=np.nanmin(height) if np.isfinite(height).any() else 0.0,
        posinf=np.finfo(np.float32).max,
        neginf=np.finfo(np.float32).min,
    )
    low, high = np.percentile(height, (clip_percent, 100.0 - clip_percent))
    if high <= low:
        return np.zeros(height.shape, dtype=np.float32)
    return np.clip((height - low) / (high - low), 0.0, 1.0).astype(np.float32)


def default_path(name: str) -> str:
    """``<folder of the .blend>/<name>.efflorescence.exr``, named as a bake names its maps
    (``imageio.image_path``: a name a file name cannot hold gets a hash suffix, so that two
    objects never share a file); ValueError if the .blend is unsaved."""
    import bpy

    if not bpy.data.filepath:
        raise ValueError("save the .blend first: the efflorescence map is saved beside it")
    path = imageio.image_path(os.path.dirname(bpy.data.filepath), name, MAP_NAME)
    imageio.check_file_name(path)
    return path


def make_map(
    obj: "bpy.types.Object",
    *,
    photo: str | os.PathLike | None = None,
    size: int = 512,
    rows: int = 8,
    bricks_per_row: int = 4,
    force: bool = False,
) -> "bpy.types.Image":
    """Make the mesh ``obj``'s efflorescence map beside the .blend (``default_path``) and point
    ``obj`` at it (``bake.link_image``): from the photograph ``photo`` if given (an empty path
    is refused), else along brick joints (``brick_joint_map`` of ``rows`` courses of
    ``bricks_per_row``), ``size``² pixels.  The map records what it was made from, as a bake's
    does (``Provenance``): a file there made from another .blend or object, or not by this
    extension, is refused (``OverwriteRefused``) unless ``force``.  ValueError or OSError, the
    file unchanged, if ``obj`` has no UV map, the .blend is unsaved, ``size`` is no int or the
    photograph cannot be read."""
    from .bake import link_image
    from .provenance import Provenance, refuse_overwrite

    size = whole_number("size", size)
    if not obj.data.uv_layers:
        raise ValueError("has no UV map to read an efflorescence map through: unwrap it first")
    path = default_path(obj.name)
    made = Provenance.of(obj, MAP_NAME)
    if not force:
        refuse_overwrite(path, made)
    if photo is not None:
        if not os.fspath(photo):
            raise ValueError("choose the photograph to make the efflorescence map from")
        height = photo_map(photo, size=size)
    else:
        height = brick_joint_map(size, rows=rows, bricks_per_row=bricks_per_row)
    return link_image(obj, MAP_NAME, save_map(height, path, metadata=made.header()))


def save_map(height: np.ndarray, path: str | os.PathLike, metadata: dict[str, str] | None = None) -> str:
    """Write a location map as a single-channel float EXR, atomically, with ``metadata`` in its
    header; returns the path."""
    imageio.write_image(path, np.asarray(height, dtype=np.float32), metadata=metadata)
    return os.fspath(path)


def _buffer(pixels):
    import OpenImageIO as oiio

    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    buffer = oiio.ImageBuf(oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], oiio.FLOAT))
    buffer.set_pixels(oiio.ROI(), pixels)
    return buffer


MAP = MadeMap(
    name=MAP_NAME,
    label="Efflorescence",
    description="Efflorescence location map: where salt fills the pores first, from brick joints or a photograph",
    make=make_map,
    order=10,
)
