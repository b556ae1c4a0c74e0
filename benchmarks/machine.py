"""The line that says where and when a benchmark ran, for the docs it writes."""

import datetime
import os
import pathlib
import platform


def describe(blender_version):
    """Blender version, CPU model, core count, load average now, and the UTC date and time."""
    cpuinfo = pathlib.Path("/proc/cpuinfo")
    lines = cpuinfo.read_text().splitlines() if cpuinfo.exists() else []
    cpu = next(
        (line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")),
        platform.processor() or "unknown CPU",
    )
    load = f", load average {os.getloadavg()[0]:.1f} (the machine is shared)" if hasattr(os, "getloadavg") else ""
    return (
        f"Blender {blender_version}, {cpu}, {os.cpu_count()} cores{load}, "
        f"{datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC"
    )
