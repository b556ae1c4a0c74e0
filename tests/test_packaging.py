"""The extension zip: built and validated with Blender's own tool, it holds only what the
extension needs, and installs, enables and disables in a clean Blender user config.

Without a ``blender`` binary, the zip is built by the bpy wheel's bl_pkg/cli/blender_ext.py,
and installed by ``bpy.ops.extensions.package_install_files`` in a subprocess whose user
config points at a temporary folder (the variables must be set before ``import bpy``).
"""

import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import textwrap
import tomllib
import zipfile

import bpy

import pytest

from porous_weathering.maps import registry

ROOT = pathlib.Path(__file__).resolve().parent.parent
MANIFEST = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
ZIP_NAME = f"{MANIFEST['id']}-{MANIFEST['version']}.zip"
#: Every top-level entry the zip may hold.
ALLOWED_TOP = {
    "blender_manifest.toml",
    "__init__.py",
    "LICENSE",
    "porous_weathering",
    "node_groups",
    "sample_blends",
    "wheels",
}
ASSET_FILES = {"node_groups/porous_weathering_assets.blend", "node_groups/blender_assets.cats.txt"}


def blender_ext():
    """The wheel's extension command-line tool (an internal file of Blender's: it may move)."""
    for folder, _, files in os.walk(bpy.utils.resource_path("LOCAL")):
        if "blender_ext.py" in files and folder.endswith(os.path.join("bl_pkg", "cli")):
            return os.path.join(folder, "blender_ext.py")
    pytest.fail("bl_pkg/cli/blender_ext.py not found in the bpy wheel")


def run_ext(*args):
    result = subprocess.run(
        [sys.executable, blender_ext(), *args, "--output-type", "JSON"], capture_output=True, text=True, timeout=300
    )
    messages = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    errors = [text for kind, text in messages if kind in ("ERROR", "FATAL_ERROR")]
    assert result.returncode == 0 and not errors, f"blender_ext {args[0]} failed: {errors or result.stderr}"
    return messages


def declared_wheels():
    return [path.removeprefix("./") for path in MANIFEST.get("wheels", [])]


@pytest.fixture(scope="module")
def plain_zip(tmp_path_factory):
    """The zip without wheels, built from a copy of the work tree whose manifest declares none."""
    source = tmp_path_factory.mktemp("source") / "porous_weathering"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".git", ".venv-*", "wheels", "out", "failed"))
    manifest = source / "blender_manifest.toml"
    manifest.write_text(re.sub(r"^wheels = \[.*?\]\n", "", manifest.read_text(), flags=re.S | re.M))
    output = tmp_path_factory.mktemp("dist") / ZIP_NAME
    run_ext("build", "--source-dir", str(source), "--output-filepath", str(output))
    return output


def test_the_permission_text_names_no_map():
    """The manifest's reason to use files covers every map without naming one: a map's module is
    all a new map needs (docs/architecture.md, "Add a map")."""
    text = MANIFEST["permissions"]["files"].lower()
    named = [kind.name for kind in (*registry.all_kinds(), *registry.made_kinds()) if kind.name in text]
    assert not named and "maps" in text, (text, named)


def test_zip_is_valid_and_holds_only_the_extension(plain_zip):
    run_ext("validate", str(plain_zip))
    names = set(zipfile.ZipFile(plain_zip).namelist())
    assert {name.split("/")[0] for name in names} <= ALLOWED_TOP - {"wheels"}
    assert not [name for name in names if "__pycache__" in name or name.endswith(".pyc")]
    assert {name for name in names if name.startswith("node_groups/")} == ASSET_FILES
    package = {
        str(path.relative_to(ROOT))
        for path in (ROOT / "porous_weathering").rglob("*.py")
        if "__pycache__" not in path.parts
    }
    assert package and package <= names, f"missing from the zip: {sorted(package - names)}"


INSTALL = textwrap.dedent("""
    import importlib, json, os, sys
    import bpy

    def operator_registered():
        try:
            return bool(bpy.ops.porous_weathering.add_porous_material.get_rna_type())
        except KeyError:
            return False

    zip_path, repo = sys.argv[1], "user_default"
    module = f"bl_ext.{repo}.porous_weathering"
    result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo=repo, enable_on_install=True)
    assert result == {"FINISHED"}, result
    enabled = {addon.module for addon in bpy.context.preferences.addons}
    assert module in enabled, sorted(enabled)
    assert operator_registered(), "the operator did not register"
    package = sys.modules[module]
    libraries = bpy.context.preferences.filepaths.asset_libraries
    library = libraries["Porous Weathering"]
    installed = os.path.join(os.path.dirname(package.__file__), "node_groups")
    assert os.path.samefile(library.path, installed), (library.path, installed)
    assert os.path.isfile(os.path.join(installed, "porous_weathering_assets.blend"))
    api = importlib.import_module(module + ".porous_weathering")  # the documented installed import
    assert api.make_preset_material("BRICK")["pw_preset"] == "BRICK"
    # the demo runs from the installed extension: its samples ship beside the package
    demo = importlib.import_module(module + ".porous_weathering.samples.demo")
    samples = os.path.join(os.path.dirname(package.__file__), "sample_blends")
    assert os.path.samefile(demo.SAMPLES_DIR, samples), (demo.SAMPLES_DIR, samples)
    assert os.path.isfile(os.path.join(samples, demo.FACADE + ".blend"))
    # Blender unpacks the wheels of enabled extensions into a site-packages of the user config.
    sites = [path for path in sys.path if path.startswith(os.environ["BLENDER_USER_EXTENSIONS"])]
    unpacked = sorted(name for site in sites if os.path.isdir(site) for name in os.listdir(site))
    bpy.ops.preferences.addon_disable(module=module)
    assert not operator_registered(), "the operator did not unregister"
    assert "Porous Weathering" not in libraries, "the asset library was not removed"
    print(json.dumps({"folder": os.path.dirname(package.__file__), "unpacked": unpacked}))
""")


