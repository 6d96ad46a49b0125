"""The manufactured solution with a moving contact zone (contact_bench.exact.manufactured),
checked independently of the symbolic derivation that built its load: finite differences of
the displacement u give the PDE residual rho u_tt - div sigma(u) - f, the tractions and,
on the contact face, Signorini's and the frictionless conditions."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from contact_bench.exact import manufactured as mf

H = 1e-3  # finite-difference step (second differences: O(H^2) + round-off / H^2)


def fd_fields(ex: mf.Manufactured, x: np.ndarray, t: float):
    """grad u (dim, dim) and the second derivatives d_j d_k u_i, u_tt at one point, by
    central differences of `ex.u` alone."""
    dim = ex.dim

    def u(p: np.ndarray, s: float) -> np.ndarray:
        return ex.u(p[:, None], s)[:, 0]

    e = np.eye(dim) * H
    grad = np.stack([(u(x + e[j], t) - u(x - e[j], t)) / (2 * H) for j in range(dim)], axis=1)
    hess = np.empty((dim, dim, dim))  # [i, j, k]
    for j, k in itertools.product(range(dim), repeat=2):
        if j == k:
            hess[:, j, k] = (u(x + e[j], t) - 2 * u(x, t) + u(x - e[j], t)) / H**2
        else:
            hess[:, j, k] = (u(x + e[j] + e[k], t) - u(x + e[j] - e[k], t)
                             - u(x - e[j] + e[k], t) + u(x - e[j] - e[k], t)) / (4 * H**2)
    utt = (u(x, t + H) - 2 * u(x, t) + u(x, t - H)) / H**2
    return grad, hess, utt


def stress(grad: np.ndarray) -> np.ndarray:
    eps = 0.5 * (grad + grad.T)
    return 2 * mf.MU * eps + mf.LAM * np.trace(eps) * np.eye(grad.shape[0])


@pytest.mark.parametrize("dim", [2, 3])
def test_the_load_is_the_pde_residual_of_the_displacement(dim: int) -> None:
    ex = mf.Manufactured(dim)
    rng = np.random.default_rng(dim)
    worst, scale = 0.0, 0.0
    for _ in range(12):
        x = rng.uniform(0.05, 0.95, dim)
        t = float(rng.uniform(0.05, 0.95))
        _, hess, utt = fd_fields(ex, x, t)
        div = np.array([sum(mf.MU * (hess[i, j, j] + hess[j, i, j])
                            + (mf.LAM * sum(hess[k, k, i] for k in range(dim)) if j == i else 0)
                            for j in range(dim)) for i in range(dim)])
        f = ex.load(0, x[:, None], t)[:, 0]
        worst = max(worst, float(np.max(np.abs(mf.RHO * utt - div - f))))
        scale = max(scale, float(np.max(np.abs(f))))
    assert scale > 0.1
    assert worst < 1e-4 * scale


@pytest.mark.parametrize("dim", [2, 3])
def test_the_tractions_are_sigma_n_on_the_loaded_faces(dim: int) -> None:
    ex = mf.Manufactured(dim)
    rng = np.random.default_rng(10 + dim)
    for region, (axis, side) in enumerate(ex.faces, start=1):
        x = rng.uniform(0.1, 0.9, dim)
        x[axis] = side  # the closed form extends smoothly across the face
        t = float(rng.uniform(0.1, 0.9))
        grad, _, _ = fd_fields(ex, x, t)
        n = np.zeros(dim)
        n[axis] = 1.0 if side > 0 else -1.0
        got = ex.load(region, x[:, None], t)[:, 0]
        assert np.allclose(stress(grad) @ n, got, atol=1e-4)


@pytest.mark.parametrize("dim", [2, 3])
def test_signorini_and_no_shear_hold_on_the_contact_face(dim: int) -> None:
    ex = mf.Manufactured(dim)
    rng = np.random.default_rng(20 + dim)
    contact = separated = 0
    for _ in range(40):
        x = rng.uniform(0.02, 0.98, dim)
        x[-1] = 0.0
        t = float(rng.uniform(0.0, 1.0))
        gap = float(ex.u(x[:, None], t)[-1, 0])  # the obstacle is the plane x_{dim-1} = 0
        # one-sided differences into the body for the stress at the face
        e = np.eye(dim) * H

        def u(p: np.ndarray, t: float = t) -> np.ndarray:
            return ex.u(p[:, None], t)[:, 0]

        grad = np.empty((dim, dim))
        for j in range(dim):
            if j == dim - 1:  # second-order one-sided
                grad[:, j] = (-3 * u(x) + 4 * u(x + e[j]) - u(x + 2 * e[j])) / (2 * H)
            else:
                grad[:, j] = (u(x + e[j]) - u(x - e[j])) / (2 * H)
        sig = stress(grad)
        s_nn = sig[-1, -1]
        assert gap >= 0.0
        assert s_nn <= 1e-5
        assert abs(gap * s_nn) < 1e-7
        assert np.all(np.abs(sig[:-1, -1]) < 1e-5)  # frictionless
        assert abs(gap - float(ex.gap(x[:, None], t)[0])) < 1e-15
        assert abs(s_nn - float(ex.normal_stress(x[:, None], t)[0])) < 1e-5
        contact += s_nn < -1e-4
        separated += gap > 1e-4
    assert contact > 5 and separated > 5  # both parts of the face are sampled


def test_the_contact_zone_moves_across_the_face() -> None:
    ex = mf.Manufactured(2)
    x = np.vstack([np.linspace(0, 1, 201), np.zeros(201)])
    zone = [float(np.mean(ex.normal_stress(x, t) < 0)) for t in (0.0, 0.5, 1.0)]
    assert zone[0] < 0.25 < zone[1] < 0.6 < zone[2]


def test_the_generated_closed_forms_are_current() -> None:
    pytest.importorskip("sympy")
    path = Path(mf.__file__).with_name("manufactured_forms.py")
    assert path.read_text() == mf.generate() + "\n", (
        "regenerate: python -m contact_bench.exact.manufactured")
