"""Writes `bench/kernels/newmark_vec.py`, the vector Newmark kernels (implicit and explicit).

    python -m contact_bench.kernels.newmark_codegen          # rewrite newmark_vec.py
    python -m contact_bench.kernels.newmark_codegen --check  # exit 1 if the file is out of date

The kernels are generated rather than written by hand because their hot loop is one
long straight-line body per case (16 lanes = two `<8 x double>` vectors, with or
without the load vector, with or without each spike correction): the cases must be
separate branch-free loops, and no array may be passed to a helper function inside
the loop (numba increfs an array on every call). The generated file is kept in the
repository, so numba caches it like any other module (`cache=True` needs a source
file) and it can be read; tests/test_codegen.py checks that it is up to date.

What the kernels compute is described in `contact_bench.kernels.newmark` (the algorithm) and in
the generated file's docstring (the vector passes).
"""

from __future__ import annotations

import sys
from pathlib import Path

TARGET = Path(__file__).with_name("newmark_vec.py")
HALVES = (("0", ""), ("1", " + U8"))  # the two 8-wide halves of a 16-lane row


class _Emitter:
    def __init__(self) -> None:
        self.lines: list[str] = []
        self.depth = 0

    def __call__(self, *lines: str) -> None:
        for line in lines:
            self.lines.append("    " * self.depth + line if line else "")

    def indent(self) -> _Emitter:
        self.depth += 1
        return self

    def dedent(self) -> None:
        self.depth -= 1

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def _update(e: _Emitter, implicit: bool, h: str, at: str, out: str, sample: bool) -> None:
    """Newmark update of 8 entries at position `at` from the final solution zf{h}:
    implicit d = zf - X (= beta dt^2 a1), X <- zf + Q + k1 d; explicit d = zf (= dt^2 a1),
    X <- X + Q + k1 d; both Q <- Q + k2 d. On sample steps also Vs = Q / dt + kv d."""
    e(f"xo{h} = vload(X, {at})", f"q{h} = vload(Q, {at})")
    d = f"d{h}" if implicit else f"zf{h}"
    if implicit:
        e(f"d{h} = zf{h} - xo{h}")
    if sample:
        e(f"vstore(Vs, {at}, vfma(kv, {d}, q{h} * idtv))")
    base = f"zf{h}" if implicit else f"xo{h}"
    e(f"{out} = vfma(k1, {d}, {base} + q{h})", f"vstore(X, {at}, {out})",
      f"vstore(Q, {at}, vfma(k2, {d}, q{h}))")


def _correction(e: _Emitter, h: str, at: str, doA: bool, doB: bool, bat: str) -> None:
    if doA:
        e(f"zf{h} = vfnma(cA{h}, vload(sa, {at}), zf{h})")
    if doB:
        e(f"zf{h} = vfnma(cB{h}, vload(sb, {bat}), zf{h})")


def _row(e: _Emitter, implicit: bool, upd: bool, doA: bool, doB: bool, load: bool,
         last: int = 0) -> None:
    """Iteration j of the fused pass: (upd) final value and update of row j + 1, then the
    right-hand side of row j and its forward-sweep step. last: 0 a middle row, 1 row
    m - 2 (row m - 1 was updated before the pass), 2 row m - 1 (its next neighbour is
    row 0 of the next lane)."""
    e("p = uint64(j) * U16", "pn = p + U16")
    for h, o in HALVES:
        if last == 2:
            e(f"sp{h} = vload(SloN, uint64({8 * int(h)}))",
              f"xp{h} = vload(X, uint64({1 + 8 * int(h)}))")
            continue
        e(f"sp{h} = vload(Slo, pn{o})")
        if upd:
            e(f"zf{h} = vload(z, pn{o})")
            _correction(e, h, f"pn{o}", doA, doB, f"pn - ub{o}")
            _update(e, implicit, h, f"pn{o}", f"xp{h}", False)
        else:
            e(f"xp{h} = vload(X, pn{o})")
    for h, o in HALVES:
        e(f"r{h} = vfma(sp{h}, xp{h}, vfma(sm{h}, xm{h}, vload(Sd, p{o}) * xc{h}))")
        if load:
            e(f"r{h} = vload(G, p{o}) + r{h}")
        e(f"y{h} = vfnma(vload(lo, p{o}), y{h}, r{h})", f"vstore(z, p{o}, y{h})")
    e("xm0, xm1, xc0, xc1, sm0, sm1 = xc0, xc1, xp0, xp1, sp0, sp1")


