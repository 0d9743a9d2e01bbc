"""Numba extensions of the engine: the helper decorators, borrowed arrays, prefetch, FMA.

No physics here: :func:`_borrow` is what lets the event loop call small helpers on its
arrays at no cost (its docstring says why), :func:`_prefetch` / :func:`_prefetch_at`
are cache hints, :func:`_fma` a correctly rounded ``x * y + z`` (written with Numba's
public extension API, ``intrinsic``); :func:`_sources_digest` keys the loop's disk cache
on every module the loop imports (:func:`kernel_sources`).
"""

from __future__ import annotations

import functools
import hashlib
import os
import pathlib
import re

import numba
from llvmlite import ir
from numba.core import cgutils, types
from numba.core.extending import intrinsic

_inline = numba.njit(inline="always", error_model="numpy")
"""Helpers inlined into the kernels at Numba-IR level: the scene flags they
take become constants there (loops over D unrolled, unused branches gone)."""

_helper = numba.njit(error_model="numpy")
"""Helpers without flags, compiled once and left to LLVM to inline: Numba-IR
inlining is slow to compile, and with borrowed arrays a call costs nothing
much."""


@intrinsic
def _borrow(typingctx, arr):
    """The same array without its reference count (a borrowed view).

    Numba increments and decrements an array's reference count, atomically,
    wherever an array variable is copied, which includes every inlined helper
    taking the array; in the event loop that cost more than the physics. A
    kernel borrows its arguments once at entry: the caller holds the real
    references for the whole call, so the views stay valid, and NRT_incref
    on a null meminfo is a no-op that LLVM removes.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, value=args[0])
        dst = context.make_array(sig.return_type)(context, builder)
        for name in ("parent", "nitems", "itemsize", "data", "shape", "strides"):
            setattr(dst, name, getattr(src, name))
        dst.meminfo = context.get_constant_null(types.MemInfoPointer(types.voidptr))
        return dst._getvalue()

    return arr(arr), codegen


def _emit_prefetch(context, builder, aryty, arr, idxs):
    """Emit llvm.prefetch (read, keep in all cache levels, data cache) of element idxs of arr."""
    ary = context.make_array(aryty)(context, builder, value=arr)
    ptr = cgutils.get_item_pointer2(context, builder, ary.data,
                                    cgutils.unpack_tuple(builder, ary.shape),
                                    cgutils.unpack_tuple(builder, ary.strides), aryty.layout,
                                    idxs, wraparound=False)
    i32 = ir.IntType(32)
    if getattr(ptr.type, "is_opaque", False):  # LLVM with opaque pointers
        name = "llvm.prefetch.p0"
    else:
        ptr = builder.bitcast(ptr, ir.IntType(8).as_pointer())
        name = "llvm.prefetch.p0i8"
    fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
    fn = cgutils.get_or_insert_function(builder.module, fnty, name)
    builder.call(fn, [ptr, i32(0), i32(3), i32(1)])


@intrinsic
def _prefetch(typingctx, arr, i):
    """Ask the CPU to start loading row i of an array into the cache (llvm.prefetch).

    A hint with no effect on results: on large systems the rows of the 3^D
    cells of a scan are all requested at once instead of one after the
    other, so their cache misses overlap.
    """
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        zero = context.get_constant(types.intp, 0)
        _emit_prefetch(context, builder, sig.args[0], args[0],
                       [idx, zero] if sig.args[0].ndim == 2 else [idx])
        return context.get_dummy_value()

    return types.void(arr, i), codegen


@intrinsic
def _prefetch_at(typingctx, arr, i, j):
    """Ask the CPU to start loading element (i, j) of a 2D array into the cache (a hint)."""
    if not isinstance(arr, types.Array) or arr.ndim != 2 or not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        idx = context.cast(builder, args[1], sig.args[1], types.intp)
        col = context.cast(builder, args[2], sig.args[2], types.intp)
        _emit_prefetch(context, builder, sig.args[0], args[0], [idx, col])
        return context.get_dummy_value()

    return types.void(arr, i, j), codegen


@intrinsic
def _kept8(typingctx, arr, row, col):
    """The bits i < 8 (an int64) for which arr[row, col + i] is not > 0 (<= 0, or NaN), of a
    C-contiguous 2D float32 array whose row holds at least col + 8 columns: one vector
    load, compare and mask move (vcmpleps, vmovmskps), where testing each column costs a
    branch (the survivors of the float32 rejection pass, eight at a time; measurements:
    docs/explanation/engine_measurements.md#event-engine-intrinsics)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 2 and arr.dtype == types.float32
            and arr.layout == "C" and isinstance(row, types.Integer)
            and isinstance(col, types.Integer)):
        return None  # (the 8 columns are read as one vector: contiguous rows only)

    def codegen(context, builder, sig, args):
        aryty = sig.args[0]
        ary = context.make_array(aryty)(context, builder, value=args[0])
        idxs = [context.cast(builder, args[1], sig.args[1], types.intp),
                context.cast(builder, args[2], sig.args[2], types.intp)]
        ptr = cgutils.get_item_pointer2(context, builder, ary.data,
                                        cgutils.unpack_tuple(builder, ary.shape),
                                        cgutils.unpack_tuple(builder, ary.strides),
                                        aryty.layout, idxs, wraparound=False)
        vec = ir.VectorType(ir.FloatType(), 8)
        if getattr(ptr.type, "is_opaque", False):
            vals = builder.load(ptr, typ=vec, align=4)
        else:
            vals = builder.load(builder.bitcast(ptr, vec.as_pointer()), align=4)
        le = builder.fcmp_unordered("<=", vals, ir.Constant(vec, [0.0] * 8))
        bits = builder.bitcast(le, ir.IntType(8))
        return builder.zext(bits, ir.IntType(64))

    return types.int64(arr, row, col), codegen


