"""Helpers shared by the figure scripts of ``docs/figures``: where the pictures go,
and a one-line note of the machine and date to print beside each figure."""

from __future__ import annotations

import datetime
import os
import platform
from pathlib import Path

#: The pictures are committed here and shown by the documentation pages.
STATIC = Path(__file__).resolve().parent.parent / "_static"


def machine() -> str:
    """CPU model, core count and the day: what a reader needs to weigh a figure."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    day = datetime.datetime.now(datetime.UTC).date().isoformat()
    return f"{cpu}, {os.cpu_count()} cores, {day}"


def load() -> str:
    """The machine's load averages (1, 5, 15 minutes): how busy it was."""
    try:
        return "load average " + ", ".join(f"{v:.1f}" for v in os.getloadavg())
    except OSError:
        return "load average unknown"


def timed_process(cmd, cpu=None, *, env=None, stderr=None) -> float:
    """Wall seconds of the process ``cmd``, run to its end with its output discarded
    (``stderr`` as :func:`subprocess.run` takes it); its CPU seconds (user + system)
    appended to the list ``cpu`` when given."""
    import resource
    import subprocess
    import time

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=stderr, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if cpu is not None:
        cpu.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    return wall


def output_path(name: str, out: str | None) -> Path:
    path = Path(out) if out else STATIC / name
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def save_figure(fig, path: Path, note: str) -> None:
    """Stamp ``note`` (command, machine, date) under the figure, write it, close it."""
    import matplotlib.pyplot as plt

    fig.supxlabel(note, fontsize=7, color="0.4")
    fig.savefig(path, dpi=80)
    plt.close(fig)