def _pass_a(e: _Emitter, implicit: bool, upd: bool) -> None:
    """Right-hand side G + S X and forward sweep of all rows into z; with upd, fused with
    the final value and update of rows 2 .. m-2 (rows 0, 1, m-1 are done before)."""
    e("# right-hand side G + S X and forward sweep"
      + (", fused with the update of rows 2 .. m-2" if upd else ""),
      "xm0 = vload(X, (um - uint64(1)) * U16 - uint64(1))",
      "xm1 = vload(X, (um - uint64(1)) * U16 + uint64(7))",
      "xc0 = vload(X, uint64(0))", "xc1 = vload(X, U8)",
      "sm0 = vload(Slo, uint64(0))", "sm1 = vload(Slo, U8)",
      "y0 = vsplat(0.0)", "y1 = y0")
    for load in (True, False):
        e("if has_load:" if load else "else:")
        e.indent()
        e("j = 0")
        _row(e, implicit, False, False, False, load)
        if upd:
            e("for seg in range(3):")
            e.indent()
            e("j_lo = bnd[seg]", "j_hi = bnd[seg + 1]",
              "doA = j_lo < ja - 1  # row j + 1 < ja",
              "doB = j_lo >= j0b - 1  # row j + 1 >= m - jb")
            for k, (doA, doB) in enumerate(((True, True), (True, False), (False, True),
                                            (False, False))):
                cond = {(True, True): "doA and doB", (True, False): "doA",
                        (False, True): "doB", (False, False): None}[(doA, doB)]
                e("else:" if cond is None else ("if " if k == 0 else "elif ") + cond + ":")
                e.indent()
                e("for j in range(j_lo, j_hi):")
                e.indent()
                _row(e, implicit, True, doA, doB, load)
                e.dedent()
                e.dedent()
            e.dedent()
        else:
            e("for j in range(1, m - 2):")
            e.indent()
            _row(e, implicit, False, False, False, load)
            e.dedent()
        e("j = m - 2")
        _row(e, implicit, False, False, False, load, last=1)
        e("j = m - 1")
        _row(e, implicit, False, False, False, load, last=2)
        e.dedent()


def _finals(e: _Emitter, implicit: bool, rows: str, sample: bool, update: bool) -> None:
    """Final values (spike correction) of `rows`, the contact node's, then (update) the
    Newmark update of the same rows (`_updates`)."""
    e(f"for i in {rows}:")
    e.indent()
    e("p = uint64(i) * U16")
    for h, o in HALVES:
        e(f"zf{h} = vload(z, p{o})")
    e("if i < ja:")
    e.indent()
    for h, o in HALVES:
        _correction(e, h, f"p{o}", True, False, "")
    e.dedent()
    e("if i >= j0b:")
    e.indent()
    e("pb = uint64(i - j0b) * U16")
    for h, o in HALVES:
        _correction(e, h, "", False, True, f"pb{o}")
    e.dedent()
    for h, o in HALVES:
        e(f"vstore(z, p{o}, zf{h})")
    e.dedent()
    if implicit:
        e("if mu != 0.0:  # in contact: u0 = 0 exactly", "    z[0] = 0.0")
    else:
        e("z[0] = 0.0  # the massless node has no acceleration")
    if implicit:
        e("u1 = z[0]")
    if update:
        _updates(e, implicit, rows, sample)


