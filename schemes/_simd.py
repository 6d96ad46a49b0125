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
"""

from __future__ import annotations

import operator

from llvmlite import ir
from numba import types
from numba.core import cgutils
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


def _binop(name: str):
    @intrinsic
    def f(typingctx, a, b):
        def codegen(context, builder, sig, args):
            return getattr(builder, name)(args[0], args[1])
        return f64x8(a, b), codegen
    return f


def _register(op, f) -> None:
    @overload(op)
    def ov(a, b):
        if isinstance(a, F64x8) and isinstance(b, F64x8):
            return lambda a, b: f(a, b)


for _op, _name in ((operator.add, "fadd"), (operator.sub, "fsub"), (operator.mul, "fmul")):
    _register(_op, _binop(_name))
