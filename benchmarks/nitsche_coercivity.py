"""The smallest Nitsche parameter gamma0 for which the symmetric sparse Nitsche
stiffness K - (1 / gam) B^T M_f B stays positive semi-definite, gam = gamma0 E / h, on a
sparse scene (default: the disc), per degree and mesh.

    python benchmarks/nitsche_coercivity.py [--case disc_drop] [--nx 2 3 4 6 8]

gamma0_min = (h / E) sup_v (B v).M_f.(B v) / v.K.v: the largest eigenvalue of the
n_c x n_c pencil (B K^+ B^T, M_f^-1), with K^+ B^T solved on K + eps M (B kills the rigid
motions, so the shift leaves it unchanged up to eps) and checked by an independent
sparse generalized eigenvalue solve (eigsh of B^T M_f B against K + eps M). h is the
problem's `h_contact` (the element size over the degree squared); the last column gives
gamma0_min for h = the element size R / nx itself (scenes with a `degree` parameter).
"""

from __future__ import annotations

import argparse

import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.linalg import eigsh, splu

from contact_bench.api.registry import make_case


def gamma0_min(problem) -> tuple[float, float]:
    """(gamma0_min by the n_c-sized pencil, by eigsh on the n-sized one), for the
    problem's own h_contact."""
    K, M = problem.K, problem.M
    B = sp.csr_matrix(problem.normal_stress)
    Mf = problem.contact.face_mass.toarray()
    eps = 1e-10 * abs(K).max() / max(abs(M).max(), 1e-300)
    lu = splu(sp.csc_matrix(K + eps * M))
    X = lu.solve(B.T.toarray())  # n x n_c
    S = B @ X
    S = 0.5 * (S + S.T)
    L = la.cholesky(Mf, lower=True)
    lam = float(la.eigvalsh(L.T @ S @ L).max())
    A = sp.csr_matrix(B.T @ sp.csr_matrix(Mf) @ B)
    lam2 = float(eigsh(A, k=1, M=sp.csc_matrix(K + eps * M), which="LA",
                       return_eigenvectors=False)[0])
    scale = problem.h_contact / problem.E_contact
    return lam * scale, lam2 * scale


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="disc_drop")
    ap.add_argument("--nx", type=int, nargs="+", default=[2, 3, 4, 6, 8])
    args = ap.parse_args(argv)
    print("| degree | nx | dofs | contact dofs | h_contact | gamma0_min | (eigsh) |"
          " gamma0_min at h_el = R / nx |")
    print("|---|---|---|---|---|---|---|---|")
    has_degree = "degree" in make_case(args.case).params
    for degree in (1, 2) if has_degree else (None,):
        case = make_case(f"{args.case}[degree={degree}]" if has_degree else args.case)
        for nx in args.nx:
            p = case.sparse_problem(nx, 1.0, "consistent")
            g, g2 = gamma0_min(p)
            at_el = f"{g * case.R / nx / p.h_contact:.4g}" if degree else "-"
            print(f"| {degree or 'fixed'} | {nx} | {p.nfree} | {p.contact.size} |"
                  f" {p.h_contact:.4g} | {g:.4g} | {g2:.4g} | {at_el} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