def _updates(e: _Emitter, implicit: bool, rows: str, sample: bool, comment: str = "") -> None:
    """The Newmark update (`_update`) of `rows` from their final values in z."""
    e(f"for i in {rows}:{comment}")
    e.indent()
    e("p = uint64(i) * U16")
    for h, o in HALVES:
        e(f"zf{h} = vload(z, p{o})")
        _update(e, implicit, h, f"p{o}", f"xn{h}", sample)
    e.dedent()


def _backward_reduced(e: _Emitter, implicit: bool) -> None:
    e("# backward sweep (rows m-1 .. 0); interface rows kept in ibuf",
      "p = (um - uint64(1)) * U16",
      "y0 = vload(z, p) * vload(invd, p)", "y1 = vload(z, p + U8) * vload(invd, p + U8)",
      "vstore(z, p, y0)", "vstore(z, p + U8, y1)",
      "vstore(ibuf, uint64(32), y0)", "vstore(ibuf, uint64(40), y1)",
      "for _ in range(1, m):")
    e.indent()
    e("pn = p", "p = pn - U16",
      "y0 = vfnma(vload(lo, pn), y0, vload(z, p) * vload(invd, p))",
      "y1 = vfnma(vload(lo, pn + U8), y1, vload(z, p + U8) * vload(invd, p + U8))",
      "vstore(z, p, y0)", "vstore(z, p + U8, y1)")
    e.dedent()
    e("vstore(ibuf, U16, y0)", "vstore(ibuf, uint64(24), y1)",
      "# reduced system: (A, B) = sum over the diagonals of H of diagonal * shifted (s, t)",
      "cA0 = vsplat(0.0)", "cA1 = cA0", "cB0 = cA0", "cB1 = cA0",
      "for kd in range(Dsrc.size):")
    e.indent()
    e("g = uint64(kd) * U16", "src = uint64(Dsrc[kd])", "if Ddst[kd] == 0:",
      "    cA0 = vfma(vload(Dg, g), vload(ibuf, src), cA0)",
      "    cA1 = vfma(vload(Dg, g + U8), vload(ibuf, src + U8), cA1)",
      "else:",
      "    cB0 = vfma(vload(Dg, g), vload(ibuf, src), cB0)",
      "    cB1 = vfma(vload(Dg, g + U8), vload(ibuf, src + U8), cB1)")
    e.dedent()
    if not implicit:
        return
    e("# contact: if the free u0 = x0 < 0, add mu w (w = S^-1 e0) through the spike coefficients",
      "x0 = 0.0", "for kx in range(X0pos.size):", "    x0 += X0val[kx] * ibuf[X0pos[kx]]",
      "mu = -x0 / w0 if x0 < 0.0 else 0.0",
      "if mu != 0.0:")
    e.indent()
    e("muv = vsplat(mu)", "cA0 = vfma(muv, vload(hw, uint64(0)), cA0)",
      "cA1 = vfma(muv, vload(hw, U8), cA1)", "cB0 = vfma(muv, vload(hw, U16), cB0)",
      "cB1 = vfma(muv, vload(hw, uint64(24)), cB1)",
      "vstore(coef, uint64(0), cA0)", "coef[0] -= mu", "cA0 = vload(coef, uint64(0))")
    e.dedent()


_SIGNATURE = """\
@njit(cache=True, fastmath=FASTMATH)
def {name}(bar, lanes, state, coef, ibuf, upd, run, out):
    \"\"\"{doc}\"\"\"
    Md, Me, Kd, Ke, F = bar
    Sd, Slo, SloN, G, has_load, fac, Dg, Dsrc, Ddst, X0pos, X0val, hw, w0 = lanes
    X, Q, z, Vs = state
    u0, k1s, k2s, kvs, sscale, massless = upd
    dt, nsteps, stride, offset = run
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, nodes = fac
    um = uint64(m)
    j0b = m - jb
    ub = uint64(j0b) * U16
    k1 = vsplat(k1s)
    k2 = vsplat(k2s)
    kv = vsplat(kvs)
    idt = 1.0 / dt
    idtv = vsplat(idt)
    # rows 2 .. m-2 of the fused pass in 3 segments, each with fixed spike corrections
    bnd = np.empty(4, np.int64)
    b1 = min(max(ja - 1, 1), m - 2)
    b2 = min(max(j0b - 1, 1), m - 2)
    bnd[0] = 1
    bnd[1] = min(b1, b2)
    bnd[2] = max(b1, b2)
    bnd[3] = m - 2
    min_u0 = u0
    E0 = out.energy[0]
    rM, rK = row_sums(Md, Me), row_sums(Kd, Ke)  # energy coefficients, once per run
    en = EnergyRows(rM, Me, rK, Ke, F, offset)
    k = 1
"""

