"""Scatters whose indices are known when tracing, recomputed with gathers.

Under XLA's deterministic GPU ops (`--xla_gpu_deterministic_ops`, graspjax's default) a
scatter whose indices are not declared unique becomes a sort of its (index, value) pairs over
the whole batch, then a prefix scan and a unique scatter: dozens of kernels for what is, in
MJX's step, a sum over a handful of bodies or constraint rows. MJX's indices there are the
model's: its kinematic tree sums (`scan.body_tree`, in `com_pos`, `crb`, `rne` and every
Jacobian), the line search's friction rows added onto their normals, the kinematics' and the
integrator's writes. They are concrete when the step is traced, so each such scatter can be
computed from a table made then:

- a scatter-add: each destination's value plus its updates, added one at a time in the order
  of the updates (the order XLA's CPU scatter adds them in), read by gathers;
- a scatter (write) whose destinations are distinct: each destination's update, gathered.

`without_sorted_scatters(fun)` traces `fun` to a jaxpr and evaluates it with those scatters
replaced, inside loop bodies, branches and calls too (each such jaxpr that holds a scatter is
traced again with what its equation knows of its inputs: a loop's constants, a call's
operands). Equations of known inputs only are traced where they are used (or computed, for a
scatter's indices); every other equation is bound with its own parameters. Scatters of traced
indices, writes to one place twice, other combiners, sums of more than `_DEEPEST` updates into
one place and scatters inside jaxprs this does not open (`checkpoint`'s, `shard_map`'s, a
custom derivative rule's) stay scatters. On the CPU the values are XLA's own scatters' bit for bit
(tests/test_scatters.py); in a larger program XLA may fuse the arithmetic around them
differently, so floats can differ there in the last place.
"""

from __future__ import annotations

import contextlib
import functools
import weakref
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jax.extend import core

from graspjax import privates

_ADD, _WRITE = "scatter-add", "scatter"  # the primitives rewritten
_CALLS = ("jit", "pjit", "closed_call", "core_call", "custom_jvp_call", "custom_vjp_call",
          "custom_vjp_call_jaxpr")  # calls whose jaxpr takes the operands as they are
_DEEPEST = 64  # most updates summed into one place by gathers (beyond: the scatter is kept)
_MODES = (lax.GatherScatterMode.FILL_OR_DROP, lax.GatherScatterMode.CLIP,
          lax.GatherScatterMode.PROMISE_IN_BOUNDS)  # the index modes `destinations` knows


def without_sorted_scatters(fun: Callable) -> Callable:
    """`fun` (pytrees of arrays in and out) with its scatters of trace-time indices computed
    by gathers (module docstring), jitted: traced and rewritten once per input signature."""

    def wrapped(*args):
        leaves, tree = jax.tree.flatten(args)
        closed, shape = jax.make_jaxpr(lambda *x: fun(*jax.tree.unflatten(tree, x)),
                                       return_shape=True)(*leaves)
        outs = evaluate(closed.jaxpr, closed.consts, leaves)
        return jax.tree.unflatten(jax.tree.structure(shape), outs)

    return jax.jit(wrapped)


def evaluate(jaxpr: core.Jaxpr, consts, args) -> list:
    """`jaxpr`'s outputs at (`consts`, `args`) as traced values, scatters of known indices
    gathered and the jaxprs of calls and loops evaluated the same way. An equation of known
    inputs only is held (`_Known`) until an output is used: traced into this trace when used
    by it (once per trace: `staged`), or computed now when it makes a scatter's indices
    (`_computed`: integer arithmetic by NumPy, anything else by XLA on the CPU)."""
    env, staged = {}, {}

    def read(v):
        return v.val if isinstance(v, core.Literal) else env[v]

    for var, value in zip(jaxpr.constvars, consts, strict=True):
        env[var] = value
    for var, value in zip(jaxpr.invars, args, strict=True):
        env[var] = value
    for eqn in jaxpr.eqns:
        invals = [read(v) for v in eqn.invars]
        if not eqn.effects and all(map(_is_known, invals)):
            held = _Known(eqn, invals)
            outs = [_Output(held, i) for i in range(len(eqn.outvars))]
        else:
            outs = _equation(eqn, invals, staged)
        for var, value in zip(eqn.outvars, outs, strict=True):
            env[var] = value
    return [_traced(read(v), staged) for v in jaxpr.outvars]


@contextlib.contextmanager
def _context(eqn):
    """The equation's source line and context, for what is traced from it."""
    name_stack = privates.source_info_util.current_name_stack() + eqn.source_info.name_stack
    with (privates.source_info_util.user_context(eqn.source_info.traceback, name_stack=name_stack),
          eqn.ctx.manager):
        yield


