"""Explicit 8 x double vectors for numba: a numba type wrapping LLVM's <8 x double>.

Used by the generated Newmark kernels (`contact_bench.kernels.newmark_vec`). A value of this type
lives in registers, so a loop-carried vector (the forward and backward sweeps of a
tridiagonal solve, 16 lanes = two vectors) is a register recurrence instead of a chain
of stores and reloads through memory, which is what numba's auto-vectorised loops give.

- vload(a, i) / vstore(a, i, v): the 8 doubles a[i : i + 8] (unaligned allowed);
- vsplat(x): x in all 8 elements;
- vfma(a, b, c) = a * b + c and vfnma(a, b, c) = c - a * b, each rounded once;
- +, -, * between two vectors, element by element (IEEE, no reassociation).

Indices are unsigned (uint64), like the scalar kernels of `contact_bench.core.spike`.

Added for the error norms (`contact_bench.harness.metrics`), at the end of the module: vloadc (vload
checked at typing: a C-contiguous float64 array of any dimension, flat index) and a
4 x double type F64x4 (the 4 quadrature points of an element) with v4load, v4bcast (one
double in the 4 elements: an AVX-512 broadcast memory operand of the arithmetic),
v4splat, v4hsum (horizontal sum in a fixed order) and +, -, * (IEEE, no fma).

Added for the characteristics solution's sparse kernel (`contact_bench.exact.characteristics`), at
the
end of the module: vselect_lt, vselect_le, vselect_ge, vselect_eq (a op b ? x : y lane by
lane, ordered comparisons), vany (a lane not 0), vdiv (a / b), vfloor, and, with an index
array ia (1-D, C-contiguous, int64): vgather(a, ia, i) (the lanes a[ia[i + lane]] as
doubles), vstore_index(ia, i, v) (ia[i : i + 8] = v as int64); vprefetch(a, i) (a hint:
the cache line of a[i]). Their codegen helpers (gather_indices, gather_lanes,
gather_pairs) also build the kernel's own gather of a cell's data.

Added for the d'Alembert solution's kernel (`contact_bench.exact.dalembert`), at the end of the
module:
vrows4(tab, f), the 4 columns of the rows f[lane] of a (rows, 4) table, one 32-byte load
per lane and 12 shuffles.
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


def array_data(context, builder, aryty, ary):
    """The data pointer of the array ary (of numba type aryty)."""
    return context.make_array(aryty)(context, builder, ary).data


def _elem(context, builder, aryty, ary, idx, idxty):
    """Address of ary[idx] (flat), idx (of numba type idxty) taken as uint64."""
    arr = context.make_array(aryty)(context, builder, ary)
    i = context.cast(builder, idx, idxty, types.uint64)
    return builder.gep(arr.data, [i], inbounds=True)


def _ptr(context, builder, aryty, ary, idx, idxty):
    return builder.bitcast(_elem(context, builder, aryty, ary, idx, idxty), _V.as_pointer())


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
# Added for the error norms (`contact_bench.harness.metrics`). The loads check their array at
# typing: a
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


# ---------------------------------------------------------------------------------------
# Added for the characteristics solution's sparse kernel (`contact_bench.exact.characteristics`).
# The
# operations type only for the arguments they are meant for (F64x8 values, 1-D
# C-contiguous arrays, int64 index arrays): any other fails to type (no matching
# definition). Comparisons are ordered (false with a NaN).
_I64 = ir.IntType(64)


def _vectors(*tys: types.Type) -> bool:
    return all(ty == f64x8 for ty in tys)


def _array1(ty: types.Type) -> bool:
    """Whether ty is a 1-D C-contiguous array."""
    return isinstance(ty, types.Array) and ty.ndim == 1 and ty.layout == "C"


def is_index_array(ty: types.Type) -> bool:
    return _array1(ty) and ty.dtype == types.int64


def is_float_array(ty: types.Type) -> bool:
    return _array1(ty) and ty.dtype == types.float64


def _select(op: str):
    @intrinsic
    def select(typingctx, a, b, x, y):
        """a op b ? x : y, lane by lane (an ordered comparison: false with a NaN)."""
        if not _vectors(a, b, x, y):
            return None

        def codegen(context, builder, sig, args):
            cond = builder.fcmp_ordered(op, args[0], args[1])
            return builder.select(cond, args[2], args[3])
        return f64x8(a, b, x, y), codegen
    return select


vselect_lt, vselect_le, vselect_ge, vselect_eq = (_select(op) for op in ("<", "<=", ">=", "=="))


@intrinsic
def vany(typingctx, a):
    """Whether a lane of a is not 0 (a NaN lane counts)."""
    if not _vectors(a):
        return None

    def codegen(context, builder, sig, args):
        ne = builder.fcmp_unordered("!=", args[0], ir.Constant(_V, [0.0] * 8))
        bits = builder.bitcast(ne, ir.IntType(8))
        return builder.icmp_unsigned("!=", bits, ir.Constant(ir.IntType(8), 0))
    return types.boolean(a), codegen


@intrinsic
def vdiv(typingctx, a, b):
    """a / b, lane by lane (IEEE: the scalar quotient in every lane)."""
    if not _vectors(a, b):
        return None

    def codegen(context, builder, sig, args):
        return builder.fdiv(args[0], args[1])
    return f64x8(a, b), codegen


@intrinsic
def vfloor(typingctx, a):
    """floor(a), lane by lane."""
    if not _vectors(a):
        return None

    def codegen(context, builder, sig, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_V, [_V]),
                                            "llvm.floor.v8f64")
        return builder.call(fn, [args[0]])
    return f64x8(a), codegen


@intrinsic
def vstore_index(typingctx, ia, i, v):
    """ia[i : i + 8] = the lanes of v (whole numbers) as int64."""
    if not (is_index_array(ia) and isinstance(i, types.Integer) and _vectors(v)):
        return None

    def codegen(context, builder, sig, args):
        p = builder.bitcast(_elem(context, builder, sig.args[0], args[0], args[1], sig.args[1]),
                            ir.VectorType(_I64, 8).as_pointer())
        builder.store(builder.fptosi(args[2], ir.VectorType(_I64, 8)), p, align=8)
        return context.get_dummy_value()
    return types.none(ia, i, v), codegen


def gather_indices(context, builder, sig, args, pos: int) -> list:
    """The 8 int64 indices ia[i : i + 8] (ia = args[pos], i = the last argument)."""
    data = array_data(context, builder, sig.args[pos], args[pos])
    at = context.cast(builder, args[-1], sig.args[-1], types.uint64)
    return [builder.load(builder.gep(data, [builder.add(at, ir.Constant(_I64, lane))],
                                     inbounds=True)) for lane in range(8)]


def gather_lanes(context, builder, aryty, ary, idx: list):
    """The vector of a[idx[lane]] (one load per lane), as doubles."""
    data = array_data(context, builder, aryty, ary)
    vec = ir.Constant(_V, ir.Undefined)
    for lane, j in enumerate(idx):
        val = context.cast(builder, builder.load(builder.gep(data, [j], inbounds=True)),
                           aryty.dtype, types.float64)
        vec = builder.insert_element(vec, val, ir.Constant(_I32, lane))
    return vec


def gather_pairs(builder, data, idx: list) -> tuple:
    """The vectors of a[idx[lane]] and a[idx[lane] + 1] (data: a float64 pointer): one
    16-byte load per lane, then the lanes sorted out."""
    v2 = ir.VectorType(ir.DoubleType(), 2)
    two = [builder.load(builder.bitcast(builder.gep(data, [j], inbounds=True),
                                        v2.as_pointer()), align=8) for j in idx]
    four = [builder.shuffle_vector(two[2 * q], two[2 * q + 1], _mask(0, 1, 2, 3))
            for q in range(4)]
    eight = [builder.shuffle_vector(four[2 * q], four[2 * q + 1], _mask(*range(8)))
             for q in range(2)]
    return (builder.shuffle_vector(eight[0], eight[1], _mask(*range(0, 16, 2))),
            builder.shuffle_vector(eight[0], eight[1], _mask(*range(1, 16, 2))))


@intrinsic
def vgather(typingctx, a, ia, i):
    """The lanes a[ia[i + lane]] (a any 1-D C-contiguous array of numbers), as doubles."""
    if not (_array1(a) and isinstance(a.dtype, (types.Integer, types.Float))
            and is_index_array(ia) and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        return gather_lanes(context, builder, sig.args[0], args[0],
                            gather_indices(context, builder, sig, args, 1))
    return f64x8(a, ia, i), codegen


@intrinsic
def vprefetch(typingctx, a, i):
    """Ask for the cache line of a[i] (a hint: no load, no fault)."""
    if not (_array1(a) and isinstance(i, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        i8p = ir.IntType(8).as_pointer()
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [i8p, _I32, _I32, _I32]),
            "llvm.prefetch")  # overloaded on the address space: named by LLVM
        ptr = builder.bitcast(_elem(context, builder, sig.args[0], args[0], args[1],
                                    sig.args[1]), i8p)
        builder.call(fn, [ptr, ir.Constant(_I32, 0), ir.Constant(_I32, 3), ir.Constant(_I32, 1)])
        return context.get_dummy_value()
    return types.none(a, i), codegen


# Added for the d'Alembert solution's kernel (`contact_bench.exact.dalembert`): the rows of a table.


def _rows_table(ty: types.Type) -> bool:
    """Whether ty is a 2-D C-contiguous float64 array (a table of rows)."""
    return (isinstance(ty, types.Array) and ty.ndim == 2 and ty.layout == "C"
            and ty.dtype == types.float64)


@intrinsic
def vrows4(typingctx, tab, f):
    """(tab[i, 0], tab[i, 1], tab[i, 2], tab[i, 3]) lane by lane, i = f[lane] (whole
    numbers, valid rows of the (rows, 4) table): one 32-byte load per lane (a row), then
    12 shuffles."""
    if not (_rows_table(tab) and _vectors(f)):
        return None

    def codegen(context, builder, sig, args):
        data = array_data(context, builder, sig.args[0], args[0])
        idx = builder.fptosi(args[1], ir.VectorType(_I64, 8))
        v4 = ir.VectorType(ir.DoubleType(), 4)
        four = ir.Constant(_I64, 4)
        r = [builder.load(builder.bitcast(
            builder.gep(data, [builder.mul(builder.extract_element(idx, ir.Constant(_I32, k)),
                                           four)], inbounds=True), v4.as_pointer()), align=8)
             for k in range(8)]
        s = [builder.shuffle_vector(r[2 * k], r[2 * k + 1], _mask(*range(8))) for k in range(4)]
        # rows 4q..4q+3 of columns (0, 1) and (2, 3)
        c01, c23 = _mask(0, 4, 8, 12, 1, 5, 9, 13), _mask(2, 6, 10, 14, 3, 7, 11, 15)
        t = [builder.shuffle_vector(s[2 * q], s[2 * q + 1], m) for q in (0, 1)
             for m in (c01, c23)]
        first, last = _mask(0, 1, 2, 3, 8, 9, 10, 11), _mask(4, 5, 6, 7, 12, 13, 14, 15)
        cols = [builder.shuffle_vector(t[c // 2], t[2 + c // 2], first if c % 2 == 0 else last)
                for c in range(4)]
        return context.make_tuple(builder, sig.return_type, cols)
    return types.UniTuple(f64x8, 4)(tab, f), codegen


# ---------------------------------------------------------------------------------------
# Added for the sampled energy (`contact_bench.core.sampling.energy_rows`): vhsum(a), the
# sum of the 8 lanes in a fixed order.
@intrinsic
def vhsum(typingctx, a):
    """((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7)) (IEEE, in this order: the halves
    added lane by lane, then the quarters, then the pair)."""
    if not _vectors(a):
        return None

    def codegen(context, builder, sig, args):
        x = args[0]
        h = builder.fadd(builder.shuffle_vector(x, x, _mask(0, 1, 2, 3)),
                         builder.shuffle_vector(x, x, _mask(4, 5, 6, 7)))
        q = builder.fadd(builder.shuffle_vector(h, h, _mask(0, 1)),
                         builder.shuffle_vector(h, h, _mask(2, 3)))
        return builder.fadd(builder.extract_element(q, ir.Constant(_I32, 0)),
                            builder.extract_element(q, ir.Constant(_I32, 1)))
    return types.float64(a), codegen
