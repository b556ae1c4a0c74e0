"""Bad parameters and files: every numeric input at, below and above its range and NaN; a rain
direction that cannot be made; missing, corrupt and wrong-format images; output folders that
cannot be written; paths with spaces and non-ASCII characters.

Read-only folders: the tests run as root, and root writes through file modes, so a folder
made read-only with chmod is only refused when ``os.access`` says so (a normal user); the
tests that must refuse whoever runs them use a path below a regular file (ENOTDIR) or in /proc.
"""

import math
import os
import warnings

import bpy

import numpy as np
import pytest

import porous_weathering as pw
from bad_meshes import cube, data_counts
from helpers import corner_values, run_cli
from porous_weathering import weathering
from porous_weathering.common import imageio
from porous_weathering.core import model
from porous_weathering.core.model import PorousInputWarning
from porous_weathering.maps import bake, edges, rain, runoff
from porous_weathering.publish import export
from porous_weathering.samples import studio

NAN = math.nan

#: make_porous_material keyword -> (group socket, low, high): the ranges of docs/model.md §1.
MATERIAL_INPUTS = {
    "ks": ("Specular", 0.0, 1.0),
    "roughness": ("Roughness", 0.0, 1.5),
    "porosity": ("Porosity", 0.0, 1.0),
    "pore_depth_ratio": ("Pore Depth Ratio", 0.0, 10.0),
}


def material_input(keyword, value):
    """The group socket value a material built with ``keyword=value`` (on black k_d) got."""
    material = pw.make_porous_material("M", base_color=(0.0, 0.0, 0.0), **{keyword: value})
    return material.node_tree.nodes["Porous"].inputs[MATERIAL_INPUTS[keyword][0]].default_value


@pytest.mark.parametrize("keyword", MATERIAL_INPUTS)
def test_material_inputs_at_their_bounds_are_kept_exactly(fresh_scene, keyword):
    _, low, high = MATERIAL_INPUTS[keyword]
    with warnings.catch_warnings():
        warnings.simplefilter("error", PorousInputWarning)
        assert material_input(keyword, low) == low
        assert material_input(keyword, high) == pytest.approx(high)


@pytest.mark.parametrize("keyword", MATERIAL_INPUTS)
@pytest.mark.parametrize("where", ["below", "above", "NaN", "-inf"])
def test_material_inputs_out_of_range_are_clamped_with_a_named_warning(fresh_scene, keyword, where):
    _, low, high = MATERIAL_INPUTS[keyword]
    value, expected = {
        "below": (low - 0.5, low),
        "above": (high + 0.5, high),
        "NaN": (NAN, low),
        "-inf": (-math.inf, low),
    }[where]
    name = {"ks": "k_s", "roughness": "m", "porosity": "alpha", "pore_depth_ratio": "s_p"}[keyword]
    with pytest.warns(PorousInputWarning, match=f"'{name}'"):
        assert material_input(keyword, value) == pytest.approx(expected)


def test_base_colour_nan_and_out_of_range_channels_are_clamped(fresh_scene):
    with pytest.warns(PorousInputWarning, match="'k_d'"), pytest.warns(PorousInputWarning, match="k_s \\+ k_d > 1"):
        material = pw.make_porous_material("M", base_color=(NAN, -1.0, 7.0), ks=0.1)
    assert tuple(material.node_tree.nodes["Porous"].inputs["Base Color"].default_value) == pytest.approx(
        (0.0, 0.0, 0.9, 1.0)
    )


@pytest.mark.parametrize("bad", [(0.5, 0.5), 3, "", None])
def test_base_colour_of_the_wrong_shape_is_refused_before_anything_is_made(fresh_scene, bad):
    before = data_counts()
    with pytest.raises(ValueError, match="base_color|base colour"):
        pw.make_porous_material("M", base_color=bad)
    assert data_counts() == before


@pytest.mark.parametrize("name", list(model.WEATHERING_INPUTS))
def test_weathering_inputs_clamp_below_above_and_nan(name):
    default, low, high, users = model.WEATHERING_INPUTS[name]
    shape = np.shape(default)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PorousInputWarning)
        for value in (low, high):
            assert np.all(model.weathering_state(users, {name: np.full(shape, value)})[name] == value)
    for value, expected in ((low - 1.0, low), (high + 1.0, high), (NAN, low)):
        with pytest.warns(PorousInputWarning, match=f"'{name}'"):
            state = model.weathering_state(users, {name: np.full(shape, value)})
        assert np.all(state[name] == expected)
        kd, ks, water = model.weathered_coefficients(
            (0.5, 0.4, 0.3), 0.1, 0.4, 0.3, 2.0, 0.7, 0.9, users, **{name: np.full(shape, expected)}
        )
        assert np.isfinite(kd).all() and np.isfinite(ks).all() and np.isfinite(water).all()


