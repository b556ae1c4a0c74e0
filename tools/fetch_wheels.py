"""Download the wheels blender_manifest.toml declares into wheels/, for an offline-installable zip.

    python tools/fetch_wheels.py        (any Python 3.11+ with pip; no bpy needed)

The manifest's file names are the single source of truth: each names its package, version,
Python and platform tags, and pip downloads exactly that file from PyPI. To move to another
version, edit the names in the manifest and run this again. See docs/packaging.md.
"""

import pathlib
import subprocess
import sys
import tomllib

ROOT = pathlib.Path(__file__).resolve().parent.parent


def declared_wheels(manifest=ROOT / "blender_manifest.toml"):
    """The manifest's wheel paths, relative to the repo root."""
    return [path.removeprefix("./") for path in tomllib.loads(manifest.read_text())["wheels"]]


def pip_download_args(filename):
    """pip download arguments that fetch exactly the wheel ``filename`` and nothing else."""
    name, version, python_tag, abi_tag, platform_tags = filename.removesuffix(".whl").split("-")
    python_version = f"{python_tag[2]}.{python_tag[3:]}"  # cp311 -> 3.11
    args = [
        "--no-deps",
        "--only-binary=:all:",
        "--implementation",
        "cp",
        "--python-version",
        python_version,
        "--abi",
        abi_tag,
    ]
    for platform_tag in platform_tags.split("."):
        args += ["--platform", platform_tag]
    return args + [f"{name}=={version}"]


def fetch(wheels=None):
    """Download the missing wheels; returns the paths still missing afterwards."""
    missing = [path for path in (wheels or declared_wheels()) if not (ROOT / path).is_file()]
    for path in missing:
        target = (ROOT / path).parent
        target.mkdir(parents=True, exist_ok=True)
        print(f"downloading {path}")
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pip",
                "download",
                "-q",
                "-d",
                str(target),
                *pip_download_args(pathlib.PurePosixPath(path).name),
            ],
            check=True,
        )
    return [path for path in missing if not (ROOT / path).is_file()]


if __name__ == "__main__":
    still_missing = fetch()
    for path in still_missing:
        print(f"pip did not produce {path}: check the name in blender_manifest.toml", file=sys.stderr)
    sys.exit(1 if still_missing else 0)
