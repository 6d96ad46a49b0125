"""A manufactured exact solution of dynamic Signorini contact with a moving contact zone.

The body is the unit box (0, 1)^dim (dim 2: plane strain; 3), coordinates x_0 .. x_{dim-1},
the last one normal to the contact face x_{dim-1} = 0, which rests on the rigid plane
x_{dim-1} = 0 (initial gap 0). Lame's lambda = mu = 1, rho = 1 (`LAM`, `MU`, `RHO`).

One level function s(x, t) = x_0 - x_c(t) (+ 0.2 (x_1 - 1/2) in 3D: an oblique front),
x_c(t) = 0.2 + 0.6 t, sweeps the face in t in [0, 1]. With R_k(s) = max(0, s)^k (k =
`KPOW` = 4, C^3), the gap phi = A R_k(s) >= 0 and the normal stress psi = -B R_k(-s) <= 0
have phi psi = 0 everywhere: contact (phi = 0, psi < 0) where s < 0, separation where
s > 0. With z = x_{dim-1} and i over the tangential coordinates,

    u_i = -z d_i phi + z^2 q_i,   u_z = phi + z psi / (lambda + 2 mu) + z^2 q_z,

q a smooth field (`Q_AMP`: waves in time). At z = 0: u_z = phi (the gap), u_i = 0 so
div u = d_z u_z and sigma_zz = (lambda + 2 mu) d_z u_z = psi, and sigma_iz = mu (d_z u_i
+ d_i u_z) = mu (-d_i phi + d_i phi) = 0 (no shear): Signorini's conditions and the
frictionless condition hold exactly. The body force f = rho u_tt - div sigma(u), the
tractions sigma(u) n on the other faces and the initial data u(., 0), u_t(., 0) follow
by symbolic differentiation (sympy; R_k differentiated as k R_{k-1}).

The closed forms are generated once into `contact_bench.exact.manufactured_forms` (sympy,
`python -m contact_bench.exact.manufactured`; a test checks the file is current), so that
sympy is needed only to regenerate and test them. `Manufactured(dim)` evaluates u, u_t,
phi, psi and the load density through one compiled scalar function (`closed_form`, a
numba cfunc: the `contact_bench.api.sparse.TimeLoad` contract). The derivation:
docs/manufactured.md; the independent check of the PDE and of the complementarity
conditions: tests/test_manufactured_solution.py.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np
from numba import njit

LAM, MU, RHO = 1.0, 1.0, 1.0
#: the power k of the gap and the stress profiles (C^{k-1}; f needs three derivatives)
KPOW = 4
#: the gap's and the normal stress's amplitudes A, B
A_GAP, B_STRESS = 0.2, 1.0
#: the amplitude of the smooth field q (vanishing to second order at the face)
Q_AMP = 0.1
#: the final time of the sweep x_c(t) = 0.2 + 0.6 t
T_END = 1.0
#: the faces with traction data, (axis, side): the box's faces but the contact face;
#: load region r >= 1 is FACES[r - 1] (region 0: the volume)
FACES = {2: ((0, 0.0), (0, 1.0), (1, 1.0)),
         3: ((0, 0.0), (0, 1.0), (1, 0.0), (1, 1.0), (2, 1.0))}


def front(t: Any) -> Any:
    """x_c(t), where the level function's zero line crosses x_1 = 1/2."""
    return 0.2 + 0.6 * t