def install(zip_path, user_dir):
    """Install, enable and disable the zip in a clean user config.

    Returns the install folder and what was unpacked from wheels while the extension was enabled.
    """
    user_dir.mkdir(parents=True, exist_ok=True)
    env = {
        **os.environ,
        "BLENDER_USER_CONFIG": str(user_dir / "config"),
        "BLENDER_USER_SCRIPTS": str(user_dir / "scripts"),
        "BLENDER_USER_EXTENSIONS": str(user_dir / "extensions"),
        "BLENDER_USER_DATAFILES": str(user_dir / "datafiles"),
    }
    result = subprocess.run(
        [sys.executable, "-c", INSTALL, str(zip_path)],
        env=env,
        cwd=user_dir,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    folder = pathlib.Path(report["folder"])
    assert folder.is_relative_to(user_dir / "extensions"), folder
    return folder, report["unpacked"]


def test_zip_installs_enables_and_disables_in_a_clean_user_config(plain_zip, tmp_path):
    folder, unpacked = install(plain_zip, tmp_path)
    assert (folder / "porous_weathering" / "shading" / "material.py").is_file()
    assert unpacked == []


def test_platform_zips_with_wheels(tmp_path):
    """With the wheels downloaded (tools/fetch_wheels.py), each platform's zip carries its own."""
    wheels = declared_wheels()
    missing = [path for path in wheels if not (ROOT / path).is_file()]
    if not wheels or missing:
        pytest.skip(f"{len(missing)} wheels not downloaded: run python tools/fetch_wheels.py")
    run_ext("build", "--source-dir", str(ROOT), "--output-dir", str(tmp_path), "--split-platforms")
    for platform in MANIFEST["platforms"]:
        built = tmp_path / ZIP_NAME.replace(".zip", f"-{platform.replace('-', '_')}.zip")
        run_ext("validate", str(built))
        zipped = {name for name in zipfile.ZipFile(built).namelist() if name.startswith("wheels/")}
        assert zipped and len(zipped) < len(wheels), (platform, zipped)
    linux = tmp_path / ZIP_NAME.replace(".zip", "-linux_x64.zip")
    _, unpacked = install(linux, tmp_path / "user")
    assert "OpenImageIO" in unpacked and "embreex" in unpacked, unpacked
    assert any(name.startswith("xatlas") for name in unpacked), unpacked


def test_pip_installs_the_package_alone(tmp_path):
    """``pip install .`` (a Dask worker's image, docs/batch.md) builds a wheel of the package and
    nothing else of the repository; the build backend comes from PyPI (pyproject.toml)."""
    # the repository as it is, every top-level folder beside the package, in a copy (the build
    # leaves its egg-info and build/ beside the sources); hidden folders (.venv-*, .git) left out
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, ignore=shutil.ignore_patterns(".*", "__pycache__", "wheels", "build", "dist", "out"))
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "-q", "-w", str(tmp_path / "dist")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    if built.returncode and re.search(r"(No matching distribution|Could not find a version).*setuptools", built.stderr):
        pytest.skip("the build backend (setuptools) cannot be fetched from PyPI here")
    assert built.returncode == 0, built.stderr[-3000:]
    (wheel,) = (tmp_path / "dist").glob("porous_weathering-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert {name.split("/")[0] for name in names} == {
        "porous_weathering",
        f"porous_weathering-{MANIFEST['version']}.dist-info",
    }
    packages = {str(path.parent.relative_to(ROOT)) for path in (ROOT / "porous_weathering").rglob("__init__.py")}
    assert packages <= {os.path.dirname(name) for name in names}, "every subpackage is in the wheel"


def test_the_demo_without_its_sample_scenes_says_so_in_one_line(monkeypatch, tmp_path, capsys):
    """A package installed alone has no sample scenes: the demo says so before any work."""
    from porous_weathering.cli import entry
    from porous_weathering.samples import demo

    monkeypatch.setattr(demo, "SAMPLES_DIR", str(tmp_path / "sample_blends"))
    out = tmp_path / "out"
    assert entry.main(["demo", "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("error: no sample scene ") and "limestone_facade.blend" in line
    assert not out.exists()