@intrinsic
def _lowest(typingctx, x):
    """The index of the lowest set bit of an int64 x != 0 (llvm.cttz: tzcnt / bsf)."""
    if not isinstance(x, types.Integer):
        return None

    def codegen(context, builder, sig, args):
        v = context.cast(builder, args[0], sig.args[0], types.int64)
        return builder.cttz(v, ir.IntType(1)(1))

    return types.int64(x), codegen


@intrinsic
def _fma(typingctx, x, y, z):
    """x * y + z rounded once (LLVM's llvm.fma: the FMA instruction where the CPU has one,
    a correctly rounded library call where it does not); in float32 when all three are
    float32 (llvm.fma.f32), in float64 otherwise."""
    if not all(isinstance(a, types.Float) for a in (x, y, z)):
        return None
    single = all(a == types.float32 for a in (x, y, z))
    ty = types.float32 if single else types.float64

    def codegen(context, builder, sig, args):
        f = ir.FloatType() if single else ir.DoubleType()
        vals = [context.cast(builder, v, t, ty) for v, t in zip(args, sig.args)]
        fn = builder.module.declare_intrinsic("llvm.fma", [f], ir.FunctionType(f, [f] * 3))
        return builder.call(fn, vals)

    return ty(ty, ty, ty), codegen


_IMPORT = re.compile(r"^(?:from[ \t]+(\.*)([\w.]*)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]*)"
                     r"|import[ \t]+([^\n#]*))", re.M)
"""A module-level import statement (at the start of a line: an import inside a function is
indented): ``from`` (dots, module, names) or ``import`` (modules)."""


def kernel_sources(root: pathlib.Path | None = None, start: str = "gaz_cli.engines.event.loop") -> list:
    """The source files whose code the loop's compiled kernels may hold: ``start``'s module and
    every gaz module it imports at module level, directly or through those it imports.

    A kernel reaches other modules' jitted helpers and constants only through its module's
    globals, hence through module-level imports (an import inside a Python function is not
    seen by Numba); so the set is the closure of the module-level ``import`` / ``from ...
    import`` lines (:data:`_IMPORT`, read as text: nothing is imported, and a regular
    expression costs far less at each start than :mod:`ast`; measurements:
    docs/explanation/engine_measurements.md#event-engine-intrinsics), whatever package each
    module lives in: engine/, its sub-packages at any depth, gaz_cli/numba_config.py (the
    decorators' options, which Numba's key leaves out). ``from package import name`` counts
    ``package/name.py`` when name is a module. ``root`` is the directory holding the
    ``gaz_cli`` package (default: this installation's). Sorted paths.
    """
    root = pathlib.Path(__file__).parents[3] if root is None else pathlib.Path(root)
    top = start.split(".")[0]

    files: dict = {}

    def file_of(module: str) -> pathlib.Path | None:
        if module not in files:
            base = os.path.join(root, *module.split("."))
            files[module] = next((pathlib.Path(f) for f in (base + ".py", os.path.join(base, "__init__.py"))
                                  if os.path.isfile(f)), None)
        return files[module]

    seen: dict = {}
    todo, visited = [start], set()
    while todo:
        module = todo.pop()
        if module in visited:
            continue
        visited.add(module)
        f = file_of(module)
        if f is None or f in seen:
            continue
        seen[f] = module
        package = module if f.name == "__init__.py" else module.rpartition(".")[0]
        for dots, name, names, plain in _IMPORT.findall(f.read_text(encoding="utf-8")):
            if plain:
                todo += [m for m in (p.split(" as ")[0].strip() for p in plain.split(","))
                         if m.split(".")[0] == top]
                continue
            if dots:  # relative: from .x import y
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - len(dots) + 1])
                name = f"{base}.{name}" if name else base
            if name.split(".")[0] != top:
                continue
            todo.append(name)
            g = file_of(name)
            if g is not None and g.name == "__init__.py":  # from package import module?
                todo += [f"{name}.{n.split(' as ')[0].strip()}" for n in names.strip("()").split(",")
                         if n.strip() and n.strip() != "*"]
    return sorted(seen)


def sources_digest(root: pathlib.Path | None = None) -> int:
    """A number that changes with the source of any module the loop's kernels may hold
    (:func:`kernel_sources`: the loop's module-level imports, followed through every package),
    for the ``gaz_cli`` package under ``root`` (default: this installation's).

    Numba's disk cache keys a function on its own file only: an edit of an inlined helper in
    another module (interactions.py, say, or a module of a sub-package) would leave a stale
    loop in the cache, and a user upgrading gaz would run old kernels. The loop (loop.build)
    holds this number (:func:`_sources_digest`) as a closure constant, which Numba's cache
    key includes.
    """
    root = pathlib.Path(__file__).parents[3] if root is None else pathlib.Path(root)
    h = hashlib.sha256()
    for f in kernel_sources(root):
        h.update(f.relative_to(root).as_posix().encode())
        h.update(f.read_bytes())
    return int(h.hexdigest()[:15], 16)


@functools.lru_cache(maxsize=None)
def _sources_digest() -> int:
    """:func:`sources_digest` of this installation, once a process."""
    return sources_digest()
