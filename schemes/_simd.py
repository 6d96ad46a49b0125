"""Explicit 8 x double vectors for numba: a numba type wrapping LLVM's <8 x double>.

Used by the generated Newmark kernels (`schemes._newmark_vec`). A value of this type
lives in registers, so a loop-carried vector (the forward and backward sweeps of a
tridiagonal solve, 16 lanes = two vectors) is a register recurrence instead of a chain
of stores and reloads through memory, which is what numba's auto-vectorised loops give.

- vload(a, i) / vstore(a, i, v): the 8 doubles a[i : i + 8] (unaligned allowed);
- vsplat(x): x in all 8 elements;
- vfma(a, b, c) = a * b + c and vfnma(a, b, c) = c - a * b, each rounded once;
- +, -, * between two vectors, element by element (IEEE, no reassociation).

Indices are unsigned (uint64), like the scalar kernels of `schemes._spike`.

Added for the error norms (`bench.metrics`), at the end of the module: vloadc (vload
checked at typing: a C-contiguous float64 array of any dimension, flat index) and a
4 x double type F64x4 (the 4 quadrature points of an element) with v4load, v4bcast (one
double in the 4 elements: an AVX-512 broadcast memory operand of the arithmetic),
v4splat, v4hsum (horizontal sum in a fixed order) and +, -, * (IEEE, no fma).
"""

from __future__ import annotations

import operator

from llvmlite import ir
from numba import types
from numba.core import cgutils, errors
from numba.extending import intrinsic, models, overload, register_model

_V = ir.VectorType(ir.DoubleType(), 8)


class F64x8(types.Type):
    """numba type of a <8 x double> value."""

    def __init__(self) -> None:
        super().__init__(name="F64x8")


f64x8 = F64x8()


@register_model(F64x8)
class _F64x8Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _V)


def _ptr(context, builder, aryty, ary, idx, idxty):
    arr = context.make_array(aryty)(context, builder, ary)
    i = context.cast(builder, idx, idxty, types.uint64)
    p = builder.gep(arr.data, [i], inbounds=True)
    return builder.bitcast(p, _V.as_pointer())


@intrinsic
def vload(typingctx, a, i):
    """The 8 doubles a[i : i + 8]."""
    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        return builder.load(p, align=8)
    return f64x8(a, i), codegen


@intrinsic
def vstore(typingctx, a, i, v):
    """a[i : i + 8] = v."""
    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        builder.store(args[2], p, align=8)
        return context.get_dummy_value()
    return types.none(a, i, v), codegen


@intrinsic
def vsplat(typingctx, x):
    """x in all 8 elements."""
    def codegen(context, builder, sig, args):
        x = context.cast(builder, args[0], sig.args[0], types.float64)
        v = ir.Constant(_V, ir.Undefined)
        v = builder.insert_element(v, x, ir.Constant(ir.IntType(32), 0))
        return builder.shuffle_vector(v, v, ir.Constant(ir.VectorType(ir.IntType(32), 8), [0] * 8))
    return f64x8(x), codegen


def _fma(builder, a, b, c):
    fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_V, [_V, _V, _V]),
                                        "llvm.fma.v8f64")
    return builder.call(fn, [a, b, c])


@intrinsic
def vfma(typingctx, a, b, c):
    """a * b + c, rounded once."""
    def codegen(context, builder, sig, args):
        return _fma(builder, *args)
    return f64x8(a, b, c), codegen


@intrinsic
def vfnma(typingctx, a, b, c):
    """c - a * b, rounded once."""
    def codegen(context, builder, sig, args):
        return _fma(builder, builder.fneg(args[0]), args[1], args[2])
    return f64x8(a, b, c), codegen


def _register_arithmetic(vtype: types.Type) -> None:
    """+, -, * between two values of the vector type vtype, element by element."""
    def binop(name: str):
        @intrinsic
        def f(typingctx, a, b):
            def codegen(context, builder, sig, args):
                return getattr(builder, name)(args[0], args[1])
            return vtype(a, b), codegen
        return f

    def register(op, f) -> None:
        @overload(op)
        def ov(a, b):
            if a == vtype and b == vtype:
                return lambda a, b: f(a, b)

    for op, name in ((operator.add, "fadd"), (operator.sub, "fsub"), (operator.mul, "fmul")):
        register(op, binop(name))


