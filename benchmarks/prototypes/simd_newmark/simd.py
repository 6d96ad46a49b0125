"""Explicit 8 x double vectors for numba (a numba type wrapping LLVM's <8 x double>).

vload(a, i) / vstore(a, i, v): 8 consecutive doubles at a[i] (unaligned allowed);
vfma(a, b, c) = a*b + c (one rounding), vfnma(a, b, c) = c - a*b (one rounding);
+, -, * on vectors; vsplat(x) broadcasts a scalar. Values live in registers, so a
loop-carried vector is a register recurrence (no store-to-load forwarding).
"""
import operator

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, models, overload, register_model

_V = ir.VectorType(ir.DoubleType(), 8)


class F64x8(types.Type):
    def __init__(self):
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
    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        return builder.load(p, align=8)
    return f64x8(a, i), codegen


@intrinsic
def vloada(typingctx, a, i):
    """vload with a 64-byte alignment promise."""
    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        return builder.load(p, align=64)
    return f64x8(a, i), codegen


@intrinsic
def vstore(typingctx, a, i, v):
    def codegen(context, builder, sig, args):
        p = _ptr(context, builder, sig.args[0], args[0], args[1], sig.args[1])
        builder.store(args[2], p, align=8)
        return context.get_dummy_value()
    return types.none(a, i, v), codegen


@intrinsic
def vsplat(typingctx, x):
    def codegen(context, builder, sig, args):
        x = context.cast(builder, args[0], sig.args[0], types.float64)
        v = ir.Constant(_V, ir.Undefined)
        v = builder.insert_element(v, x, ir.Constant(ir.IntType(32), 0))
        return builder.shuffle_vector(v, v, ir.Constant(ir.VectorType(ir.IntType(32), 8), [0] * 8))
    return f64x8(x), codegen


@intrinsic
def vget(typingctx, v, k):
    def codegen(context, builder, sig, args):
        k = context.cast(builder, args[1], sig.args[1], types.int32)
        return builder.extract_element(args[0], k)
    return types.float64(v, k), codegen


def _fma(builder, a, b, c):
    mod = builder.module
    fn = cgutils.get_or_insert_function(mod, ir.FunctionType(_V, [_V, _V, _V]), "llvm.fma.v8f64")
    return builder.call(fn, [a, b, c])


@intrinsic
def vfma(typingctx, a, b, c):
    def codegen(context, builder, sig, args):
        return _fma(builder, *args)
    return f64x8(a, b, c), codegen


@intrinsic
def vfnma(typingctx, a, b, c):
    def codegen(context, builder, sig, args):
        return _fma(builder, builder.fneg(args[0]), args[1], args[2])
    return f64x8(a, b, c), codegen


def _binop(name):
    @intrinsic
    def f(typingctx, a, b):
        def codegen(context, builder, sig, args):
            return getattr(builder, name)(args[0], args[1])
        return f64x8(a, b), codegen
    return f


vadd, vsub, vmul = _binop("fadd"), _binop("fsub"), _binop("fmul")


def _register_binop(op, f):
    """overload the Python operator `op` on two F64x8 with the intrinsic `f`."""
    @overload(op)
    def ov(a, b):
        if isinstance(a, F64x8) and isinstance(b, F64x8):
            return lambda a, b: f(a, b)


for _op, _f in ((operator.add, vadd), (operator.sub, vsub), (operator.mul, vmul)):
    _register_binop(_op, _f)