class _Known:
    """An equation whose inputs are all known when tracing: its outputs traced, or computed."""

    def __init__(self, eqn, invals):
        self.eqn, self.invals = eqn, invals
        self.known_outs = None

    def traced(self, staged: dict) -> list:
        """The outputs traced into the trace whose equations `staged` holds."""
        if id(self) not in staged:
            staged[id(self)] = _equation(self.eqn, self.invals, staged)
        return staged[id(self)]

    def known(self) -> list:
        """The outputs computed (concrete arrays)."""
        if self.known_outs is None:
            self.known_outs = _computed(self.eqn, [_known(x) for x in self.invals])
        return self.known_outs


class _Output:
    """One output of a `_Known` equation."""

    def __init__(self, held: _Known, index: int):
        self.held, self.index = held, index


def _computed(eqn, invals) -> list:
    """An equation's outputs at concrete inputs: by NumPy where `_NUMPY` has its primitive
    and every value is an integer or boolean array (exact, so XLA's own values), else by XLA
    on the CPU (an executable compiled per operation: tens of ms each)."""
    name, outs = eqn.primitive.name, [v.aval for v in eqn.outvars]
    integral = all(_integral(v.aval.dtype) for v in [*eqn.invars, *eqn.outvars])
    if integral and name in ("jit", "pjit"):
        closed = eqn.params["jaxpr"]
        return _evaluated(closed.jaxpr, closed.consts, [np.asarray(x) for x in invals])
    if integral and name in _NUMPY:
        out = np.asarray(_NUMPY[name](*map(np.asarray, invals), **eqn.params))
        assert out.shape == outs[0].shape, (name, out.shape, outs[0].shape)
        return [out.astype(outs[0].dtype)]
    with jax.ensure_compile_time_eval(), jax.default_device(_cpu()):
        return _bind(eqn.primitive, eqn.params, invals)


def _evaluated(jaxpr: core.Jaxpr, consts, args) -> list:
    """A jaxpr's outputs (arrays) at concrete inputs, equation by equation (`_computed`)."""
    env = dict(zip(jaxpr.constvars, consts, strict=True)) | dict(
        zip(jaxpr.invars, args, strict=True))

    def read(v):
        return v.val if isinstance(v, core.Literal) else env[v]

    for eqn in jaxpr.eqns:
        env.update(zip(eqn.outvars, _computed(eqn, [read(v) for v in eqn.invars]), strict=True))
    return [np.asarray(read(v), v.aval.dtype) for v in jaxpr.outvars]


def _integral(dtype) -> bool:
    """Whether values of `dtype` are integers or booleans (NumPy computes them exactly)."""
    return np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.bool_)


def _broadcast_in_dim(x, shape, broadcast_dimensions, **_):
    """XLA's broadcast: x's dimension i becomes dimension broadcast_dimensions[i] of `shape`."""
    expanded = [1] * len(shape)
    for i, d in enumerate(broadcast_dimensions):
        expanded[d] = x.shape[i]
    return np.broadcast_to(x.reshape(expanded), shape)


def _iota(dtype, shape, dimension, **_):
    return np.broadcast_to(np.arange(shape[dimension], dtype=dtype).reshape(
        [-1 if d == dimension else 1 for d in range(len(shape))]), shape)


def _slice(x, start_indices, limit_indices, strides, **_):
    return x[tuple(slice(a, b, c) for a, b, c in zip(
        start_indices, limit_indices, strides or (1,) * x.ndim, strict=True))]


def _reshape(x, new_sizes, dimensions, **_):
    return x.reshape(new_sizes) if dimensions is None else x.transpose(dimensions).reshape(new_sizes)


_NUMPY = {  # primitive: its value on integer and boolean arrays (outputs cast to XLA's dtype)
    "add": lambda a, b, **_: a + b,  # integers wrap in both
    "sub": lambda a, b, **_: a - b,
    "mul": lambda a, b, **_: a * b,
    "neg": lambda a, **_: -a,
    "max": lambda a, b, **_: np.maximum(a, b),
    "min": lambda a, b, **_: np.minimum(a, b),
    "and": lambda a, b, **_: a & b,
    "or": lambda a, b, **_: a | b,
    "not": lambda a, **_: ~a,
    "eq": lambda a, b, **_: a == b,
    "ne": lambda a, b, **_: a != b,
    "lt": lambda a, b, **_: a < b,
    "le": lambda a, b, **_: a <= b,
    "gt": lambda a, b, **_: a > b,
    "ge": lambda a, b, **_: a >= b,
    "select_n": lambda which, *cases, **_: np.choose(which.astype(np.int64), cases, mode="clip"),
    "convert_element_type": lambda x, **_: x,  # the cast to the output's dtype does it
    "broadcast_in_dim": _broadcast_in_dim,
    "iota": _iota,
    "concatenate": lambda *xs, dimension, **_: np.concatenate(xs, dimension),
    "slice": _slice,
    "reshape": _reshape,
    "squeeze": lambda x, dimensions, **_: np.squeeze(x, tuple(dimensions)),
    "transpose": lambda x, permutation, **_: np.transpose(x, permutation),
}


