"""Prototype: implicit Newmark step (beta = 1/4, gamma = 1/2) in register-carried vector passes.

State (Ut, Q), Q = dt V + dt^2 (1 - gamma) A. Per step:
  pass B (rows m-1 .. 0): backward sweep, recurrence in zmm registers (simd.F64x8)
  reduced system (as vector diagonals of H) + contact
  pass A (rows 0 .. m-1): spike correction + Newmark update of row j+1 (step n) fused with
          the right-hand side M Ut + bF and forward sweep of row j (step n+1)
Sample steps take an unfused path (final z and V stored for record_lane_sample).

Compared with a plain numba version:
- one generated kernel (no array passed to a helper inside the step loop: numba increfs
  arrays on calls, and inlined helpers leave NRT calls in the hot loop); its source (SRC)
  is built as a string and exec'd at import -- no file is written
  (`python newmark_b.py` prints it),
- pass A split into branch-free row ranges (A correction / none / B correction / both),
- F = 0 skips the load vector (flag `has_load`, a separate loop version),
- the reduced system as diagonals of H (vector FMAs on shifted interface values),
- all vector arrays 64-byte aligned (`aligned`).
Needs m >= 3 lane rows (n >= 33 free dofs). Not wired into schemes/: see README.md.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # repo root (bench, schemes)

import numpy as np
from numba import njit, uint64
from simd import vfma, vfnma, vload, vsplat, vstore

from schemes._common import allocate, blown_up, energy_of, initial_acceleration, trajectory
from schemes._spike import L, record_lane_sample, spike_factor

_FM = {"contract"}
U8 = uint64(8)
U16 = uint64(16)


def _row_code(ind, doA, doB, upd, has_load, last=0):
    """source of one iteration j (stencil+forward of row j, update of row i = j+1).
    last: 0 generic, 1 j = m-2 (row m-1 already updated), 2 j = m-1 (wraps to row 0)."""
    s = []
    a = s.append
    a("p = uint64(j) * U16")
    a("pn = p + U16")
    for h, hs in ((0, ""), (1, " + U8")):
        if last == 2:
            a(f"mp{h} = vload(MloN, uint64({8*h}))")
            a(f"xp{h} = vload(Ut, uint64({1 + 8*h}))")
            continue
        a(f"mp{h} = vload(Mlo, pn{hs})")
        if upd and last == 0:
            a(f"zf{h} = vload(z, pn{hs})")
            if doA:
                a(f"zf{h} = vfnma(cA{h}, vload(sa, pn{hs}), zf{h})")
            if doB:
                a(f"zf{h} = vfnma(cB{h}, vload(sb, pn - ub{hs}), zf{h})")
            a(f"uu{h} = vload(Ut, pn{hs})")
            a(f"q{h} = vload(Q, pn{hs})")
            a(f"d{h} = zf{h} - uu{h}")
            a(f"xp{h} = vfma(k1, d{h}, zf{h} + q{h})")
            a(f"vstore(Ut, pn{hs}, xp{h})")
            a(f"vstore(Q, pn{hs}, vfma(k2, d{h}, q{h}))")
        else:
            a(f"xp{h} = vload(Ut, pn{hs})")
    for h, hs in ((0, ""), (1, " + U8")):
        a(f"r{h} = vfma(mp{h}, xp{h}, vfma(ml{h}, xm{h}, vload(Mdl, p{hs}) * x0{h}))")
        if has_load:
            a(f"r{h} = vload(bF, p{hs}) + r{h}")
        a(f"y{h} = vfnma(vload(lo, p{hs}), y{h}, r{h})")
        a(f"vstore(z, p{hs}, y{h})")
    a("xm0, xm1, x00, x01, ml0, ml1 = x00, x01, xp0, xp1, mp0, mp1")
    return "".join(" " * ind + x + "\n" for x in s)


def _pass_a_code(ind, upd):
    """pass A for both has_load variants; rows 0 and m-1 are updated before (upd)."""
    out = []
    sp = " " * ind
    out.append(sp + "ub = uint64(j0b) * U16\n")
    out.append(sp + "xm0 = vload(Ut, (um - uint64(1)) * U16 - uint64(1))\n")
    out.append(sp + "xm1 = vload(Ut, (um - uint64(1)) * U16 + uint64(7))\n")
    out.append(sp + "x00 = vload(Ut, uint64(0))\nx01 = vload(Ut, U8)\n".replace("\n", "\n" + sp, 1))
    out.append(sp + "ml0 = vload(Mlo, uint64(0))\n" + sp + "ml1 = vload(Mlo, U8)\n")
    out.append(sp + "y0 = vsplat(0.0)\n" + sp + "y1 = vsplat(0.0)\n")
    for hl in (True, False):
        out.append(sp + ("if has_load:\n" if hl else "else:\n"))
        i2 = ind + 4
        s2 = " " * i2
        if upd:
            # segments of j in [0, m-2): flags constant within [b[k], b[k+1])
            out.append(s2 + "for seg in range(3):\n")
            s3 = " " * (i2 + 4)
            out.append(s3 + "j_lo = bnd[seg]\n" + s3 + "j_hi = bnd[seg + 1]\n")
            out.append(s3 + "doA = j_lo < ja - 1\n" + s3 + "doB = j_lo >= j0b - 1\n")
            first = True
            for doA, doB in ((True, True), (True, False), (False, True), (False, False)):
                cond = f"doA == {doA} and doB == {doB}"
                out.append(s3 + ("if " if first else "elif ") + cond + ":\n")
                first = False
                out.append(" " * (i2 + 8) + "for j in range(j_lo, j_hi):\n")
                out.append(_row_code(i2 + 12, doA, doB, True, hl))
        else:
            out.append(s2 + "for j in range(0, m - 2):\n")
            out.append(_row_code(i2 + 4, False, False, False, hl))
        out.append(s2 + "j = m - 2\n")
        out.append(_row_code(i2, False, False, False, hl, last=1))
        out.append(s2 + "j = m - 1\n")
        out.append(_row_code(i2, False, False, False, hl, last=2))
    return "".join(out)


_KERNEL = '''
def kernel_b(Md, Me, Kd, Ke, F, Mdl, Mlo, MloN, bF, has_load, fac, Dg, Dsrc, Ddst, X0pos, X0val,
             hw, w0, Ut, Q, z, Vs, coef, ibuf, u0, dt, beta, gamma, massless, nsteps, stride,
             offset, t_out, U_out, V_out, cu_out, s_out, E_out):
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, pos = fac
    um = uint64(m)
    j0b = m - jb
    ibdt2 = 1.0 / (beta * dt * dt)
    k1 = vsplat((gamma + 0.5 - beta) / beta)
    k2 = vsplat(1.0 / beta)
    idt = 1.0 / dt
    idtv = vsplat(idt)
    kv = vsplat(dt * gamma * ibdt2)
    # segment bounds of the fused pass over j in [0, m-2): i = j+1 < ja <=> j < ja-1
    bnd = np.empty(4, np.int64)
    b1 = min(max(ja - 1, 0), m - 2)
    b2 = min(max(j0b - 1, 0), m - 2)
    bnd[0] = 0
    bnd[1] = min(b1, b2)
    bnd[2] = max(b1, b2)
    bnd[3] = m - 2
    nd = Dsrc.size
    min_u0 = u0
    E0 = E_out[0]
    k = 1
    cA0 = vsplat(0.0)
    cA1 = cA0
    cB0 = cA0
    cB1 = cA0
PASS_A_FWD
    for step in range(1, nsteps + 1):
        # pass B: backward sweep
        p = (um - uint64(1)) * U16
        y0 = vload(z, p) * vload(invd, p)
        y1 = vload(z, p + U8) * vload(invd, p + U8)
        vstore(z, p, y0)
        vstore(z, p + U8, y1)
        vstore(ibuf, uint64(32), y0)
        vstore(ibuf, uint64(40), y1)
        for qq in range(1, m):
            pn = p
            p = pn - U16
            y0 = vfnma(vload(lo, pn), y0, vload(z, p) * vload(invd, p))
            y1 = vfnma(vload(lo, pn + U8), y1, vload(z, p + U8) * vload(invd, p + U8))
            vstore(z, p, y0)
            vstore(z, p + U8, y1)
        vstore(ibuf, U16, y0)
        vstore(ibuf, uint64(24), y1)
        # reduced system: (A, B) = sum over diagonals of H of diag * shifted (s, t)
        cA0 = vsplat(0.0)
        cA1 = cA0
        cB0 = cA0
        cB1 = cA0
        for kd in range(nd):
            g = uint64(kd) * U16
            src = uint64(Dsrc[kd])
            if Ddst[kd] == 0:
                cA0 = vfma(vload(Dg, g), vload(ibuf, src), cA0)
                cA1 = vfma(vload(Dg, g + U8), vload(ibuf, src + U8), cA1)
            else:
                cB0 = vfma(vload(Dg, g), vload(ibuf, src), cB0)
                cB1 = vfma(vload(Dg, g + U8), vload(ibuf, src + U8), cB1)
        x0 = 0.0
        for kx in range(X0pos.size):
            x0 += X0val[kx] * ibuf[X0pos[kx]]
        mu = -x0 / w0 if x0 < 0.0 else 0.0
        if mu != 0.0:
            muv = vsplat(mu)
            cA0 = vfma(muv, vload(hw, uint64(0)), cA0)
            cA1 = vfma(muv, vload(hw, U8), cA1)
            cB0 = vfma(muv, vload(hw, U16), cB0)
            cB1 = vfma(muv, vload(hw, uint64(24)), cB1)
            vstore(coef, uint64(0), cA0)
            coef[0] -= mu
            cA0 = vload(coef, uint64(0))
        sample = step % stride == 0 or step == nsteps
        if not sample:
            # rows 0 and m-1: final z, update (they feed the wrapped stencil rows)
            for i in (0, m - 1):
                p = uint64(i) * U16
                zf0 = vload(z, p)
                zf1 = vload(z, p + U8)
                if i < ja:
                    zf0 = vfnma(cA0, vload(sa, p), zf0)
                    zf1 = vfnma(cA1, vload(sa, p + U8), zf1)
                if i >= j0b:
                    pb = uint64(i - j0b) * U16
                    zf0 = vfnma(cB0, vload(sb, pb), zf0)
                    zf1 = vfnma(cB1, vload(sb, pb + U8), zf1)
                vstore(z, p, zf0)
                vstore(z, p + U8, zf1)
            if mu != 0.0:
                z[0] = 0.0
            for i in (0, m - 1):
                p = uint64(i) * U16
                zf0 = vload(z, p)
                zf1 = vload(z, p + U8)
                u_0 = vload(Ut, p)
                u_1 = vload(Ut, p + U8)
                q0 = vload(Q, p)
                q1 = vload(Q, p + U8)
                d0 = zf0 - u_0
                d1 = zf1 - u_1
                vstore(Ut, p, vfma(k1, d0, zf0 + q0))
                vstore(Ut, p + U8, vfma(k1, d1, zf1 + q1))
                vstore(Q, p, vfma(k2, d0, q0))
                vstore(Q, p + U8, vfma(k2, d1, q1))
            u1 = z[0]
        else:
            for i in range(m):
                p = uint64(i) * U16
                zf0 = vload(z, p)
                zf1 = vload(z, p + U8)
                if i < ja:
                    zf0 = vfnma(cA0, vload(sa, p), zf0)
                    zf1 = vfnma(cA1, vload(sa, p + U8), zf1)
                if i >= j0b:
                    pb = uint64(i - j0b) * U16
                    zf0 = vfnma(cB0, vload(sb, pb), zf0)
                    zf1 = vfnma(cB1, vload(sb, pb + U8), zf1)
                vstore(z, p, zf0)
                vstore(z, p + U8, zf1)
            if mu != 0.0:
                z[0] = 0.0
            u1 = z[0]
            for i in range(m):
                p = uint64(i) * U16
                zf0 = vload(z, p)
                zf1 = vload(z, p + U8)
                u_0 = vload(Ut, p)
                u_1 = vload(Ut, p + U8)
                q0 = vload(Q, p)
                q1 = vload(Q, p + U8)
                d0 = zf0 - u_0
                d1 = zf1 - u_1
                vstore(Vs, p, vfma(kv, d0, q0 * idtv))
                vstore(Vs, p + U8, vfma(kv, d1, q1 * idtv))
                vstore(Ut, p, vfma(k1, d0, zf0 + q0))
                vstore(Ut, p + U8, vfma(k1, d1, zf1 + q1))
                vstore(Q, p, vfma(k2, d0, q0))
                vstore(Q, p + U8, vfma(k2, d1, q1))
        if massless:
            Ut[0] = 2.0 * u1 - u0
            Q[0] = u1 - u0
            Vs[0] = (u1 - u0) * idt
        u0 = u1
        if u1 < min_u0:
            min_u0 = u1
        if not sample:
PASS_A_UPD
        else:
            energy = record_lane_sample(k, step * dt, pos, z, Vs, -mu * ibdt2, Md, Me, Kd, Ke,
                                        F, offset, t_out, U_out, V_out, cu_out, s_out, E_out)
            k += 1
            if blown_up(energy, E0):
                return k, step, min_u0, step
            if step < nsteps:
PASS_A_FWD2
    return k, nsteps, min_u0, -1
'''

SRC = (_KERNEL.replace("PASS_A_FWD2\n", _pass_a_code(16, False))
       .replace("PASS_A_FWD\n", _pass_a_code(4, False))
       .replace("PASS_A_UPD\n", _pass_a_code(12, True)))
_g = dict(np=np, uint64=uint64, U8=U8, U16=U16, vload=vload, vstore=vstore, vfma=vfma,
          vfnma=vfnma, vsplat=vsplat, record_lane_sample=record_lane_sample, blown_up=blown_up)
exec(compile(SRC, "<kernel_b>", "exec"), _g)
kernel_b = njit(fastmath=_FM)(_g["kernel_b"])
kernel_a = kernel_b


def aligned(x, align=64):
    """copy of x (float64) whose data starts on an `align`-byte boundary."""
    x = np.asarray(x, float)
    buf = np.empty(x.size + align // 8)
    off = (-buf.ctypes.data % align) // 8
    out = buf[off:off + x.size]
    out[:] = x
    return out


def h_diagonals(sp, tol=0.0):
    """H (from the Spike triplets) as diagonals: rows 0..15 -> A, 16..31 -> B; columns
    s (lanes 0..15, ibuf[16:32]) and t (ibuf[32:48]); row 2L (x0) kept as triplets."""
    m = sp.m
    rows = sp.Hrow
    cols = np.where(sp.Hpos < L, sp.Hpos, sp.Hpos - (m - 1) * L + L)
    keys = {}
    x0pos, x0val = [], []
    for r, c, v in zip(rows, cols, sp.Hval, strict=True):
        if r == 2 * L:
            x0pos.append(16 + c)
            x0val.append(v)
            continue
        ob, lane = divmod(r, L)
        ib, cl = divmod(c, L)
        d = cl - lane
        key = (ob, ib, d)
        keys.setdefault(key, np.zeros(L))[lane] = v
    ks = sorted(keys)
    Dg = np.concatenate([keys[k] for k in ks]) if ks else np.zeros(0)
    Dsrc = np.array([16 + 16 * ib + d for (ob, ib, d) in ks], np.int64)
    Ddst = np.array([ob for (ob, ib, d) in ks], np.int64)
    return Dg, Dsrc, Ddst, np.array(x0pos, np.int64), np.array(x0val)


def setup_a(semi, dt, nsteps, stride, beta=0.25, gamma=0.5, align=True, force_load=False):
    al = aligned if align else (lambda x: np.array(x, float))
    M, K = semi.M, semi.K
    U, V = semi.U0, semi.V0
    out = allocate(semi, nsteps, stride)
    out["U"][0], out["V"][0], out["cu"][0] = U, V, U[0]
    out["E"][0] = energy_of(M.diag, M.off, K.diag, K.off, semi.F, U, V, semi.energy_offset)
    bufs = (out["t"], out["U"], out["V"], out["cu"], out["s"], out["E"])
    bdt2 = beta * dt * dt
    sp = spike_factor(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
    assert sp.m >= 3
    A = initial_acceleration(semi)
    Ut = al(sp.to_lanes(U + dt * V + (0.5 - beta) * dt * dt * A))
    Q = al(sp.to_lanes(dt * V + dt * dt * (1.0 - gamma) * A))
    Mlo = sp.lower_to_lanes(M.off)
    MloN = np.zeros(L)
    MloN[:L - 1] = Mlo[1:L]
    has_load = bool(np.any(semi.F)) or force_load
    bF = sp.to_lanes(bdt2 * semi.F)
    lo, invd, sa, sb, Hrow, Hpos, Hval, ja, jb, m, pos = sp.factors()
    fac = (al(lo), al(invd), al(sa), al(sb), Hrow, Hpos, Hval, ja, jb, m, pos)
    Dg, Dsrc, Ddst, X0pos, X0val = h_diagonals(sp)
    N = L * sp.m
    args = (M.diag, M.off, K.diag, K.off, semi.F, al(sp.to_lanes(M.diag)), al(Mlo), al(MloN),
            al(bF), has_load, fac, al(Dg), Dsrc, Ddst, X0pos, X0val, al(sp.hw), sp.w0, Ut, Q,
            al(np.zeros(N)), al(np.zeros(N)), al(np.zeros(2 * L + 1)), al(np.zeros(4 * L)),
            float(U[0]), dt, beta, gamma, bool(semi.massless), int(nsteps), int(stride),
            semi.energy_offset, *bufs)
    return args, out


def run_a(semi, dt, nsteps, stride, beta=0.25, gamma=0.5, align=True):
    args, out = setup_a(semi, dt, nsteps, stride, beta, gamma, align)
    k, done, min_u0, blow = kernel_b(*args)
    return trajectory(out, k, done, min_u0, blow, dt)


if __name__ == "__main__":
    sys.stdout.write(SRC)
