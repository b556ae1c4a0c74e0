"""Map images on disk, through OpenImageIO: float/half EXR and 16-bit PNG, written atomically.

Arrays are float32 (H, W) or (H, W, C), top row first, linear values. A write goes to a
temporary file in the destination folder and is renamed over the target, so a failed or
interrupted bake never leaves a truncated map, or the temporary file, behind
(``atomic.temporary_file``); the file gets the permissions of any new file (0666 less the
umask). String metadata (e.g. the input hash a bake stores) travels in the file's header.
"""

import os
from collections.abc import Mapping

import numpy as np

from ..contracts import map_file_name
from . import atomic

#: Header fields of a baked map: the hash of its inputs, the map's name, the UV map it was baked
#: on (weathered materials read the image through it, weathering.image_uv_map), what it was
#: made from: the .blend file (absolute path; empty when unsaved) and the object's exact name,
#: and the map's settings (JSON: a map that reads it checks they are its run's).
HASH_KEY = "pw:inputs"
SETTINGS_KEY = "pw:settings"
MAP_KEY = "pw:map"
UV_MAP_KEY = "pw:uv_map"
SOURCE_KEY = "pw:source"
OBJECT_KEY = "pw:object"


def image_path(out_dir: str, object_name: str, map_name: str) -> str:
    """``OUT/<object>.<map>.exr``, the object's name made safe (``safe_file_name``): "Wall/1"
    gives ``Wall_1-<hash>.rain.exr`` and "Wall_1" ``Wall_1.rain.exr``."""
    return os.path.join(out_dir, map_file_name(object_name, map_name))


def check_file_name(path: str | os.PathLike) -> None:
    """ValueError when the file name of ``path`` is longer (in bytes, as the file system counts)
    than its folder's file system holds (``PC_NAME_MAX``; 255 where it cannot be asked)."""
    name = os.fsencode(os.path.basename(os.fspath(path)))
    limit = _name_max(os.path.dirname(os.path.abspath(path)))
    if len(name) > limit:
        raise ValueError(
            f"the file name {os.fsdecode(name)!r} is {len(name)} bytes, "
            f"more than the {limit} its folder's file system holds"
        )


def _name_max(folder):
    while not os.path.isdir(folder) and os.path.dirname(folder) != folder:  # a folder the bake will make
        folder = os.path.dirname(folder)
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return 255


class NonFiniteMap(RuntimeError):
    """A map about to be stored holds NaN or an infinity: a bug in the maths that made it, never
    written (a map's values are in [0, 1])."""


def check_finite(values: np.ndarray, where: str) -> None:
    """NonFiniteMap, one line naming ``where`` the map was to go, unless every value is finite.
    Checked before any clipping: np.clip keeps NaN."""
    bad = np.count_nonzero(~np.isfinite(values))
    if bad:
        raise NonFiniteMap(f"{where}: {bad} of {np.size(values)} values are not finite (a bug): nothing was written")


#: file extension -> (OpenImageIO pixel type name, header attributes)
FORMATS = {
    ".exr": {"float": ("float", {"compression": "zip"}), "half": ("half", {"compression": "zip"})},
    ".png": {"uint16": ("uint16", {})},
}
DEFAULT_PIXEL_TYPE = {".exr": "float", ".png": "uint16"}


def write_image(
    path: str | os.PathLike,
    pixels: np.ndarray,
    *,
    pixel_type: str | None = None,
    metadata: Mapping[str, str] | None = None,
) -> None:
    """Write ``pixels`` to ``path`` (.exr: "float" or "half"; .png: "uint16"), atomically.

    PNG values are clipped to [0, 1] and quantised to 1/65535; EXR keeps them as they are.
    Raises OSError naming the file when the folder is missing or not writable, and NonFiniteMap
    for NaN or infinite pixels (nothing written).
    """
    import OpenImageIO as oiio

    path = os.fspath(path)
    extension = os.path.splitext(path)[1].lower()
    if extension not in FORMATS:
        raise ValueError(f"{path}: unsupported map format {extension!r} (use .exr or .png)")
    pixel_type = pixel_type or DEFAULT_PIXEL_TYPE[extension]
    if pixel_type not in FORMATS[extension]:
        raise ValueError(f"{path}: {extension} maps take pixel types {sorted(FORMATS[extension])}, not {pixel_type!r}")
    type_name, attributes = FORMATS[extension][pixel_type]

    pixels = np.asarray(pixels, dtype=np.float32)
    check_finite(pixels, path)
    if pixels.ndim == 2:
        pixels = pixels[..., np.newaxis]
    if extension == ".png":
        pixels = np.clip(pixels, 0.0, 1.0)
    height, width, channels = pixels.shape
    spec = oiio.ImageSpec(width, height, channels, type_name)
    for name, value in {**attributes, **(metadata or {})}.items():
        spec.attribute(name, value)

    folder = os.path.dirname(os.path.abspath(path))
    try:
        with atomic.temporary_file(folder, extension) as temporary:
            _write_file(oiio, temporary, spec, pixels)
            atomic.move_into_place(temporary, path)
    except OSError as error:
        raise OSError(f"cannot write image {path}: {error.strerror or error}") from error


def _write_file(oiio, path, spec, pixels):
    output = oiio.ImageOutput.create(path)
    if output is None or not output.open(path, spec):
        raise OSError(oiio.geterror() or (output and output.geterror()) or "OpenImageIO cannot open it")
    written = output.write_image(np.ascontiguousarray(pixels))
    error = output.geterror()
    output.close()
    if not written:
        raise OSError(error)


def read_image(path: str | os.PathLike) -> tuple[np.ndarray, dict[str, str]]:
    """(pixels float32 (H, W, C), metadata dict of the header's string attributes)."""
    import OpenImageIO as oiio

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no image file {path}")
    buffer = oiio.ImageBuf(path)
    pixels = buffer.get_pixels(oiio.FLOAT)
    if buffer.has_error or pixels is None:
        raise OSError(f"cannot read image {path}: {buffer.geterror()}")
    return np.asarray(pixels, dtype=np.float32), _string_attributes(buffer.spec())


def read_metadata(path: str | os.PathLike) -> dict[str, str]:
    """The header's string attributes of an image file, or {} when there is no readable file."""
    return image_header(path) or {}


def image_header(path: str | os.PathLike) -> dict[str, str] | None:
    """The header's string attributes of an image file, or None when there is no file that
    OpenImageIO can read (missing, corrupt or not an image)."""
    import OpenImageIO as oiio

    image = oiio.ImageInput.open(os.fspath(path))
    if image is None:
        oiio.geterror()  # clear OpenImageIO's pending error message
        return None
    try:
        return _string_attributes(image.spec())
    finally:
        image.close()


def _string_attributes(spec):
    return {attribute.name: attribute.value for attribute in spec.extra_attribs if isinstance(attribute.value, str)}
