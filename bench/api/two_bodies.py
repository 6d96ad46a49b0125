"""What the two-body scenes share (`two_discs` in 2D, `two_balls` in 3D: two mirror-image
bodies meeting at +v and -v without gravity, joined by node-to-segment or node-to-facet
rows, each with parameters `half` and `speed`): their refusal of Nitsche's method and their
momentum check. One owner, so that the 2D and the 3D scene refuse and measure alike."""

from __future__ import annotations

import numpy as np

from contact_bench.api.plugin import BodyCase, Contact, Scheme, Trajectory
from contact_bench.api.sparse import SparseProblem


def nitsche_refusal(scene: BodyCase, scheme: Scheme) -> str | None:
    """Why a Nitsche scheme cannot run the two bodies (its two-body stress term, the mean
    of the two normal stresses, is not built), naming the scene's `half=1` that it can
    run; None for every other scheme and for `half=1` (one body on a rigid plane)."""
    if int(scene.half) or scheme.traits().contact != Contact.NITSCHE:
        return None
    return ("Nitsche's method between two bodies (the mean of their normal stresses) is "
            f"not built: use {scene.name}[half=1]")


def pair_momentum_errors(scene: BodyCase, problem: SparseProblem,
                         traj: Trajectory) -> dict[str, float]:
    """err_pair_momentum: max over the samples and the `problem.dim` directions of
    |p_c(t_k) - p_c(0)|, p_c = 1_c . M V the pair's momentum along e_c, relative to the
    pair's mass times the scene's `speed`. Without gravity and with rows whose weights sum
    to one it is kept (round-off); nothing for `half=1`, where the plane pushes."""
    if int(scene.half):
        return {}
    n, dim = problem.nfree, int(problem.dim)
    drift = 0.0
    for c in range(dim):
        p = traj.V @ (problem.M @ (np.arange(n) % dim == c).astype(float))
        drift = max(drift, float(np.max(np.abs(p - p[0]))))
    return {"err_pair_momentum": drift / (float(problem.body_mass) * float(scene.speed))}