@pytest.mark.parametrize(
    "field, good, bad",
    [
        ("cone", [1e-3, 15.0, 89.0], [0.0, -5.0, 89.5, NAN, math.inf]),
        ("wind_tilt", [0.0, 45.0, 90.0], [-1.0, 90.5, NAN]),
        ("samples", [1, 4096], [0, -3]),
    ],
)
def test_rain_settings_range(field, good, bad):
    for value in good:
        towards = rain.RainSettings(**{field: value}).towards_rain()
        assert np.linalg.norm(towards) == pytest.approx(1.0)
    for value in bad:
        with pytest.raises(ValueError, match=field.split("_")[-1]):
            rain.RainSettings(**{field: value})


@pytest.mark.parametrize("azimuth", [NAN, math.inf])
def test_rain_azimuth_that_is_not_finite_is_refused(azimuth):
    with pytest.raises(ValueError, match="azimuth"):
        rain.RainSettings(wind_azimuth=azimuth)


def test_rain_direction_is_never_of_zero_length():
    """The rain direction is given as (tilt, azimuth), not as a vector: every value in range,
    and azimuths far outside one turn, give a unit vector, so a zero-length one cannot occur."""
    for tilt in np.linspace(0.0, 90.0, 7):
        for azimuth in (-720.0, -90.0, 0.0, 33.0, 359.9, 1e6):
            towards = rain.RainSettings(wind_tilt=tilt, wind_azimuth=azimuth).towards_rain()
            assert np.linalg.norm(towards) == pytest.approx(1.0) and towards[2] >= -1e-12


def test_aiming_a_light_along_a_zero_vector_is_refused(fresh_scene):
    sun = studio.add_sun(fresh_scene, (0.0, 0.0, 1.0))
    with pytest.raises(ValueError):
        studio.aim_sun(sun, (0.0, 0.0, 0.0))


@pytest.mark.parametrize("resolution, accepted", [(7, False), (8, True), (16384, True), (16385, False)])
def test_bake_resolution_range(resolution, accepted):
    if accepted:
        assert bake.BakeOptions(resolution=resolution).resolution == resolution
    else:
        with pytest.raises(ValueError, match="resolution"):
            bake.BakeOptions(resolution=resolution)


@pytest.mark.parametrize(
    "options",
    [dict(edge_radius=0.0), dict(edge_radius=-1.0), dict(edge_radius=NAN), dict(resolution=16.5)],
    ids=["radius 0", "radius -1", "radius NaN", "resolution 16.5"],
)
def test_bake_options_refuse_bad_numbers_up_front(options):
    with pytest.raises(ValueError, match="radius|resolution"):
        bake.BakeOptions(**options)


@pytest.mark.parametrize(
    "words, named",
    [(["--samples", "0"], "samples"), (["--size", "-5"], "size"), (["--bake-samples", "70000"], "bake samples")],
)
def test_the_demo_refuses_bad_numbers_before_any_work(words, named, tmp_path, capsys):
    # it rendered with them (a 14-picture run at --size -5) or failed after Fig. 11
    from porous_weathering.cli import entry

    out = tmp_path / "out"
    assert entry.main(["demo", "--out", str(out), *words]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"error: {named} must be a whole number from ") and line.endswith(f"not {words[1]}")
    assert not out.exists()


