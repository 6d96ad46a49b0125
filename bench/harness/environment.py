"""Where a run was made: package versions, CPU model, git commit; and a provenance line.

Every sweep row carries these as `env_*` columns (computed once per process), and every
file `contact-bench report` writes records `provenance(argv)`: the command, the
versions and the date.
"""

from __future__ import annotations

import ctypes
import datetime as _dt
import os
import platform
import shlex
import subprocess
from collections.abc import Sequence
from functools import cache
from importlib import metadata
from pathlib import Path

from contact_bench.core.sources import source_hash

#: distribution name -> column suffix
PACKAGES = {
    "contact-bench": "contact_bench", "numpy": "numpy", "scipy": "scipy",
    "scikit-fem": "skfem", "numba": "numba", "pandas": "pandas", "matplotlib": "matplotlib",
}
ROOT = Path(__file__).resolve().parent.parent


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def cpu_model() -> str:
    """The CPU's model name (from /proc/cpuinfo on Linux), or platform's best guess."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def git_commit() -> str:
    """`git rev-parse HEAD` of the checkout holding this package ('unknown' outside git)."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                             text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return out.stdout.strip() if out.returncode == 0 and out.stdout.strip() else "unknown"


def git_dirty() -> str:
    """'yes' when the checkout holding this package has uncommitted changes to tracked
    files (`git status --porcelain --untracked-files=no`), 'no' when clean, 'unknown'
    outside git. Untracked output folders do not count."""
    try:
        out = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                             cwd=ROOT, capture_output=True, text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    if out.returncode != 0:
        return "unknown"
    return "yes" if out.stdout.strip() else "no"


@cache
def environment() -> dict[str, str | int]:
    """The `env_*` columns of a sweep row (cached for the life of the process)."""
    env: dict[str, str | int] = {"env_python": platform.python_version()}
    env.update({f"env_{col}": _version(dist) for dist, col in PACKAGES.items()})
    env.update(env_cpu=cpu_model(), env_ncpu=os.cpu_count() or 1,
               env_platform=platform.platform(terse=True), env_git=git_commit(),
               env_git_dirty=git_dirty())
    return env


def provenance(argv: Sequence[str] | None = None) -> str:
    """One line: the command, the date (UTC), the versions, the git commit (with
    ' (dirty)' when tracked files have uncommitted changes) and the source hash of the
    code (`contact_bench.core.sources`)."""
    env = environment()
    cmd = "contact-bench " + " ".join(shlex.quote(a) for a in (argv or []))
    versions = ", ".join(f"{dist} {env[f'env_{col}']}" for dist, col in PACKAGES.items())
    return (f"made by `{cmd.strip()}` on {_dt.datetime.now(_dt.UTC):%Y-%m-%d %H:%M UTC}; "
            f"python {env['env_python']}, {versions}; CPU {env['env_cpu']} "
            f"({env['env_ncpu']} cores); git {env['env_git']}"
            + (" (dirty)" if env["env_git_dirty"] == "yes" else "")
            + f"; source {source_hash()}")


#: arrays above this size are mapped and unmapped one by one (glibc's M_MMAP_THRESHOLD)
MMAP_THRESHOLD = 1 << 22
TRIM_THRESHOLD = 64 << 20


def return_freed_memory() -> bool:
    """Make glibc give large freed arrays back to the system at once, and keep smaller
    ones for the next allocation.

    glibc raises its mmap threshold each time a mapped block is freed (up to 32 MB), so
    after assembly frees its n-sized temporaries the next n-sized arrays come from the
    heap, and the heap keeps what the temporaries freed: about 80 MB more resident
    memory at n = 1e6. A fixed threshold keeps every array above MMAP_THRESHOLD (4 MB)
    mapped on its own. Below it, arrays come from the heap, and a trim threshold of
    64 MB keeps what a run frees for the next run: the sample buffers of a default run
    (1.5-2.6 MB a field) are not page-faulted again inside every run's wall_s. The
    price: meshes whose n-sized arrays are under 4 MB keep some freed temporaries on the
    heap; at n = 1e6 they are mapped. Both effects are measured in docs/performance.md
    and `results/memory.md`. Returns False where there is
    no glibc (nothing changes then).
    """
    try:
        libc = ctypes.CDLL("libc.so.6")
        ok = bool(libc.mallopt(-3, MMAP_THRESHOLD))  # -3: M_MMAP_THRESHOLD
        return ok and bool(libc.mallopt(-1, TRIM_THRESHOLD))  # -1: M_TRIM_THRESHOLD
    except (OSError, AttributeError):
        return False
