"""The digest of `trajectory_digest.py`, with the trajectories kept, for a change that may
move the last bits (a different direct solver): how far apart two checkouts' runs are.

    python benchmarks/trajectory_diff.py --extra --scenes --save before.npz   # checkout A
    python benchmarks/trajectory_diff.py --extra --scenes --save after.npz    # checkout B
    python benchmarks/trajectory_diff.py --compare before.npz after.npz

The first two print the same lines as `trajectory_digest.py` (same options) and save every
run's t, U, V, contact u, stress, energy; `--compare` prints, for every run whose arrays
differ, the largest difference of each array relative to that array's largest magnitude.
"""

from __future__ import annotations

import argparse

import numpy as np
from trajectory_digest import digest, numeric_extra, plan, trajectories

FIELDS = ("t", "U", "V", "contact_u", "stress", "energy")


def record(args: argparse.Namespace) -> None:
    specs, runs = plan(args.extra, args.scenes, args.only_scenes, args.scheme, args.scene)
    saved: dict[str, np.ndarray] = {}
    for case_name, nx, scheme_name, tr in trajectories(specs, runs):
        motion = [tr.t, tr.U, tr.V, tr.contact_u, tr.stress, *numeric_extra(tr.extra)]
        print(f"{case_name:<14} {scheme_name:<16} {digest([*motion, tr.energy])}",
              flush=True)
        key = f"{case_name}|{nx}|{scheme_name}"
        for f in FIELDS:
            saved[f"{key}|{f}"] = np.asarray(getattr(tr, f), float)
        for j, a in enumerate(numeric_extra(tr.extra)):
            saved[f"{key}|extra{j}"] = np.asarray(a, float)
    if args.save:
        np.savez_compressed(args.save, **saved)


def compare(a_path: str, b_path: str) -> None:
    a, b = np.load(a_path), np.load(b_path)
    runs = sorted({k.rsplit("|", 1)[0] for k in a.files})
    for run in runs:
        keys = sorted(k for k in a.files if k.startswith(run + "|"))
        diffs = []
        for k in keys:
            x = a[k]
            y = b[k] if k in b.files else None
            if y is None or y.shape != x.shape:
                diffs.append(f"{k.rsplit('|', 1)[1]}: shape {x.shape} vs "
                             f"{None if y is None else y.shape}")
                continue
            if np.array_equal(x, y, equal_nan=True):
                continue
            scale = max(float(np.nanmax(np.abs(x), initial=0.0)), 1e-300)
            diffs.append(f"{k.rsplit('|', 1)[1]} {float(np.nanmax(np.abs(x - y))) / scale:.1e}")
        if diffs:
            print(f"{run:<50} " + ", ".join(diffs))
        else:
            print(f"{run:<50} equal")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extra", action="store_true")
    ap.add_argument("--scenes", action="store_true")
    ap.add_argument("--only-scenes", action="store_true")
    ap.add_argument("--scheme", action="append", help="only these schemes (repeatable)")
    ap.add_argument("--scene", action="append",
                    help="only these scenes of SCENES (repeatable, with --only-scenes)")
    ap.add_argument("--save", help="npz file for the trajectories")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"),
                    help="compare two saved runs instead of running")
    args = ap.parse_args(argv)
    if args.compare:
        compare(*args.compare)
    else:
        record(args)


if __name__ == "__main__":
    main()
