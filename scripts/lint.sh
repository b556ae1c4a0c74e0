#!/usr/bin/env bash
# Lint and format check (ruff, configured in pyproject.toml), in the test environment.
#   scripts/lint.sh [--blender 5.2|4.5] [--fix]
source "$(dirname "$0")/env.sh" "$@"
[ "${1:-}" = "--blender" ] && shift 2
cd "$PW_ROOT"
if [ "${1:-}" = "--fix" ]; then
    "$PW_VENV/bin/ruff" check --fix . && exec "$PW_VENV/bin/ruff" format .
fi
"$PW_VENV/bin/ruff" check . && exec "$PW_VENV/bin/ruff" format --check .