_DOC_ARGS = """
    bar: the `Bar` (node order); lanes: the `LaneOps`; state: the `XQState` (interleaved);
    coef, ibuf: scratch (2 L + 1 and 4 L); upd: the `XQCoef` (k1s, k2s, kvs its k1, k2,
    kv); run: the `Run`; out: the `Samples` (sample 0 written).
    """
_DOC_IMPLICIT = """Implicit Newmark, state (X, Q), see the module docstring.

    k1s, k2s, kvs = (gamma + 1/2 - beta) / beta, 1 / beta, gamma / (beta dt); the contact
    stress is -mu sscale, sscale = 1 / (beta dt^2).
""" + _DOC_ARGS
_DOC_EXPLICIT = """Central differences, massless contact node, state (X, Q): see the module doc.

    k1s, k2s, kvs = gamma + 1/2, 1, gamma / dt.
""" + _DOC_ARGS


def _kernel(e: _Emitter, implicit: bool) -> None:
    name = "implicit_kernel" if implicit else "explicit_kernel"
    doc = _DOC_IMPLICIT if implicit else _DOC_EXPLICIT
    e(*_SIGNATURE.format(name=name, doc=doc).splitlines())
    e.indent()
    e("unfused = True  # the forward pass of this step is still to do (first step, after a sample)",
      "for step in range(1, nsteps + 1):")
    e.indent()
    e("if unfused:")
    e.indent()
    if not implicit:
        e("lam = eliminate_contact_node(Kd, Ke, F, X, 16)  # node 1 is at position 16")
    _pass_a(e, implicit, False)
    e.dedent()
    if not implicit:
        e("u1 = X[0]  # u0 of this step, eliminated before the solve")
    _backward_reduced(e, implicit)
    e("sample = step % stride == 0 or step == nsteps", "if not sample:")
    e.indent()
    e("# rows 0, 1 and m-1 first: the fused pass reads them across lanes and rows")
    _finals(e, implicit, "(0, 1, m - 1)", False, True)
    e.dedent()
    e("else:")
    e.indent()
    _finals(e, implicit, "range(m)", True, implicit)
    if not implicit:
        e("for i in range(m):")
        e.indent()
        e("p = uint64(i) * U16")
        for _, o in HALVES:
            e(f"vstore(Vs, p{o}, vfma(kv, vload(z, p{o}), vload(Q, p{o}) * idtv))")
        e.dedent()
    e.dedent()
    # the massless contact node: backward-difference velocity, no acceleration
    if implicit:
        e("if massless:")
        e.indent()
        e("X[0] = 2.0 * u1 - u0", "Q[0] = u1 - u0", "Vs[0] = (u1 - u0) * idt")
        e.dedent()
    else:
        e("Vs[0] = (u1 - u0) * idt", "v0 = u1 - u0")
    e("u0 = u1", "if u1 < min_u0:", "    min_u0 = u1", "unfused = sample", "if not sample:")
    e.indent()
    if not implicit:
        e("Q[0] = v0", "lam = eliminate_contact_node(Kd, Ke, F, X, 16)")
    _pass_a(e, implicit, True)
    e.dedent()
    e("else:")
    e.indent()
    stress = "-mu * sscale" if implicit else "-lam"
    Xs = "z" if implicit else "X"
    e(f"energy = record_lane_sample(k, step * dt, nodes, {Xs}, Vs, {stress}, en, out)",
      "k += 1", "if blown_up(energy, E0):", "    return k, step, min_u0, step")
    if not implicit:
        _updates(e, False, "range(m)", False, "  # the update, after the sample of U1")
        e("Q[0] = v0")
    e.dedent()
    e.dedent()
    e("return k, nsteps, min_u0, -1")
    e.dedent()


