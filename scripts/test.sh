#!/usr/bin/env bash
# Runs the test suite on one Blender line (sets everything up on first use).
#   scripts/test.sh [--blender 5.2|4.5] [pytest arguments...]
# The Dask cluster tests run in a pytest process of their own: a cluster's threads and
# forked helpers left in a bpy process have hung later Cycles renders there (bpy 4.5).
source "$(dirname "$0")/env.sh" "$@"
[ "${1:-}" = "--blender" ] && shift 2
cd "$PW_ROOT"
echo "== tests on Blender $PW_BLENDER ($("$PW_PY" -c 'import bpy; print(bpy.app.version_string)'))"
if [ $# -gt 0 ]; then
    exec "$PW_PY" -m pytest "$@"
fi
status=0
"$PW_PY" -m pytest --ignore=tests/test_distributed.py || status=1
"$PW_PY" -m pytest tests/test_distributed.py || status=1
exit $status
