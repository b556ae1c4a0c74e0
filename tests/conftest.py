"""Every test starts from an empty factory scene; a failing test leaves its .blend in tests/failed/."""

import pathlib

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
