"""Two discs (or balls) on non-matching meshes (node-to-segment or node-to-facet rows)
against their half problem.

For each nx, runs `two_discs[lift=0.505,<mesh>]` (disc B's mesh turned or with more
rings: the interfaces do not match) and `two_discs[lift=0.505,half=1]` (disc A on a rigid
plane on the symmetry line) with one scheme, and prints a markdown table of the largest
relative differences: the first contact's end, peak force and impulse, and disc A's
displacement over every sample (relative to its largest value; `u_A_l2`: the l2 norm
over every sample and dof, relative to that of u_A), with the pair's
momentum drift `err_pair_momentum` ("past T": the first contact lasts past T in both).
The two refined together approach each other: the continuous pair is symmetric
(docs/contact.md quotes the table). `--scene two_balls` does the same in 3D (ball B's
mesh turned about its vertical axis, `turn_b`, or of the other kind, `ball_b`).

    python benchmarks/node_to_segment.py --scheme redistributed --mesh turn_b=7 \
        --nx 2 3 4 6 8
    python benchmarks/node_to_segment.py --scene two_balls --scheme 'penalty[beta=0]' \
        --mesh turn_b=7 --nx 2 4 8
"""

from __future__ import annotations

import argparse

import numpy as np

from contact_bench.harness.runner import run_one

KEYS = ("first_contact_end", "peak_contact_force", "contact_impulse")


def rel(a, b) -> float:
    """max |a - b| / max |a| (nan when both are nan: a contact lasting past T)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if np.all(np.isnan(a)) and np.all(np.isnan(b)):
        return float("nan")
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(a))), 1e-300))


def differences(scheme: str, mesh: str, nx: int, T: float, degree: int = 1,
                scene: str = "two_discs") -> dict[str, float]:
    """The half problem's and the non-matching pair's differences at one nx."""
    base = f"{scene}[degree={degree},lift=0.505"
    half = run_one(base + ",half=1]", scheme, nx=nx, T=T).trajectory
    run = run_one(f"{base},{mesh}]", scheme, nx=nx, T=T)
    two = run.trajectory
    if half is None or two is None:
        raise SystemExit(f"{scheme} does not run {scene}: {run.row.get('status')}")
    out = {k: rel(half.extra[k], two.extra[k]) for k in KEYS}
    n = half.U.shape[1]
    out["u_A"] = rel(half.U, two.U[:, :n])
    out["u_A_l2"] = float(np.linalg.norm(half.U - two.U[:, :n]) / np.linalg.norm(half.U))
    out["err_pair_momentum"] = float(run.row["err_pair_momentum"])
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="two_discs", choices=("two_discs", "two_balls"))
    ap.add_argument("--scheme", default="redistributed")
    ap.add_argument("--mesh", default="turn_b=7", help="the scene's parameters of body B")
    ap.add_argument("--nx", type=int, nargs="+", default=[2, 3, 4, 6, 8])
    ap.add_argument("--T", type=float, default=3.0)
    ap.add_argument("--degree", type=int, default=1, choices=(1, 2))
    args = ap.parse_args(argv)
    cols = (*KEYS, "u_A", "u_A_l2", "err_pair_momentum")
    print(f"{args.scheme}, {args.scene}[degree={args.degree},lift=0.505,{args.mesh}] against "
          f"half=1, T = {args.T:g}\n")
    print("| nx | " + " | ".join(cols) + " |")
    print("|---" * (len(cols) + 1) + "|")
    for nx in args.nx:
        d = differences(args.scheme, args.mesh, nx, args.T, args.degree, args.scene)
        print(f"| {nx} | " + " | ".join("past T" if np.isnan(d[c]) else f"{d[c]:.2e}"
                                        for c in cols) + " |", flush=True)


if __name__ == "__main__":
    main()
