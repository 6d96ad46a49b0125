"""Digest of every scheme's trajectory on the default run: one SHA-256 per (scene, scheme).

Two checkouts that print the same digests step every scheme bit for bit alike (t, U, V,
contact u, stress and energy of every sample). Used to show that a refactoring changed no
number: run it before and after, then `diff` the outputs.

    python benchmarks/trajectory_digest.py > before.txt
"""

from __future__ import annotations

import hashlib

import numpy as np

try:
    from contact_bench.api.registry import cases, schemes
    from contact_bench.harness import run_one
except ImportError:  # the layout before the one-package move
    from contact_bench.api.registry import cases, schemes  # type: ignore[no-redef]
    from contact_bench.harness.runner import run_one  # type: ignore[no-redef]


def digest(arrays: list[np.ndarray]) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def main() -> None:
    for case_name, cls in cases().plugins.items():
        if not cls.in_default_run:
            continue
        for scheme_name in schemes().names():
            run = run_one(case_name, scheme_name)
            tr = run.trajectory
            if tr is None:
                print(f"{case_name:<14} {scheme_name:<16} no trajectory ({run.row['status']})")
                continue
            arrays = [tr.t, tr.U, tr.V, tr.contact_u, tr.stress, tr.energy]
            print(f"{case_name:<14} {scheme_name:<16} {digest(arrays)}")


if __name__ == "__main__":
    main()
