"""Sampling, discrete energy and the blow-up rule, shared by every stepping kernel.

A kernel keeps a sample every `stride` steps and at the last step (`is_sample`), writes
it with `record_sample`, and stops at the first step whose energy is not finite or
exceeds `BLOWUP_FACTOR` times |E(0)| (`blown_up`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contact_bench.core.tridiag import QUAD_BLOCK, tri_quad

BLOWUP_FACTOR = 1e3  # energy above this multiple of E(0) counts as a blow-up


@njit(cache=True)
def energy_of(Md, Me, Kd, Ke, F, U, V, offset):
    """1/2 V.M.V + 1/2 U.K.U - F.U + offset.

    The quadratic forms by `tri_quad` (strain energy from element differences, no
    cancellation), F.U in blocks of QUAD_BLOCK terms, four interleaved partial sums
    each: digits do not fade as the mesh grows."""
    n = U.size
    s = 0.0
    i = 0
    while i < n:
        end = min(i + QUAD_BLOCK, n)
        s0 = s1 = s2 = s3 = 0.0
        while i + 4 <= end:
            s0 += F[i] * U[i]
            s1 += F[i + 1] * U[i + 1]
            s2 += F[i + 2] * U[i + 2]
            s3 += F[i + 3] * U[i + 3]
            i += 4
        while i < end:
            s0 += F[i] * U[i]
            i += 1
        s += (s0 + s1) + (s2 + s3)
    return 0.5 * tri_quad(Md, Me, V) + 0.5 * tri_quad(Kd, Ke, U) - s + offset


@njit(cache=True)
def record_sample(k, t, U, V, stress, energy, t_out, U_out, V_out, cu_out, s_out, E_out):
    """Write sample k: time, nodal U and V, u(0, t), contact stress, energy."""
    t_out[k] = t
    U_out[k, :] = U
    V_out[k, :] = V
    cu_out[k] = U[0]
    s_out[k] = stress
    E_out[k] = energy


@njit(cache=True)
def is_sample(step, nsteps, stride):
    return step % stride == 0 or step == nsteps


@njit(cache=True)
def blown_up(energy, energy0):
    if not np.isfinite(energy):
        return True
    return abs(energy) > BLOWUP_FACTOR * max(abs(energy0), 1e-300)


def n_samples(nsteps: int, stride: int) -> int:
    return nsteps // stride + 1 + (1 if nsteps % stride else 0)
