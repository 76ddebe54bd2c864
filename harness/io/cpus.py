"""The CPUs this process may use: its affinity mask and its cgroup CPU quota (the local worker
pool's limit, ``harness.validate.local_workers``, and the provenance line of every report,
``harness.io.provenance.cores``)."""

from __future__ import annotations

import math
import os
from pathlib import Path


def _cgroup_cpu_limit() -> float | None:
    """CPUs allowed by the cgroup CPU quota of this process (``quota / period``), the smallest
    along its cgroup path; None without a quota or off Linux. Reads cgroup v2 ``cpu.max`` and
    cgroup v1 ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us``."""
    limits: list[float] = []
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        hier, controllers, rel = parts
        if hier == "0" and controllers == "":  # cgroup v2
            roots, name = [Path("/sys/fs/cgroup")], "cpu.max"
        elif "cpu" in controllers.split(","):  # cgroup v1
            roots, name = [Path("/sys/fs/cgroup") / c for c in ("cpu", "cpu,cpuacct", controllers)], None
        else:
            continue
        for root in roots:
            folder = root / rel.lstrip("/")
            while True:
                try:
                    if name:
                        quota, period = (folder / name).read_text().split()[:2]
                        if quota != "max":
                            limits.append(int(quota) / int(period))
                    else:
                        quota = int((folder / "cpu.cfs_quota_us").read_text())
                        period = int((folder / "cpu.cfs_period_us").read_text())
                        if quota > 0 and period > 0:
                            limits.append(quota / period)
                except (OSError, ValueError):
                    pass
                if folder == root or folder.parent == folder:
                    break
                folder = folder.parent
    return min(limits) if limits else None


def usable_cpus() -> int:
    """How many CPUs this process may use: the size of its affinity mask
    (``os.sched_getaffinity(0)``, else ``os.cpu_count()``), further limited by a cgroup CPU
    quota rounded up (a quota of 1.5 CPUs gives 2). At least 1."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 1
    limit = _cgroup_cpu_limit()
    if limit:
        n = min(n, max(1, math.ceil(limit - 1e-9)))
    return max(1, n)
