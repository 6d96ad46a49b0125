"""The figures of Dabaghi et al. (2014, Fig. 5.1-5.4): u(0, t) and the contact stress against
the exact ones, and the energy in time."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from contact_bench.harness.io import atomic_write  # noqa: E402
from contact_bench.harness.runner import Run  # noqa: E402


def contact_figure(runs: list[Run], exact, title: str, path: str | Path) -> Path:
    """Three panels: contact displacement, contact stress (axis clipped at 4x the exact
    minimum), relative energy drift (symlog); one line per scheme."""
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    runs = [r for r in runs if r.trajectory is not None]
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    for i, run in enumerate(runs):
        tr = run.trajectory
        c = colors[i % 10]
        label = run.row["scheme"]
        axes[0].plot(tr.t, tr.contact_u, color=c, lw=1, label=label)
        axes[1].plot(tr.t, tr.stress, color=c, lw=1, label=label)
        e0 = tr.energy[0] if tr.energy[0] != 0 else 1.0
        axes[2].plot(tr.t, (tr.energy - tr.energy[0]) / abs(e0), color=c, lw=1, label=label)
    if exact is not None and runs:
        t = np.linspace(0, max(r.trajectory.t[-1] for r in runs), 4001)
        axes[0].plot(t, exact.u(0.0, t), "k--", lw=1.2, label="exact")
        s_exact = exact.stress(t)
        axes[1].plot(t, s_exact, "k--", lw=1.2, label="exact")
        if s_exact.min() < 0:  # spikes of chattering schemes run off the axis
            axes[1].set_ylim(4.0 * s_exact.min(), -0.5 * s_exact.min())
    axes[0].set_ylabel("u(0, t)")
    axes[1].set_ylabel("contact stress E u_x(0, t)")
    axes[2].set_ylabel("(E(t) - E(0)) / |E(0)|")
    axes[2].set_yscale("symlog", linthresh=1e-5)
    axes[2].set_xlabel("t")
    axes[0].set_title(title)
    axes[0].legend(fontsize=7, ncol=2)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=110, format=path.suffix[1:]))
    plt.close(fig)
    return path
