"""What a result was made with: date, engine and library versions, machine, and the command."""

from __future__ import annotations

import datetime as _dt
import os
import platform
import shlex
import sys
from pathlib import Path
from typing import Mapping

from harness.io.cpus import usable_cpus


def cpu_model(cpuinfo: str | None = None) -> str:
    """The CPU's model name: from the text of ``/proc/cpuinfo`` (or ``cpuinfo`` if given) the
    first ``model name`` (x86, most ARM), ``cpu model`` (MIPS), ``Hardware`` or ``Model`` (ARM
    boards) or ``cpu`` (POWER) line; else ``platform.processor()``; else ``"unknown cpu"``."""
    text = cpuinfo
    if text is None:
        try:
            text = Path("/proc/cpuinfo").read_text(errors="replace")
        except OSError:
            text = ""
    found: dict[str, str] = {}
    for line in text.splitlines():
        key, sep, value = line.partition(":")
        key, value = key.strip().lower(), " ".join(value.split())
        if sep and value and key in ("model name", "cpu model", "hardware", "model", "cpu") and key not in found:
            found[key] = value
    for key in ("model name", "cpu model", "hardware", "model", "cpu"):
        # "model" on x86 is a number; take it only where it is a name (ARM boards)
        if key in found and not found[key].isdigit():
            return found[key]
    return platform.processor() or "unknown cpu"


def cores() -> str:
    """The CPUs this process may use and the machine's logical CPUs, e.g. ``"2 usable of 8"``
    (usable: the affinity mask and cgroup CPU quota, ``harness.io.cpus.usable_cpus``)."""
    return f"{usable_cpus()} usable of {os.cpu_count() or '?'}"


_ARGV: list[str] | None = None  # the arguments given to harness.cli.main.main, if it recorded them


def set_argv(argv: list[str] | None) -> None:
    """Record the command's arguments (without the program name) for ``command_line``; the CLI
    calls this when ``main(argv)`` is given its arguments explicitly (tests, other programs), so
    that reports name those rather than the calling program's ``sys.argv``. ``None`` forgets."""
    global _ARGV
    _ARGV = None if argv is None else [str(a) for a in argv]


def command_line(argv: list[str] | None = None) -> str:
    """The command as typed, for a report's "Reproduce with" line: ``"harness "`` followed by
    the shell-quoted arguments, so that it can be pasted back into a shell. The arguments are
    ``argv`` if given, else those recorded with ``set_argv``, else ``sys.argv[1:]``."""
    args = list(argv) if argv is not None else (_ARGV if _ARGV is not None else sys.argv[1:])
    return " ".join(["harness", *(shlex.quote(str(a)) for a in args)])


def provenance(engines: Mapping[str, str] | None = None) -> dict[str, str]:
    """Versions of the engines (``engines``: ``{engine: version}``, as the registry gives them,
    ``harness.engines.provenance``) and numerical libraries, the machine (OS, architecture, CPU
    model), the CPUs this process may use, the UTC time now and the machine's load now (``load``:
    the 1-minute load average, at the end of the run that writes the report; "?" where the OS
    does not tell): timings are comparable only between runs at similar load."""
    import numba
    import numpy
    import scipy

    return {
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "harness": __import__("harness").__version__,
        **dict(engines or {}),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
        "machine": f"{platform.system()} {platform.machine()} ({cpu_model()})",
        "cpus": cores(),
        "load": _load(),
    }


def _load() -> str:
    try:
        return f"{os.getloadavg()[0]:.2f}"
    except (AttributeError, OSError):  # no load average on this OS
        return "?"


#: How the reports name the numerical libraries of ``provenance()`` (in this order, after the
#: engines: ``made_with``).
LIBRARY_NAMES = {"numpy": "NumPy", "scipy": "SciPy", "python": "Python"}


def made_with(prov: dict[str, str], engines: Mapping[str, str] | None = None) -> str:
    """``"MuJoCo 4.0.0, Pinocchio 4.1.0, Exudyn ..., NumPy ..., SciPy ..., Python ... on <machine>, load
    average 1.93 (1 min, at the end of the run)"``:
    the versions of ``provenance()`` every report's header states (missing keys are left out);
    ``engines``: ``{engine: how reports write it}``, in order (``harness.engines.made_with``)."""
    labels = {**dict(engines or {}), **LIBRARY_NAMES}
    parts = [f"{label} {prov[key]}" for key, label in labels.items() if key in prov]
    return (", ".join(parts) + (f" on {prov['machine']}" if "machine" in prov else "")
            + (f", load average {prov['load']} (1 min, at the end of the run)" if "load" in prov else ""))
