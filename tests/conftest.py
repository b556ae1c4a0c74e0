"""Every test starts from an empty factory scene; a failing test leaves its .blend in tests/failed/.

Shared fixtures: ``registered`` (the extension registered for the test), ``bust`` (adds the
scan-like bust to the scene: ``helpers.add_bust``) and ``toys`` (the toy mode and toy map of
tests/helpers.py registered for the test)."""

import pathlib

import bpy

import pytest

import helpers
import porous_weathering
from porous_weathering.blender import compat

FAILED = pathlib.Path(__file__).resolve().parent / "failed"


@pytest.fixture(autouse=True)
def fresh_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield bpy.context.scene


@pytest.fixture
def registered():
    """The extension registered (its operators, panel and properties) for the test."""
    porous_weathering.register()
    yield
    porous_weathering.unregister()


@pytest.fixture
def bust(fresh_scene):
    """``bust(triangles=20_000, name="Bust", *, scale=1.0, rotation=(0, 0, 0), scan_noise=True)``
    adds the scan-like bust (sample_blends/scan_generator.py, in millimetres times ``scale``) to
    the scene and returns it (``helpers.add_bust``)."""
    return helpers.add_bust


@pytest.fixture
def toys():
    with helpers.registered_toys():
        yield


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
    ever in a static destructor at interpreter exit (seen at the end of the full suite);
    Blender's folder for the session removed all the same."""
    status = getattr(config, "_pw_exit_status", None)
    if status is not None:  # a session ran (not --help or --version)
        compat.end_process(status)


def pytest_sessionfinish(session, exitstatus):
    session.config._pw_exit_status = int(exitstatus)