def test_the_demo_refuses_an_out_a_file_stands_in_before_any_work(tmp_path, capsys):
    # a traceback after the sample scene was opened (os.makedirs)
    from porous_weathering.cli import entry

    out = tmp_path / "pictures"
    out.write_bytes(b"mine")
    assert entry.main(["demo", "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line == f"error: cannot create the output folder {out}: File exists"
    assert out.read_bytes() == b"mine"


@pytest.mark.parametrize("target", ["image", "attribute"])
def test_runoff_with_an_absorption_length_near_the_largest_float_is_the_runoff_without_absorption(
    fresh_scene, tmp_path, target
):
    obj = cube(fresh_scene)
    maps = {}
    for absorption in (1e308, math.inf):
        options = bake.BakeOptions(
            maps=("rain", "runoff"),
            target=target,
            resolution=16,
            out_dir=str(tmp_path / str(absorption)),
            rain_settings=rain.RainSettings(samples=2),
            runoff_settings=runoff.RunoffSettings(absorption_length=absorption),
        )
        [_, outcome] = bake.bake_maps([obj], options)
        maps[absorption] = (
            corner_values(obj, outcome.where) if target == "attribute" else imageio.read_image(outcome.where)[0]
        )
    assert np.isfinite(maps[1e308]).all() and maps[1e308].max() > 0.0  # was NaN almost everywhere
    np.testing.assert_allclose(maps[1e308], maps[math.inf], atol=1e-6)


@pytest.mark.parametrize("radius", [0.0, -0.1, NAN, math.inf])
def test_curvature_radius_must_be_positive_and_finite(fresh_scene, radius):
    obj = cube(fresh_scene)
    with pytest.raises(ValueError, match="radius"):
        edges.curvature(obj, radius)
    assert not obj.data.color_attributes


def test_curvature_radius_far_too_small_is_refused_not_exhausting_memory(fresh_scene):
    obj = cube(fresh_scene, size=100.0)
    with pytest.raises(ValueError, match="radius is too small"):
        edges.curvature(obj, 1e-6)


@pytest.mark.parametrize("saturation", [0.0, NAN])
def test_curvature_mask_refuses_a_saturation_that_is_not_positive(saturation):
    with pytest.raises(ValueError, match="saturation"):
        edges.curvature_mask(np.array([1.0, -1.0, 0.0]), 0.05, saturation=saturation)


# --- image files -----------------------------------------------------------------------------


@pytest.fixture
def bad_images(tmp_path):
    """{kind: path}: a missing file, a PNG cut off after its signature, a text file named .exr,
    an EXR cut in half, and a good 4 x 4 PNG in a folder whose name has spaces and non-ASCII."""
    folder = tmp_path / "Façade été 東"
    folder.mkdir()
    good = folder / "pierre de taille.png"
    imageio.write_image(good, np.full((4, 4, 3), 0.5, dtype=np.float32))
    whole = tmp_path / "whole.exr"
    imageio.write_image(whole, np.linspace(0, 1, 64 * 64, dtype=np.float32).reshape(64, 64))
    (tmp_path / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"not really a png" * 8)
    (tmp_path / "notes.exr").write_text("this is a text file, not an image")
    (tmp_path / "truncated.exr").write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    return {
        "missing": tmp_path / "missing.png",
        "corrupt": tmp_path / "corrupt.png",
        "wrong format": tmp_path / "notes.exr",
        "truncated": tmp_path / "truncated.exr",
        "good": good,
    }


@pytest.mark.parametrize(
    "kind, message", [("missing", "not found"), ("corrupt", "cannot read"), ("wrong format", "cannot read")]
)
def test_bad_base_colour_image_is_named_and_leaves_nothing(fresh_scene, bad_images, kind, message):
    before = data_counts()
    with pytest.raises(ValueError, match=message) as refusal:
        pw.make_porous_material("M", base_color=bad_images[kind])
    assert str(bad_images[kind]) in str(refusal.value)
    if kind != "missing":  # OpenImageIO's own reason is passed on, not just "failed"
        assert len(str(refusal.value)) > len(f"cannot read base colour image {bad_images[kind]}: ") + 10
    assert data_counts() == before


def test_base_colour_image_in_a_non_ascii_folder_with_spaces_loads(fresh_scene, bad_images):
    material = pw.make_porous_material("M", base_color=bad_images["good"])
    [texture] = [node for node in material.node_tree.nodes if node.type == "TEX_IMAGE"]
    assert tuple(texture.image.size) == (4, 4)
    assert texture.image.pixels[0] == pytest.approx(0.214, abs=0.01)  # 0.5 in sRGB, read as colour data


@pytest.mark.parametrize("kind", ["corrupt", "wrong format", "truncated"])
def test_unreadable_map_file_raises_oserror_with_openimageio_reason(bad_images, kind):
    with pytest.raises(OSError, match="cannot read image") as failure:
        imageio.read_image(bad_images[kind])
    assert str(bad_images[kind]) in str(failure.value)
    reason = str(failure.value).split(f"{bad_images[kind]}: ", 1)[1]
    assert reason.strip(), "OpenImageIO's reason is missing"


def test_bake_replaces_a_corrupt_old_map_with_a_whole_one(fresh_scene, tmp_path):
    plane = studio.add_plane(fresh_scene, size=2.0)
    out = tmp_path / "maps"
    out.mkdir()
    (out / "Plane.rain.exr").write_text("a map file overwritten by something else")
    [outcome] = bake.bake_maps(
        [plane],
        bake.BakeOptions(maps=("rain",), resolution=16, out_dir=str(out), rain_settings=rain.RainSettings(samples=2)),
    )
    assert outcome.status == "written"
    pixels, _ = imageio.read_image(outcome.where)
    assert pixels.mean() == pytest.approx(1.0, abs=0.05)


# --- output folders --------------------------------------------------------------------------


@pytest.mark.parametrize("folder", ["{file}/maps", "/proc/porous-maps"], ids=["below a file", "in /proc"])
def test_unwritable_output_folder_is_refused_before_anything_changes(fresh_scene, tmp_path, folder):
    (tmp_path / "file").write_text("a file, not a folder")
    out = folder.format(file=tmp_path / "file")
    plane = studio.add_plane(fresh_scene, size=2.0)
    plane.data.uv_layers.remove(plane.data.uv_layers[0])  # the bake would have to add a lightmap
    before = data_counts()
    with pytest.raises(OSError, match="output folder") as refusal:
        bake.bake_maps([plane], bake.BakeOptions(maps=("rain",), resolution=16, out_dir=out))
    assert out in str(refusal.value)
    assert data_counts() == before and not plane.data.uv_layers


def test_read_only_folder_is_refused_when_the_system_says_so(fresh_scene, tmp_path):
    """Root writes through chmod: then the bake goes ahead and writes (documented behaviour)."""
    out = tmp_path / "read only"
    out.mkdir()
    plane = studio.add_plane(fresh_scene, size=2.0)
    os.chmod(out, 0o555)
    try:
        options = bake.BakeOptions(
            maps=("rain",), resolution=16, out_dir=str(out), rain_settings=rain.RainSettings(samples=1)
        )
        if os.access(out, os.W_OK):  # root
            assert [o.status for o in bake.bake_maps([plane], options)] == ["written"]
        else:
            with pytest.raises(OSError, match="not writable"):
                bake.bake_maps([plane], options)
            assert os.listdir(out) == []
    finally:
        os.chmod(out, 0o755)


def test_object_and_folder_names_with_spaces_slashes_and_non_ascii(fresh_scene, tmp_path):
    plane = studio.add_plane(fresh_scene, size=2.0, name="Façade Nord/Süd 東")
    out = tmp_path / "cartes – été 地图"
    options = bake.BakeOptions(
        maps=("rain", "edges"), resolution=16, out_dir=str(out), rain_settings=rain.RainSettings(samples=1)
    )
    outcomes = bake.bake_maps([plane], options)
    # "/" is no file-name character: "_" and the hash of the exact name (bake.image_path)
    assert sorted(os.listdir(out)) == ["Façade Nord_Süd 東-e892c604.edges.exr", "Façade Nord_Süd 東-e892c604.rain.exr"]
    for outcome in outcomes:
        assert np.isfinite(imageio.read_image(outcome.where)[0]).all()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scène.blend"))
    bake.link_images([plane], options)
    image = bpy.data.images[plane["pw_rain_image"]]
    assert image.filepath.startswith("//cartes – été 地图/") and tuple(image.size) == (16, 16)


@pytest.mark.parametrize("kind", ["missing", "corrupt", "wrong format", "truncated"])
def test_bad_efflorescence_photograph_raises_oserror_with_openimageio_reason(bad_images, kind):
    from porous_weathering.maps import efflorescence_map

    with pytest.raises(OSError, match="cannot read photograph") as failure:
        efflorescence_map.photo_map(bad_images[kind])
    reason = str(failure.value).split(f"{bad_images[kind]}: ", 1)[1]
    assert reason.strip(), "OpenImageIO's reason is missing"


# --- the API's small promises -------------------------------------------------------------------


def weathered_material():
    return weathering.make_weathered_material("Weathered", environment=None)


#: (call, the argument its one-line ValueError names): a string, an array or a list where a
#: number or a name is expected (each was a TypeError, or taken as a number).
WRONG_TYPES = {
    "years '10'": (lambda: weathering.age_for_years("10", 2), "years"),
    "years array": (lambda: weathering.age_for_years(np.array([1, 2]), 2), "years"),
    "concentration list": (lambda: weathering.age_for_years(10, [2]), "elemental_carbon"),
    "environment list": (lambda: weathering.make_weathered_material("W", environment=["URBAN"]), "environment"),
    "time '0.5'": (lambda: weathering.make_weathered_material("W", time="0.5"), "time"),
    "ks '0.1'": (lambda: pw.make_porous_material("M", ks="0.1"), "ks"),
    "porosity array": (lambda: pw.make_porous_material("M", porosity=np.array([0.1, 0.2])), "porosity"),
    "start '0'": (lambda: weathering.animate_weathering(weathered_material(), 1, 9, start="0"), "start"),
    "input list": (
        lambda: weathering.animate_weathering(weathered_material(), 1, 9, input_name=["time"]),
        "weathering input",
    ),
    "frame '9'": (lambda: weathering.animate_years(weathered_material(), 1, "9", 10, 2), "frame_end"),
    "rain cone '10'": (lambda: rain.RainSettings(cone="10"), "cone"),
}


@pytest.mark.parametrize("case", WRONG_TYPES)
def test_a_string_array_or_list_for_a_number_or_name_is_a_one_line_value_error(fresh_scene, case):
    call, argument = WRONG_TYPES[case]
    with pytest.raises(ValueError, match=argument) as refusal:
        call()
    assert "\n" not in str(refusal.value)
    assert not any(material.animation_data or material.node_tree.animation_data for material in bpy.data.materials)


def test_animate_weathering_refuses_a_one_frame_range_as_animate_years_does(fresh_scene):
    material = weathered_material()
    with pytest.raises(ValueError, match="frame range 5-5: the last frame must come after the first"):
        weathering.animate_weathering(material, 5, 5)  # was two keyframes on one frame
    assert material.node_tree.animation_data is None


def test_years_whose_dose_overflows_keyframe_the_fully_weathered_state(fresh_scene):
    material = weathered_material()
    studio.add_plane(fresh_scene).data.materials.append(material)  # animated as the scene's frame changes
    weathering.animate_years(material, 1, 3, 1e308, 1e308)  # was a ValueError after two keyframes
    time = material.node_tree.nodes["Porous"].inputs["Time"]
    for frame, age in ((2, 1.0), (3, 1.0), (1, 0.0)):
        fresh_scene.frame_set(frame)
        assert time.default_value == age


def test_keyframe_aging_refuses_a_one_frame_range_as_keyframe_years_does(registered, fresh_scene):
    plane = studio.add_plane(fresh_scene)
    plane.data.materials.append(weathered_material())
    bpy.context.view_layer.objects.active = plane
    fresh_scene.frame_start = fresh_scene.frame_end = 7
    for years in (0.0, 10.0):
        with pytest.raises(RuntimeError, match="the last frame must come after the first"):
            bpy.ops.porous_weathering.keyframe_aging(years=years)
    assert plane.active_material.node_tree.animation_data is None


def test_the_bake_operators_blend_relative_folder(registered, fresh_scene, tmp_path):
    plane = studio.add_plane(fresh_scene)
    plane.select_set(True)
    with pytest.raises(RuntimeError, match="'//maps' is beside the .blend .*not saved yet: save it first"):
        bpy.ops.porous_weathering.bake_maps(maps={"edges"}, resolution=16, out_dir="//maps")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "wall.blend"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # was Blender's RuntimeWarning about the "//" prefix
        assert bpy.ops.porous_weathering.bake_maps(maps={"edges"}, resolution=16, out_dir="//maps") == {"FINISHED"}
    assert os.listdir(tmp_path / "maps") == ["Plane.edges.exr"]


@pytest.mark.parametrize("ages", [",", "0", "1e-400"])
def test_export_ages_that_leave_no_weathered_state_are_refused_before_any_work(tmp_path, ages):
    result = run_cli("export", "--ages", ages, "--out", tmp_path / "out", tmp_path / "missing.blend")
    assert result.returncode == 2  # was 0, the clean state alone written
    assert result.stderr.startswith("error: ages must hold an age in (0, 1]") and result.stderr.count("\n") == 1
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match=r"ages must hold an age in \(0, 1\]"):
        export.ExportOptions(ages=export.parse_ages(ages))