@lru_cache(maxsize=2)
def _symbolic(dim: int) -> dict[str, Any]:
    """The closed forms (sympy expressions in x0, x1, x2, t): u, u_t, phi, psi, the body
    force f and the tractions of the faces of `FACES`."""
    import sympy as sy

    class Ramp(sy.Function):
        """Ramp(k, s) = max(0, s)^k, d/ds = k Ramp(k - 1, s)."""

        nargs = 2

        def fdiff(self, argindex: int = 2) -> Any:
            k, s = self.args
            if argindex != 2:
                raise sy.ArgumentIndexError(self, argindex)
            return k * Ramp(k - 1, s) if k > 1 else sy.Heaviside(s)

    X = sy.symbols("x0 x1 x2", real=True)
    t = sy.Symbol("t", real=True)
    xs = X[:dim]
    z = xs[-1]
    lam, mu, rho = sy.nsimplify(LAM), sy.nsimplify(MU), sy.nsimplify(RHO)
    s = xs[0] - sy.Rational(1, 5) - sy.Rational(3, 5) * t
    if dim == 3:
        s = s + sy.Rational(1, 5) * (xs[1] - sy.Rational(1, 2))
    phi = sy.nsimplify(A_GAP) * Ramp(KPOW, s)
    psi = -sy.nsimplify(B_STRESS) * Ramp(KPOW, -s)
    w = 2 * sy.pi
    shape = sy.cos(sy.pi * xs[1] / 2) if dim == 3 else sy.Integer(1)
    amp = sy.nsimplify(Q_AMP)
    q = [amp * sy.cos(w * t) * sy.sin(sy.pi * xs[0]) * shape for _ in range(dim - 1)]
    q.append(amp * sy.sin(w * t) * sy.cos(sy.pi * xs[0]) * shape)
    u = [-z * sy.diff(phi, xs[i]) + z**2 * q[i] for i in range(dim - 1)]
    u.append(phi + z * psi / (lam + 2 * mu) + z**2 * q[-1])
    grad = [[sy.diff(u[i], xs[j]) for j in range(dim)] for i in range(dim)]
    div = sum(grad[i][i] for i in range(dim))
    sig = [[mu * (grad[i][j] + grad[j][i]) + (lam * div if i == j else 0)
            for j in range(dim)] for i in range(dim)]
    f = [rho * sy.diff(u[i], t, 2) - sum(sy.diff(sig[i][j], xs[j]) for j in range(dim))
         for i in range(dim)]
    tractions = []
    for axis, side in FACES[dim]:
        sign = 1 if side > 0 else -1
        tractions.append([sign * sig[i][axis] for i in range(dim)])
    return dict(X=X, t=t, Ramp=Ramp, u=u, ut=[sy.diff(c, t) for c in u], phi=phi, psi=psi,
                f=f, tractions=tractions, sigma=sig)


def _plain(expr: Any, Ramp: Any) -> Any:
    """The expression with Ramp(k, s) written as max(0, s)^k."""
    import sympy as sy

    return expr.replace(Ramp, lambda k, s: sy.Max(0, s) ** k)


def codes(dim: int) -> dict[str, int]:
    """The codes of the generated closed form (`closed_form_<dim>d(x0, x1, x2, t, code)`):
    u_c at code c, u_t c at dim + c, phi at 2 dim, psi at 2 dim + 1, and the load
    density from `load` = 2 dim + 2 on: component c of the body force (region r = 0) or
    of the traction on face FACES[r - 1] at load + r dim + c."""
    return {"u": 0, "ut": dim, "phi": 2 * dim, "psi": 2 * dim + 1, "load": 2 * dim + 2}


def generate() -> str:
    """The source of `contact_bench.exact.manufactured_forms` (sympy, cse)."""
    import sympy as sy

    out = ["# ruff: noqa: E501",
           '"""Generated by `python -m contact_bench.exact.manufactured`: DO NOT EDIT.',
           "",
           "The closed forms of `contact_bench.exact.manufactured` (codes: its `codes`), as",
           "plain scalar functions that numba compiles.",
           '"""', "", "import math", ""]
    for dim in (2, 3):
        sym = _symbolic(dim)
        exprs = [*sym["u"], *sym["ut"], sym["phi"], sym["psi"], *sym["f"]]
        for tr in sym["tractions"]:
            exprs.extend(tr)
        out += ["", f"def closed_form_{dim}d(x0, x1, x2, t, code):"]
        for code, e in enumerate(exprs):
            reps, (body,) = sy.cse([_plain(e, sym["Ramp"])], sy.numbered_symbols("c"),
                                  optimizations="basic")
            out.append(f"    if code == {code}:")
            for name, value in reps:
                out.append(f"        {name} = {sy.pycode(value)}")
            out.append(f"        return {sy.pycode(body)}")
        out.append("    return 0.0")
        out.append("")
    return "\n".join(out)


