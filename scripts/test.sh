#!/usr/bin/env bash
# Runs the test suite on one Blender line (sets everything up on first use).
#   scripts/test.sh [--blender 5.2|4.5] [pytest arguments...]
source "$(dirname "$0")/env.sh" "$@"
[ "${1:-}" = "--blender" ] && shift 2
cd "$PW_ROOT"
echo "== tests on Blender $PW_BLENDER ($("$PW_PY" -c 'import bpy; print(bpy.app.version_string)'))"
exec "$PW_PY" -m pytest "$@"