_HEADER = '''\
"""GENERATED by `python -m contact_bench.kernels.newmark_codegen`: do not edit, edit the generator.

Vector Newmark kernels in the lane-interleaved layout of `contact_bench.core.spike` (16
lanes, one row of all lanes = two `<8 x double>` values of `contact_bench.core.simd`), for
`contact_bench.kernels.newmark`.

State (X, Q): X the predictor of the next step's solve (implicit: U~ = U + dt V +
(1/2 - beta) dt^2 A; explicit: U + dt V + dt^2 / 2 A, whose nodes 1.. are the next U),
Q = dt V + dt^2 (1 - gamma) A. The solve gives z = U1 (implicit) or z = dt^2 A1
(explicit, the system is M_r z = dt^2 (F - K X)); with d = beta dt^2 A1 = z - X
(implicit) or d = z (explicit), one Newmark step is
    X <- z + Q + k1 d (implicit) or X + Q + k1 d (explicit),  Q <- Q + k2 d,
and V = Q / dt + kv d. Per step:
- backward sweep, rows m-1 .. 0, the recurrence in registers; the interface rows go
  to ibuf and the reduced system (the diagonals of H) gives the spike coefficients;
- implicit: the contact (x0 < 0: add mu w through the coefficients);
- rows 0, 1 and m-1: spike correction and update (the next pass reads them across
  lanes); explicit: the contact node is eliminated (u0 = max(0, ...)) from node 1;
- one fused pass over rows: final value and update of row j + 1, then the next step's
  right-hand side G + S X and forward-sweep step of row j; the rows that need a spike
  correction are separate loops (segments), with or without the load G.
Sample steps take an unfused path that also forms V and records the sample.
Needs m >= 3 rows (`spike_factor(..., min_rows=3)`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, uint64

from contact_bench.core.config import FASTMATH
from contact_bench.core.sampling import EnergyRows, blown_up, row_sums
from contact_bench.core.simd import vfma, vfnma, vload, vsplat, vstore
from contact_bench.core.spike import SpikeFactors, record_lane_sample
from contact_bench.core.tridiag import eliminate_contact_node


class LaneOps(NamedTuple):
    """What the vector kernels read besides the bar: the interleaved T = (Sd, Slo) of S X
    (SloN: row 0's lower band of the next lane, for row m-1) and the load G (has_load:
    G is not zero), S's SPIKE factors fac, the reduced-system map as vector diagonals
    (Dg, Dsrc, Ddst) and its x[0] row (X0pos, X0val) (`newmark.h_diagonals`), and the
    contact's response: hw, the (A, B) coefficients of S^-1 e0, and w0 = (S^-1)[0, 0]."""

    Sd: np.ndarray
    Slo: np.ndarray
    SloN: np.ndarray
    G: np.ndarray
    has_load: bool
    fac: SpikeFactors
    Dg: np.ndarray
    Dsrc: np.ndarray
    Ddst: np.ndarray
    X0pos: np.ndarray
    X0val: np.ndarray
    hw: np.ndarray
    w0: float

U8 = uint64(8)
U16 = uint64(16)
'''


def source() -> str:
    """The text of `bench/kernels/newmark_vec.py`."""
    out = [_HEADER]
    for implicit in (True, False):
        e = _Emitter()
        _kernel(e, implicit)
        out.append("\n\n" + e.text())
    return "".join(out)


def main(argv: list[str]) -> int:
    text = source()
    if argv == ["--check"]:
        ok = TARGET.exists() and TARGET.read_text() == text
        print(f"{TARGET} is {'up to date' if ok else 'OUT OF DATE'}")
        return 0 if ok else 1
    TARGET.write_text(text)
    print(f"wrote {TARGET}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
