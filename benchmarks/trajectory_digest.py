"""Digest of every scheme's trajectory on the default run: one SHA-256 per (scene, scheme).

Two checkouts that print the same digests step every scheme bit for bit alike (t, U, V,
contact u, stress and energy of every sample). Used to show that a refactoring changed no
number: run it before and after, then `diff` the outputs.

    python benchmarks/trajectory_digest.py > before.txt

`--split` prints two digests per run instead: the motion (t, U, V, contact u, stress) and
the sampled energy apart, for a change that may move the energy's last digits but must
leave the motion bit for bit alone. `--extra` adds the scheme variants that take the other
stepping kernels (explicit Newmark, the generic and SPIKE kernels of the lumped-mass
schemes, Nitsche's and the penalty's explicit forms). `--scenes` adds the 2D/3D scenes
on small grids (`SCENES`), each run by every scheme (and the extra variants) that can.
"""

from __future__ import annotations

import argparse
import hashlib
from collections.abc import Iterator

import numpy as np

from contact_bench.core.errors import BenchError

try:
    from contact_bench.api.registry import cases, schemes
    from contact_bench.harness import run_one
except ImportError:  # the layout before the one-package move
    from contact_bench.api.registry import cases, schemes  # type: ignore[no-redef]
    from contact_bench.harness.runner import run_one  # type: ignore[no-redef]

#: variants whose kernels the defaults do not reach
EXTRA_SCHEMES = (
    "redistributed[beta=0]", "redistributed[variant=getfem]", "standard[gamma=0.6]",
    "restitution[mass=consistent]", "restitution[beta=0.25]", "restitution[e=0.5]",
    "taylor_flanagan[mass=consistent]", "ode_verlet[variant=conservative]",
    "penalty[beta=0]", "penalty[mass=seed]", "nitsche[theta=-1]", "nitsche[beta=0]",
    "hht[mass=consistent]", "moreau_jean[e=0.5]",
)


#: the 2D/3D scenes of `--scenes`: (spec, nx, T), small enough to run every scheme in minutes
SCENES = (
    ("disc_drop[degree=1]", 3, 12.0),
    ("disc_drop", 2, 8.0),
    ("hertz_sphere", 4, None),
    ("sphere_drop[lift=0.1]", 8, 2.0),
    ("embedded_bar[of=clamped_bar,dim=2]", 20, 3.0),
    ("embedded_bar[of=dropped_bar,dim=3]", 10, None),
)


def digest(arrays: list[np.ndarray]) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def numeric_extra(extra: dict) -> list[np.ndarray]:
    """The kernel's numeric diagnostics (contact statistics, the impulse at each sample),
    in key order, so that a change in how a kernel keeps them shows in the digest."""
    out = []
    for key in sorted(extra):
        value = extra[key]
        if isinstance(value, float | int | np.floating | np.integer) and not isinstance(
                value, bool):
            out.append(np.array([float(value)]))
        elif isinstance(value, np.ndarray) and value.dtype.kind in "fiu":
            out.append(value)
    return out


def plan(extra: bool, scenes: bool, only_scenes: bool, scheme: list[str] | None = None,
         scene: list[str] | None = None) -> tuple[list[str], list[tuple]]:
    """The schemes (`scheme`, else every registered one and, with `extra`, the variants)
    and the runs (case, nx, T): the default run's scenes unless `only_scenes`, then the
    `SCENES` with `scenes` or `only_scenes` (only those named in `scene`, if given)."""
    specs = scheme or (schemes().names() + (list(EXTRA_SCHEMES) if extra else []))
    runs: list[tuple[str, int | None, float | None]] = []
    if not only_scenes:
        runs += [(name, None, None) for name, cls in cases().plugins.items()
                 if cls.in_default_run]
    if scenes or only_scenes:
        runs += [s for s in SCENES if not scene or s[0] in scene]
    return specs, runs


def trajectories(specs: list[str], runs: list[tuple]) -> Iterator[tuple]:
    """(case, nx, scheme, trajectory) of every run that has one; a refused run or one
    without a trajectory is a printed line instead."""
    for case_name, nx, T in runs:
        for scheme_name in specs:
            try:
                run = run_one(case_name, scheme_name, nx=nx, T=T)
            except BenchError as exc:  # a mesh the scene refuses for the scheme's mass
                print(f"{case_name:<14} {scheme_name:<16} refused ({exc})")
                continue
            tr = run.trajectory
            if tr is None:
                print(f"{case_name:<14} {scheme_name:<16} no trajectory ({run.row['status']})")
                continue
            yield case_name, nx, scheme_name, tr


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", action="store_true",
                    help="digest the motion (t, U, V, contact u, stress) and the energy apart")
    ap.add_argument("--extra", action="store_true",
                    help="also the scheme variants that take the other stepping kernels")
    ap.add_argument("--scenes", action="store_true",
                    help="also the 2D/3D scenes on small grids (SCENES)")
    ap.add_argument("--only-scenes", action="store_true",
                    help="the 2D/3D scenes of --scenes alone")
    args = ap.parse_args(argv)
    specs, runs = plan(args.extra, args.scenes, args.only_scenes)
    for case_name, _, scheme_name, tr in trajectories(specs, runs):
        motion = [tr.t, tr.U, tr.V, tr.contact_u, tr.stress, *numeric_extra(tr.extra)]
        if args.split:
            print(f"{case_name:<14} {scheme_name:<16} motion {digest(motion)} "
                  f"energy {digest([tr.energy])}")
        else:
            print(f"{case_name:<14} {scheme_name:<16} {digest([*motion, tr.energy])}")


if __name__ == "__main__":
    main()
