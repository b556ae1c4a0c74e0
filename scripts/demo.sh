#!/usr/bin/env bash
# The main job on the bundled sample scene: pictures are written to out/.
#   scripts/demo.sh [--blender 5.2|4.5] [options of python -m porous_weathering demo]
source "$(dirname "$0")/env.sh" "$@"
[ "${1:-}" = "--blender" ] && shift 2
cd "$PW_ROOT"
exec "$PW_PY" -m porous_weathering demo --out out "$@"