_register_arithmetic(f64x8)


# ---------------------------------------------------------------------------------------
# Added for the error norms (`bench.metrics`). The loads check their array at typing: a
# C-contiguous float64 array of any dimension, indexed flat (a[i] is a.reshape(-1)[i]);
# for any other array the flat index would not be the memory offset.
_V4 = ir.VectorType(ir.DoubleType(), 4)
_I32 = ir.IntType(32)


def _mask(*lanes: int) -> ir.Constant:
    return ir.Constant(ir.VectorType(_I32, len(lanes)), list(lanes))


def _check_flat(a, i, name: str) -> None:
    if not (isinstance(a, types.Array) and a.layout == "C" and a.dtype == types.float64):
        raise errors.TypingError(f"{name}: a C-contiguous float64 array is needed, got {a}")
    if not isinstance(i, types.Integer):
        raise errors.TypingError(f"{name}: an integer index is needed, got {i}")


@intrinsic
def vloadc(typingctx, a, i):
    """The 8 doubles a.reshape(-1)[i : i + 8] of a C-contiguous float64 array."""
    _check_flat(a, i, "vloadc")

    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        return builder.load(p, align=8)
    return f64x8(a, i), codegen


class F64x4(types.Type):
    """numba type of a <4 x double> value."""

    def __init__(self) -> None:
        super().__init__(name="F64x4")


f64x4 = F64x4()


@register_model(F64x4)
class _F64x4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, _V4)


def _dptr(context, builder, sig, args):
    """Address of a.reshape(-1)[i] as a double*."""
    p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
    return builder.bitcast(p, ir.DoubleType().as_pointer())


@intrinsic
def v4load(typingctx, a, i):
    """The 4 doubles a.reshape(-1)[i : i + 4] of a C-contiguous float64 array."""
    _check_flat(a, i, "v4load")

    def codegen(context, builder, sig, args):
        p = builder.bitcast(_dptr(context, builder, sig, args), _V4.as_pointer())
        return builder.load(p, align=8)
    return f64x4(a, i), codegen


def _splat4(builder, x):
    v = builder.insert_element(ir.Constant(_V4, ir.Undefined), x, ir.Constant(_I32, 0))
    return builder.shuffle_vector(v, v, _mask(0, 0, 0, 0))


@intrinsic
def v4bcast(typingctx, a, i):
    """a.reshape(-1)[i] in the 4 elements (C-contiguous float64 array). Used by one
    operation, the load becomes its broadcast memory operand (AVX-512): no shuffle."""
    _check_flat(a, i, "v4bcast")

    def codegen(context, builder, sig, args):
        return _splat4(builder, builder.load(_dptr(context, builder, sig, args), align=8))
    return f64x4(a, i), codegen


@intrinsic
def v4splat(typingctx, x):
    """x in the 4 elements."""
    def codegen(context, builder, sig, args):
        return _splat4(builder, context.cast(builder, args[0], sig.args[0], types.float64))
    return f64x4(x), codegen


@intrinsic
def v4hsum(typingctx, v):
    """(v0 + v1) + (v2 + v3) (IEEE, in this order)."""
    if not isinstance(v, F64x4):
        raise errors.TypingError(f"v4hsum: an F64x4 is needed, got {v}")

    def codegen(context, builder, sig, args):
        (x,) = args
        q = builder.fadd(builder.shuffle_vector(x, x, _mask(0, 2)),
                         builder.shuffle_vector(x, x, _mask(1, 3)))
        return builder.fadd(builder.extract_element(q, ir.Constant(_I32, 0)),
                            builder.extract_element(q, ir.Constant(_I32, 1)))
    return types.float64(v), codegen


_register_arithmetic(f64x4)