SIGNATURE = "float64(float64, float64, float64, float64, int64)"


@lru_cache(maxsize=2)
def closed_form(dim: int) -> Any:
    """The compiled closed form of `dim` (a numba cfunc, cached on disk): the load
    density of `contact_bench.api.sparse.TimeLoad` and the fields' evaluation."""
    from numba import cfunc

    from contact_bench.exact import manufactured_forms as forms

    return cfunc(SIGNATURE, cache=True)(getattr(forms, f"closed_form_{dim}d"))


@njit(cache=True)
def _evaluate(fn, X, t, code, out):  # pragma: no cover - compiled
    for j in range(out.size):
        out[j] = fn(X[0, j], X[1, j], X[2, j], t[j], code)


class Manufactured:
    """The manufactured solution in `dim` (2 or 3) dimensions (module docstring)."""

    def __init__(self, dim: int) -> None:
        if dim not in (2, 3):
            raise ValueError(f"dim = {dim!r}: the manufactured solution has dim 2 or 3")
        self.dim = int(dim)
        self.codes = codes(self.dim)

    @property
    def faces(self) -> tuple[tuple[int, float], ...]:
        """The faces with traction data (axis, side), in the load's region order."""
        return FACES[self.dim]

    @property
    def density(self) -> Any:
        """The compiled closed form (`closed_form`)."""
        return closed_form(self.dim)

    def value(self, code: int, x: np.ndarray, t: Any) -> np.ndarray:
        """The closed form's `code` at points x (dim or 3, ...) and times t, broadcast."""
        x = np.asarray(x, float)
        shape = np.broadcast_shapes(x[0].shape, np.shape(t))
        X = np.zeros((3, int(np.prod(shape))))
        for c in range(min(x.shape[0], 3)):
            X[c] = np.broadcast_to(x[c], shape).ravel()
        tt = np.ascontiguousarray(np.broadcast_to(np.asarray(t, float), shape).ravel())
        out = np.empty(X.shape[1])
        _evaluate(self.density, X, tt, int(code), out)
        return out.reshape(shape)

    def u(self, x: np.ndarray, t: Any) -> np.ndarray:
        """(dim, ...) displacement at points x (dim, ...) and times t (broadcast)."""
        return np.stack([self.value(self.codes["u"] + c, x, t) for c in range(self.dim)])

    def ut(self, x: np.ndarray, t: Any) -> np.ndarray:
        """(dim, ...) velocity."""
        return np.stack([self.value(self.codes["ut"] + c, x, t) for c in range(self.dim)])

    def gap(self, x: np.ndarray, t: Any) -> np.ndarray:
        """phi: the gap at points of the face (their last coordinate ignored)."""
        return self.value(self.codes["phi"], x, t)

    def normal_stress(self, x: np.ndarray, t: Any) -> np.ndarray:
        """psi: sigma_nn on the face (compression negative)."""
        return self.value(self.codes["psi"], x, t)

    def load(self, region: int, x: np.ndarray, t: Any) -> np.ndarray:
        """(dim, ...) the body force f = rho u_tt - div sigma(u) (region 0) or the
        traction sigma(u) n on face FACES[region - 1]."""
        base = self.codes["load"] + int(region) * self.dim
        return np.stack([self.value(base + c, x, t) for c in range(self.dim)])


__all__ = ["A_GAP", "B_STRESS", "FACES", "KPOW", "LAM", "MU", "SIGNATURE", "Manufactured",
           "Q_AMP", "RHO", "T_END", "closed_form", "codes", "front", "generate"]


if __name__ == "__main__":  # regenerate the closed forms
    import pathlib

    target = pathlib.Path(__file__).with_name("manufactured_forms.py")
    target.write_text(generate() + "\n")
    print(f"wrote {target}")
