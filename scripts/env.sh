# Sourced by the other scripts: makes (once) and activates the virtual environment of one
# Blender line, with bpy from PyPI and the project's dependencies, plus the system libraries
# headless rendering needs.  Choose the line with --blender 5.2|4.5 or PW_BLENDER; by
# default 5.2 where Python 3.13 can be found, else 4.5 on Python 3.11.
set -euo pipefail
PW_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

pw_find_python() {  # pw_find_python 3.13 -> path of a working interpreter, or nothing
    local version="$1" candidate
    for candidate in "python$version" \
        "$(command -v pyenv >/dev/null 2>&1 && pyenv root)"/versions/"$version"*/bin/"python$version" \
        /usr/bin/"python$version" /usr/local/bin/"python$version"; do
        if [ -n "$candidate" ] && "$candidate" -c "import sys" >/dev/null 2>&1; then
            command -v "$candidate" 2>/dev/null || echo "$candidate"
            return 0
        fi
    done
    return 1
}

pw_system_deps() {  # the EGL / X libraries bpy and headless EEVEE load
    local packages="libegl1 libegl-mesa0 libgl1-mesa-dri libxi6 libxxf86vm1 libxfixes3 libxrender1 libsm6 libxkbcommon0"
    local missing=""
    for package in $packages; do
        dpkg -s "$package" >/dev/null 2>&1 || missing="$missing $package"
    done
    [ -z "$missing" ] && return 0
    if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
        echo "installing system libraries:$missing"
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
    else
        echo "warning: missing system libraries:$missing (sudo apt-get install$missing)" >&2
    fi
}

PW_BLENDER="${PW_BLENDER:-}"
if [ "${1:-}" = "--blender" ]; then PW_BLENDER="$2"; shift 2; fi
if [ -z "$PW_BLENDER" ]; then
    if pw_find_python 3.13 >/dev/null; then PW_BLENDER=5.2; else PW_BLENDER=4.5; fi
fi
case "$PW_BLENDER" in
    5.2) PW_PYTHON_VERSION=3.13 ;;
    4.5) PW_PYTHON_VERSION=3.11 ;;
    *) echo "unsupported Blender line '$PW_BLENDER' (use 5.2 or 4.5)" >&2; exit 2 ;;
esac
PW_PYTHON="$(pw_find_python "$PW_PYTHON_VERSION")" || {
    echo "Blender $PW_BLENDER needs Python $PW_PYTHON_VERSION, which was not found" >&2; exit 2; }

pw_system_deps
PW_VENV="$PW_ROOT/.venv-$PW_BLENDER"
PW_REQUIREMENTS="$PW_ROOT/requirements/blender-$PW_BLENDER.txt"
if [ ! -x "$PW_VENV/bin/python" ] || ! cmp -s "$PW_REQUIREMENTS" "$PW_VENV/.requirements"; then
    echo "setting up $PW_VENV (bpy $PW_BLENDER from PyPI, Python $PW_PYTHON_VERSION)"
    rm -rf "$PW_VENV"
    "$PW_PYTHON" -m venv "$PW_VENV"
    "$PW_VENV/bin/python" -m pip install -q --upgrade pip
    "$PW_VENV/bin/python" -m pip install -q -r "$PW_REQUIREMENTS"
    "$PW_VENV/bin/python" -c "import bpy, numpy, xatlas, OpenImageIO" \
        || { echo "the environment in $PW_VENV does not import" >&2; exit 1; }
    cp "$PW_REQUIREMENTS" "$PW_VENV/.requirements"
fi

# The Khronos glTF validator (npm package gltf-validator), which the export tests run on every
# exported file: installed beside the virtual environment (made again with it) when npm exists;
# without it those tests skip and say so.
PW_GLTF_VALIDATOR_VERSION=2.0.0-dev.3.10
pw_gltf_validator() {
    local folder="$PW_VENV/node" manifest="$PW_VENV/node/node_modules/gltf-validator/package.json"
    command -v npm >/dev/null 2>&1 || return 0
    if [ -f "$manifest" ] && grep -q "\"version\": \"$PW_GLTF_VALIDATOR_VERSION\"" "$manifest"; then
        return 0
    fi
    echo "installing gltf-validator $PW_GLTF_VALIDATOR_VERSION (npm) into $folder"
    npm install --prefix "$folder" --no-save --no-audit --no-fund --loglevel=error \
        "gltf-validator@$PW_GLTF_VALIDATOR_VERSION" >/dev/null \
        || echo "warning: gltf-validator could not be installed: the export tests skip the validator" >&2
}
pw_gltf_validator
PW_PY="$PW_VENV/bin/python"
export PW_BLENDER PW_PY PW_ROOT
