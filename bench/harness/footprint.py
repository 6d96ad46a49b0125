"""A body's memory before it is built: refuse a size that cannot fit, before assembly.

A 2D/3D scene declares its `Footprint` at a resolution (`BodyCase.footprint`: the unknowns
counted from the mesh's formula, its dimension and degree), without building anything.
`estimate_bytes` turns it into the peak memory of a run: the assembly and the run's
vectors, which grow like the unknowns, plus the sparse factor of a scheme that factors a
matrix (an implicit scheme, or an explicit one whose mass is not diagonal), which grows
like n^p with a fill-reducing ordering (a factor's bytes per unknown nearly constant in
2D, growing in 3D). The constants are fitted to measured peaks (docs/scale.md names the
command and the table); the estimate decides only clearly impossible sizes, so it is a
central fit, not a bound. A body that MKL PARDISO will factor (`PARDISO_MODELS`) has
its own constants: PARDISO's Cholesky (in 3D with the contact patch kept beside it).

`memory_limit` is what this process may use: the smallest of the memory the kernel says is
available (/proc/meminfo's MemAvailable), a cgroup's limit, and the address-space limit
(`ulimit -v`); None where none can be read (then nothing is refused).
"""

from __future__ import annotations

import resource
from pathlib import Path
from typing import Any, NamedTuple

from contact_bench.api.fem import LUMPED_KINDS, canonical_mass
from contact_bench.core import pardiso
from contact_bench.core.errors import BenchError


class Model(NamedTuple):
    """Peak bytes of a run with n unknowns: `linear` n + (`factor` n (n / 1e5)^`power`
    when the scheme factors a matrix)."""

    linear: float
    factor: float
    power: float


#: a 3D run's bytes per unknown without a factor (the assembly at its chunk budget, the
#: operators and the run's vectors): the geometric mean of the lumped explicit ball's
#: measured growth at 18,051, 137,475 and 976,875 unknowns (docs/scale.md, "Sizes that
#: cannot fit")
LINEAR_3D = 6.3e3
#: PARDISO's 3D factor and contact patch: bytes per unknown at 1e5 unknowns, and growth
PARDISO_FACTOR, PARDISO_POWER = 3.4e4, 0.37
#: PARDISO's 2D factor: bytes per unknown at 1e5 unknowns, and growth (P2 discs,
#: docs/sparse.md "PARDISO's 2D footprint")
PARDISO_FACTOR_2D, PARDISO_POWER_2D = 1.4e3, 0.06
#: per (dimension, degree): the fitted constants for SuperLU's factor (bytes per unknown;
#: see the module doc)
MODELS: dict[tuple[int, int], Model] = {
    (2, 1): Model(4.0e3, 3.2e3, 0.0),
    (2, 2): Model(4.0e3, 3.2e3, 0.0),
    (3, 1): Model(LINEAR_3D, 3.2e4, 0.56),
    (3, 2): Model(LINEAR_3D, 3.2e4, 0.56),
}


#: per (dimension, degree): the constants when MKL PARDISO factors the systems
#: (`contact_bench.core.pardiso`, from `PARDISO_MIN_DOFS` unknowns). 3D: its Cholesky
#: factor plus the contact patch the set-up keeps (`contact_bench.kernels.contact.
#: patch_rows`: 3 values per entry of L), fitted to PARDISO's factors of the ball; 2D: its
#: factor alone, fitted to the P2 disc's (the implicit step's operators are lazy there and
#: keep the patch's columns as rows come into contact); docs/sparse.md
PARDISO_MODELS: dict[tuple[int, int], Model] = {
    (2, 1): Model(4.0e3, PARDISO_FACTOR_2D, PARDISO_POWER_2D),
    (2, 2): Model(4.0e3, PARDISO_FACTOR_2D, PARDISO_POWER_2D),
    (3, 1): Model(LINEAR_3D, PARDISO_FACTOR, PARDISO_POWER),
    (3, 2): Model(LINEAR_3D, PARDISO_FACTOR, PARDISO_POWER),
}


def model(dim: int, degree: int, unknowns: float) -> Model:
    """The constants for a body: PARDISO's where it will factor (MKL loaded, at least
    `PARDISO_MIN_DOFS` unknowns), else SuperLU's (`MODELS`)."""
    key = (int(dim), min(int(degree), 2))
    if (key in PARDISO_MODELS and pardiso.MKL is not None
            and unknowns >= pardiso.PARDISO_MIN_DOFS):
        return PARDISO_MODELS[key]
    return MODELS[key]


def factors(scheme: Any) -> bool:
    """Whether the scheme's stepper factors a sparse matrix: an implicit scheme, or an
    explicit one whose mass is not diagonal (declared: its traits and mass kind)."""
    return bool(scheme.traits().implicit
                or canonical_mass(scheme.mass_kind()) not in LUMPED_KINDS)


def estimate_bytes(footprint: Any, factored: bool) -> float:
    """The estimated peak bytes of a run on a body of this `Footprint`."""
    n = float(footprint.unknowns)
    m = model(footprint.dim, footprint.degree, n)
    total = m.linear * n
    if factored:
        total += m.factor * n * (n / 1e5) ** m.power
    return total


def _meminfo_available(path: Path = Path("/proc/meminfo")) -> float | None:
    try:
        for line in path.read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024.0
    except OSError:
        return None
    return None


def _cgroup_limit() -> float | None:
    for path in (Path("/sys/fs/cgroup/memory.max"),
                 Path("/sys/fs/cgroup/memory/memory.limit_in_bytes")):
        try:
            text = path.read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 2**60:
            return float(text)
    return None


def memory_limit() -> tuple[float, str] | None:
    """(bytes, what limits them) for this process, or None where nothing can be read."""
    found: list[tuple[float, str]] = []
    avail = _meminfo_available()
    if avail is not None:
        found.append((avail, "the memory available"))
    cgroup = _cgroup_limit()
    if cgroup is not None:
        found.append((cgroup, "the cgroup's memory limit"))
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft not in (resource.RLIM_INFINITY, -1) and soft > 0:
        found.append((float(soft), "the address-space limit (ulimit -v)"))
    return min(found) if found else None


def _gb(x: float) -> str:
    return f"{x / 1e9:.3g} GB"


def check_fits(case: Any, scheme: Any, nx: int) -> None:
    """Refuse, in one line and before anything is built, a body whose estimated run does
    not fit in `memory_limit`; nothing for a scene without a footprint."""
    footprint = getattr(case, "footprint", None)
    fp = footprint(int(nx)) if callable(footprint) else None
    if fp is None:
        return
    limit = memory_limit()
    if limit is None:
        return
    factored = factors(scheme)
    need = estimate_bytes(fp, factored)
    if need <= limit[0]:
        return
    top = int(nx)
    lo, hi = 1, top
    while lo < hi:  # the largest nx that fits (the estimate grows with nx)
        mid = (lo + hi + 1) // 2
        if estimate_bytes(footprint(mid), factored) <= limit[0]:
            lo = mid
        else:
            hi = mid - 1
    fits = estimate_bytes(footprint(lo), factored) <= limit[0]
    allowed = f"nx <= {lo}" if fits else "none on this machine"
    raise BenchError(
        f"nx = {nx}: {case.spec} has {fp.unknowns:.3g} unknowns; {scheme.spec} would need "
        f"about {_gb(need)} ({'with' if factored else 'without'} a sparse factor), over "
        f"{limit[1]} ({_gb(limit[0])}); allowed: {allowed}")
