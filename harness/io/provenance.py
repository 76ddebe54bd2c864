"""What a result was made with: date, engine and library versions, machine."""

from __future__ import annotations

import datetime as _dt
import platform


def provenance() -> dict[str, str]:
    """Versions of the engines and numerical libraries, the machine, and the UTC time now."""
    import mujoco
    import numba
    import numpy
    import pinocchio
    import scipy

    return {
        "date_utc": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC"),
        "harness": __import__("harness").__version__,
        "mujoco": mujoco.__version__,
        "pinocchio": pinocchio.__version__,
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
        "machine": f"{platform.system()} {platform.machine()} ({platform.processor() or 'unknown cpu'})",
    }
