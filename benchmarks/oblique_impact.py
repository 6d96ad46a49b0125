"""The FE ball's oblique rebound beside Maw-Barber-Fawcett's theory (docs/oblique-impact.md).

`oblique_impact[of=sphere_drop[lift=0.05],mu=0.3,incidence=...]` (the ball of radius 20,
lambda = mu_L = 20, so nu = 0.25; normal speed 0.1; no gravity) run by one scheme at each
incidence, its rebound read from the FE field (`ObliqueImpact.rebound`: psi1, psi2 and
Omega with the ball's own k^2 = I / (m R^2) of the discrete mass), beside Maw, Barber
and Fawcett's theory (`contact_bench.exact.oblique.mbf_impact`: Hertz-Mindlin contact,
ring-by-ring partial slip, rigid-body inertia) at the ball's nu and k^2, with the
closed-form gross-sliding line and the cruder one-spring model (`compliant_impact`);
the MBF curve at nu = 0.3, k^2 = 2/5 (Chung and Ooi's solid sphere) drawn for
reference. Writes `oblique_impact.md` (the table, with the FE's differences from MBF)
and `oblique_impact.png` (psi2 and Omega against psi1) under --out.

    python benchmarks/oblique_impact.py --out /tmp/oblique [--scheme moreau_jean]
        [--nx 8] [--dt 0.05] [--incidence 5 10 20 30 40 50 60 70 80]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.exact import oblique
from contact_bench.harness import run_one

SPEC = "oblique_impact[of=sphere_drop[lift=0.05],mu={mu},incidence={inc}]"


def measure(a: argparse.Namespace) -> pd.DataFrame:
    """One row per incidence: the FE rebound and the theory at the ball's nu and k^2."""
    rows = []
    for inc in a.incidence:
        spec = SPEC.format(mu=a.mu, inc=inc)
        case = make_case(spec)
        run = run_one(spec, a.scheme, nx=a.nx, dt=a.dt)
        p = case.sparse_problem(a.nx, 1.0, make_scheme(a.scheme).mass_kind())
        r = case.rebound(p, run.trajectory, a.nx)
        psi2, omega = oblique.mbf_impact(np.array([r["psi1"]]), r["nu"], r["k2"])
        one, _ = oblique.compliant_impact(np.array([r["psi1"]]), r["nu"], r["k2"])
        rows.append({"incidence": inc, "psi1": r["psi1"], "psi2_fe": r["psi2"],
                     "psi2_mbf": float(psi2[0]), "psi2_fe_minus_mbf": r["psi2"] - psi2[0],
                     "psi2_one_spring": float(one[0]), "Omega_fe": r["Omega"],
                     "Omega_mbf": float(omega[0]),
                     "Omega_fe_over_mbf": r["Omega"] / float(omega[0]),
                     "e_normal": r["vn_after"] / r["vn_before"], "k2": r["k2"],
                     "err_impulse_ratio": run.row["err_impulse_ratio"],
                     "contact_end": run.trajectory.extra["first_contact_end"]})
        print(f"incidence {inc:5.1f}: psi1 {r['psi1']:7.3f} psi2 {r['psi2']:8.4f} "
              f"(MBF {psi2[0]:8.4f}) Omega {r['Omega']:7.4f} (MBF {omega[0]:7.4f})",
              flush=True)
    return pd.DataFrame(rows)


def draw(df: pd.DataFrame, nu: float, k2: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    psi = np.linspace(0.01, float(df["psi1"].max()) * 1.05, 300)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for (n, k), style, label in (((nu, k2), "-", f"MBF, nu {nu:g}, k^2 {k2:.4f}"),
                                 ((0.3, 0.4), ":", "MBF, nu 0.3, k^2 0.4")):
        s2, om = oblique.mbf_impact(psi, n, k)
        ax[0].plot(psi, s2, "k" + style, label=label)
        ax[1].plot(psi, om, "k" + style, label=label)
    s2, _ = oblique.compliant_impact(psi, nu, k2)
    ax[0].plot(psi, s2, "--", color="C0", lw=0.8, label="one-spring model")
    g2, _ = oblique.gross_sliding(psi, nu, k2)
    ax[0].plot(psi, g2, color="0.6", lw=0.8, label="gross sliding, psi1 - 4 chi")
    ax[0].plot(df["psi1"], df["psi2_fe"], "o", color="C3", label="FE ball")
    ax[1].plot(df["psi1"], df["Omega_fe"], "o", color="C3", label="FE ball")
    ax[0].set(xlabel="psi1 (normalised incidence)", ylabel="psi2 (normalised recoil)")
    ax[1].set(xlabel="psi1 (normalised incidence)", ylabel="Omega = omega R / (mu V_n)")
    for x in ax:
        x.grid(alpha=0.3)
        x.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--scheme", default="moreau_jean")
    ap.add_argument("--nx", type=int, default=8)
    ap.add_argument("--dt", type=float, default=0.05)
    ap.add_argument("--mu", type=float, default=0.3)
    ap.add_argument("--incidence", type=float, nargs="+",
                    default=[5, 10, 20, 30, 40, 50, 60, 70, 80])
    a = ap.parse_args(argv)
    df = measure(a)
    a.out.mkdir(parents=True, exist_ok=True)
    nu, k2 = 0.25, float(df["k2"].iloc[0])
    draw(df, nu, k2, a.out / "oblique_impact.png")
    cmd = ("python benchmarks/oblique_impact.py --out DIR --scheme "
           f"{a.scheme} --nx {a.nx} --dt {a.dt:g} --mu {a.mu:g}")
    text = (f"# The FE ball's oblique rebound against Maw-Barber-Fawcett's theory\n\n"
            f"`{cmd}` ({SPEC.format(mu=a.mu, inc='...')}, {a.scheme}, nx {a.nx}, "
            f"dt {a.dt:g}; nu {nu:g}, the discrete mass's k^2 {k2:.4f}, chi "
            f"{oblique.chi(nu, k2):.4f}). Theory: `contact_bench.exact.oblique."
            "mbf_impact` (Maw-Barber-Fawcett, ring-by-ring partial slip) at the ball's nu "
            "and k^2; `psi2_one_spring` the cruder `compliant_impact` "
            "(docs/oblique-impact.md).\n\n"
            f"FE minus MBF: psi2 by {df['psi2_fe_minus_mbf'].min():+.3f} to "
            f"{df['psi2_fe_minus_mbf'].max():+.3f}; Omega FE / MBF "
            f"{df['Omega_fe_over_mbf'].min():.3f} to {df['Omega_fe_over_mbf'].max():.3f}."
            "\n\n" + df.to_markdown(index=False, floatfmt=".4g") + "\n")
    (a.out / "oblique_impact.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
