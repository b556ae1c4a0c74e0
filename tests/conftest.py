"""Every test starts from an empty factory scene; a failing test leaves its .blend in tests/failed/."""

import os
import pathlib
import sys

import bpy

import pytest

FAILED = pathlib.Path(__file__).resolve().parent / "failed"


@pytest.fixture(autouse=True)
def fresh_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield bpy.context.scene


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.when == "call" and report.failed:
        FAILED.mkdir(parents=True, exist_ok=True)
        path = FAILED / (item.nodeid.replace("/", "_").replace("::", "-")[:150] + ".blend")
        try:
            bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
            report.sections.append(("failed scene", f"saved to {path}"))
        except RuntimeError as error:
            report.sections.append(("failed scene", f"could not be saved: {error}"))
    return report


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Leave without bpy's exit-time cleanup, once pytest has reported: bpy 4.5 can hang for
    ever in a static destructor at interpreter exit (seen at the end of the full suite)."""
    status = getattr(config, "_pw_exit_status", None)
    if status is not None:  # a session ran (not --help or --version)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)


def pytest_sessionfinish(session, exitstatus):
    session.config._pw_exit_status = int(exitstatus)