def _traced(x, staged: dict):
    """A value as the trace of `staged` uses it."""
    return x.held.traced(staged)[x.index] if isinstance(x, _Output) else x


def _known(x):
    """A known value, computed (a concrete array)."""
    return x.held.known()[x.index] if isinstance(x, _Output) else x


def _is_known(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def _equation(eqn, held, staged) -> list:
    """One equation's outputs traced into the trace of `staged` (with its source line), at its
    inputs as they were read (`held`)."""
    with _context(eqn):
        return _rewritten(eqn, held, staged)


def _rewritten(eqn, held, staged) -> list:
    """`_equation`'s outputs: a scatter of known indices gathered when it can be; the jaxprs in
    any other equation's parameters (loop bodies, branches, calls) rewritten the same way,
    knowing what their equation knows of their inputs."""
    name, params = eqn.primitive.name, eqn.params
    if name in (_ADD, _WRITE) and _is_known(held[1]):
        out = _gathered_scatter(name, params, _traced(held[0], staged), _known(held[1]),
                                _traced(held[2], staged))
        if out is not None:
            return [out]
    invals = [_traced(x, staged) for x in held]
    known = [x if _is_known(x) else None for x in held]
    new = {}
    for key, param in params.items():
        if isinstance(param, core.ClosedJaxpr):
            new[key] = rewrite(param, _inputs_known(name, key, params, param, known))
        elif (isinstance(param, tuple) and param
              and all(isinstance(p, core.ClosedJaxpr) for p in param)):  # cond's branches
            new[key] = tuple(rewrite(p, _inputs_known(name, key, params, p, known)) for p in param)
        else:
            new[key] = param
    return _bind(eqn.primitive, new, invals)


def _inputs_known(name, key, params, closed, known) -> list:
    """What is known of each input of the jaxpr `params[key]` of an equation (None: not
    known), from what is known of its operands: a loop's constants; a branch's or a call's
    operands. Nothing where the layout is not recognised."""
    n = len(closed.jaxpr.invars)
    if name == "while" and {"cond_nconsts", "body_nconsts"} <= params.keys():
        nc, nb = params["cond_nconsts"], params["body_nconsts"]
        consts = known[:nc] if key == "cond_jaxpr" else known[nc:nc + nb]
    elif name == "scan":
        consts = known[:_scan_consts(params)]
    elif name == "cond":
        consts = known[1:]  # the branch index first
    elif name in _CALLS:
        consts = known
    else:
        consts = []
    if name in ("cond", *_CALLS) and len(consts) != n:
        consts = []
    return consts + [None] * (n - len(consts))


def _scan_consts(params) -> int:
    """How many of a scan's operands are its constants (0 when the parameters do not say)."""
    if "num_consts" in params:
        return params["num_consts"]
    try:  # newer jax: a flat tree of (constants, carry, xs)
        return len(params["ft_in"].unpack()[0].vals)
    except (KeyError, AttributeError, TypeError):
        return 0


def rewrite(closed: core.ClosedJaxpr, known: list) -> core.ClosedJaxpr:
    """`closed` with its scatters of known indices gathered, for inputs of which `known` says
    what is known (a value, or None): the same inputs and outputs (`closed` itself when it
    has no scatter)."""
    if not _has_scatter(closed.jaxpr):
        return closed
    avals = [jax.ShapeDtypeStruct(v.aval.shape, v.aval.dtype, weak_type=v.aval.weak_type)
             for v in closed.jaxpr.invars]

    def evaluated(*args):
        args = [a if k is None else k for a, k in zip(args, known, strict=True)]
        return evaluate(closed.jaxpr, closed.consts, args)

    return jax.make_jaxpr(evaluated)(*avals)


_SCATTERING: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # jaxpr: `_has_scatter`


def _has_scatter(jaxpr: core.Jaxpr) -> bool:
    """Whether `jaxpr` or a jaxpr in its equations' parameters holds a scatter."""
    if jaxpr not in _SCATTERING:
        _SCATTERING[jaxpr] = any(
            eqn.primitive.name in (_ADD, _WRITE)
            or any(isinstance(sub, core.ClosedJaxpr) and _has_scatter(sub.jaxpr)
                   for param in eqn.params.values()
                   for sub in (param if isinstance(param, tuple) else (param,)))
            for eqn in jaxpr.eqns)
    return _SCATTERING[jaxpr]


def _bind(primitive, params, invals) -> list:
    """`primitive`'s outputs at `invals`, as traced."""
    bind_params = primitive.get_bind_params(params)  # (subfuns, params) before jax 0.8
    subfuns, bind_params = bind_params if isinstance(bind_params, tuple) else ((), bind_params)
    outs = primitive.bind(*subfuns, *invals, **bind_params)
    return outs if primitive.multiple_results else [outs]


@functools.cache
def _cpu():
    """The device constants are computed on while tracing."""
    return jax.local_devices(backend="cpu")[0]


def destinations(params, operand_shape, indices, updates_shape) -> np.ndarray:
    """The flat operand position each update element goes to (updates' shape), -1 where its
    window is dropped (out of bounds), by XLA's scatter semantics (JAX puts the index vector
    last in `indices`)."""
    dnums, indices = params["dimension_numbers"], np.asarray(indices)
    rank, n = len(operand_shape), int(np.prod(updates_shape))
    window_dims = list(dnums.update_window_dims)
    scatter_dims = [i for i in range(len(updates_shape)) if i not in window_dims]
    batching = tuple(getattr(dnums, "operand_batching_dims", ()))
    batching_in_indices = tuple(getattr(dnums, "scatter_indices_batching_dims", ()))
    skipped = set(dnums.inserted_window_dims) | set(batching)
    windowed = [d for d in range(rank) if d not in skipped]  # the window's operand dims
    size = np.ones(rank, np.int64)
    size[windowed] = [updates_shape[w] for w in window_dims]
    at = np.indices(updates_shape).reshape(len(updates_shape), n)
    where = at[scatter_dims]  # each element's place among the indices' batch dims
    vectors = indices.reshape(-1, indices.shape[-1])[  # (n, K); K may be 0 (`x.at[:]`)
        np.ravel_multi_index(tuple(where), indices.shape[:-1]) if scatter_dims
        else np.zeros(n, int)] if indices.size else np.zeros((n, indices.shape[-1]), np.int64)
    start = np.zeros((rank, n), np.int64)
    for k, d in enumerate(dnums.scatter_dims_to_operand_dims):
        start[d] = vectors[:, k]
    for d, j in zip(batching, batching_in_indices, strict=True):
        start[d] = where[j]
    high = np.asarray(operand_shape, np.int64)[:, None] - size[:, None]
    if params["mode"] == lax.GatherScatterMode.CLIP:
        start, inside = np.clip(start, 0, high), np.ones(n, bool)
    else:  # FILL_OR_DROP; PROMISE_IN_BOUNDS, where XLA also skips what is out of bounds
        inside = np.all((start >= 0) & (start <= high), axis=0)
    position = start
    position[windowed] += at[window_dims]
    flat = np.ravel_multi_index(tuple(np.where(inside, position, 0)), operand_shape)
    return np.where(inside, flat, -1).reshape(updates_shape)


def _gathered_scatter(name, params, operand, indices, updates):
    """The scatter computed by gathers from its concrete `indices`, or None to keep it: a
    write to one place twice, an update function other than the primitive's own, an index
    mode `destinations` does not know, more than `_DEEPEST` updates into one place."""
    if params.get("update_jaxpr") is not None and name == _WRITE:
        return None  # a write with a custom update function (never emitted by `.at[].set`)
    if params["mode"] not in _MODES:
        return None
    dest = destinations(params, operand.shape, indices, updates.shape).ravel()
    size = int(np.prod(operand.shape))
    kept = np.flatnonzero(dest >= 0)  # update positions in bounds, in update order
    targets, counts = np.unique(dest[kept], return_counts=True)
    if name == _WRITE and counts.size and counts.max() > 1:
        return None  # which write wins is unspecified: leave it to XLA
    if counts.size and counts.max() > _DEEPEST:
        return None  # a long chain of adds: the sorted scatter is the better program
    order = kept[np.argsort(dest[kept], kind="stable")]  # grouped by target, update order kept
    depth = int(counts.max()) if counts.size else 0
    table = np.full((targets.size, depth), updates.size)  # sources per target; updates.size: none
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    for k in range(depth):
        has = counts > k
        table[has, k] = order[starts[has] + k]
    flat = operand.reshape(-1)
    none = -0.0 if jnp.issubdtype(updates.dtype, jnp.inexact) else 0  # x + -0.0 is x, -0.0 too
    source = jnp.concatenate((updates.reshape(-1), jnp.full(1, none, updates.dtype)))
    if name == _ADD:
        value = flat[targets]
        for k in range(depth):
            value = value + source[table[:, k]]
    else:
        value = source[table[:, 0]] if depth else flat[targets]
    row = np.full(size, targets.size)  # each operand place's row in `value`; the pad: kept
    row[targets] = np.arange(targets.size)
    written = np.zeros(size, bool)
    written[targets] = True
    value = jnp.concatenate((value, jnp.zeros(1, value.dtype)))
    return jnp.where(written, value[row], flat).reshape(operand.shape).astype(operand.dtype)
