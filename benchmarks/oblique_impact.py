"""The FE ball's oblique rebound beside Maw-Barber-Fawcett's theory (docs/oblique-impact.md).

`oblique_impact[of=sphere_drop[lift=0.05],mu=0.3,incidence=...]` (the ball of radius 20,
lambda = mu_L = 20, so nu = 0.25; normal speed 0.1; no gravity) run by one scheme at each
incidence, its rebound read from the FE field (`ObliqueImpact.rebound`: psi1, psi2 and
Omega with the ball's own k^2 = I / (m R^2) of the discrete mass), beside Maw, Barber
and Fawcett's theory (`contact_bench.exact.oblique.mbf_impact`: Hertz-Mindlin contact,
ring-by-ring partial slip, rigid-body inertia) at the ball's nu and k^2, with the
closed-form gross-sliding line and the cruder one-spring model (`compliant_impact`);
the MBF curve at nu = 0.3, k^2 = 2/5 (Chung and Ooi's solid sphere) drawn for
reference, with Chung and Ooi's published FEM points (their Test 5, `CHUNG_OOI_FEM_*`)
beside it. Writes `oblique_impact.md` (the table, with the FE's differences from MBF)
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

#: Chung and Ooi (Granular Matter 13, 2011), Test 5 (constant normal speed, tangential
#: speeds varied): the points labelled "FEM" in their figures of the recoil (psi2, first
#: array) and the final spin (second) against the incidence, as digitised in Kratos's DEM
#: application (KratosMultiphysics/Kratos, applications/DEMApplication/test_examples/
#: basic_benchmarks/paper_data/benchmark5_graph1.dat and benchmark5_graph2.dat, series
#: "FEM"; the first psi2 value there is -0.0267, "modified so we didn't get a NaN").
#: Their axes are the contact point's tangential speed over mu V_n, without Mindlin's
#: kappa (so psi = kappa x), and omega R / (mu V_n) with the opposite sign: in gross
#: sliding their points lie 2 (1 + 1/k^2) = 7 below the diagonal and at -2/k^2 = -5 for
#: k^2 = 2/5, which is how the normalisation is read (docs/oblique-impact.md).
CHUNG_OOI_FEM_PSI2 = np.array([
    [0.00604, -0.02667], [0.27190, -0.02667], [0.58610, -0.02667], [0.87613, -0.08000],
    [1.19033, -0.21333], [1.55287, -0.37333], [1.91541, -0.62667], [2.31420, -0.94667],
    [2.78550, -1.25333], [3.31722, -1.52000], [3.96979, -1.72000], [4.75529, -1.70667],
    [5.75831, -1.20000], [7.12387, 0.13333], [9.11782, 2.14667], [12.35650, 5.42667]])
CHUNG_OOI_FEM_OMEGA = np.array([
    [0.00578, 0.0], [0.31792, -0.18657], [0.59538, -0.40563], [0.89017, -0.66529],
    [1.18497, -0.98177], [1.53179, -1.35506], [1.89595, -1.79329], [2.27746, -2.32083],
    [2.76301, -2.85642], [3.30058, -3.44071], [3.89017, -4.04120], [4.68786, -4.56851],
    [5.65896, -4.94146], [7.02890, -4.94072], [9.04046, -4.97211], [12.33526, -4.97032],
    [18.80347, -4.97494]])
#: their solid sphere (the dotted MBF curve is drawn for it)
CHUNG_OOI_NU, CHUNG_OOI_K2 = 0.3, 0.4


def chung_ooi_in_psi() -> tuple[np.ndarray, np.ndarray]:
    """Chung and Ooi's FEM points in this page's variables at their nu: (psi1, psi2) and
    (psi1, Omega) rows (psi = kappa x, Omega = -their spin)."""
    kappa = 2 * (1 - CHUNG_OOI_NU) / (2 - CHUNG_OOI_NU)
    return (CHUNG_OOI_FEM_PSI2 * kappa,
            np.column_stack([CHUNG_OOI_FEM_OMEGA[:, 0] * kappa, -CHUNG_OOI_FEM_OMEGA[:, 1]]))


def chung_ooi_against_mbf() -> tuple[pd.DataFrame, pd.DataFrame]:
    """Their FEM points beside `mbf_impact` at nu 0.3, k^2 2/5: psi2 differences and the
    Omega ratio at each of their incidences."""
    p2, om = chung_ooi_in_psi()
    s2, _ = oblique.mbf_impact(p2[:, 0], CHUNG_OOI_NU, CHUNG_OOI_K2)
    _, mo = oblique.mbf_impact(om[:, 0], CHUNG_OOI_NU, CHUNG_OOI_K2)
    a = pd.DataFrame({"psi1": p2[:, 0], "psi2_chung_ooi_fem": p2[:, 1], "psi2_mbf": s2,
                      "fem_minus_mbf": p2[:, 1] - s2})
    b = pd.DataFrame({"psi1": om[:, 0], "Omega_chung_ooi_fem": om[:, 1], "Omega_mbf": mo,
                      "fem_over_mbf": np.where(mo > 0, om[:, 1] / np.where(mo > 0, mo, 1),
                                               np.nan)})
    return a, b


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
    p2, om = chung_ooi_in_psi()
    keep = p2[:, 0] <= psi[-1]
    ax[0].plot(p2[keep, 0], p2[keep, 1], "s", mfc="none", color="C2",
               label="Chung & Ooi 2011 Test 5, FEM (nu 0.3)")
    keep = om[:, 0] <= psi[-1]
    ax[1].plot(om[keep, 0], om[keep, 1], "s", mfc="none", color="C2",
               label="Chung & Ooi 2011 Test 5, FEM (nu 0.3)")
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
    co2, com = chung_ooi_against_mbf()
    text += ("\n## Chung and Ooi's FEM points (Test 5) beside MBF at nu 0.3, k^2 0.4\n\n"
             "Digitised in Kratos's DEM application (benchmark5_graph1/2.dat, series "
             "'FEM'), in these variables (`CHUNG_OOI_FEM_*` in this script). psi2 FEM "
             f"minus MBF: {co2['fem_minus_mbf'].min():+.3f} to "
             f"{co2['fem_minus_mbf'].max():+.3f}; Omega FEM / MBF (psi1 > 0.2): "
             f"{com['fem_over_mbf'][com['psi1'] > 0.2].min():.3f} to "
             f"{com['fem_over_mbf'][com['psi1'] > 0.2].max():.3f}.\n\n"
             + co2.to_markdown(index=False, floatfmt=".4g") + "\n\n"
             + com.to_markdown(index=False, floatfmt=".4g") + "\n")
    (a.out / "oblique_impact.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
