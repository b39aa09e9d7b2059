"""One ``njit`` for the stack's compiled per-sample kernels (numba).

Each kernel is written once as plain Python on float64 scalars and numpy
arrays; :func:`njit` compiles it with numba's ``njit`` (``cache=True``, no
``fastmath``, so IEEE operation order and rounding are those of the Python
source and compiled runs give bit-identical trajectories to the
interpreted ones). ``NUMBA_DISABLE_JIT=1`` (numba's own switch) runs the
same functions as plain Python. Compiled machine code is cached in
``NUMBA_CACHE_DIR``: ``scripts/env.sh`` sets it to ``<workspace>/.numba_cache``
and ``scripts/setup.sh`` warms it; when it is unset and this module lives in a
workspace (a ``scripts/env.sh`` above it), that folder is used too.
Without numba installed, :func:`njit` returns the function unchanged.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import math
import os
from pathlib import Path


def _workspace_cache_dir() -> str | None:
    """<workspace>/.numba_cache for a module inside a workspace (symlink install), else None."""
    for parent in Path(__file__).resolve().parents:
        if (parent / 'scripts' / 'env.sh').is_file():
            return str(parent / '.numba_cache')
    return None


if not os.environ.get('NUMBA_CACHE_DIR'):
    _dir = _workspace_cache_dir()
    if _dir is not None:
        os.environ['NUMBA_CACHE_DIR'] = _dir   # numba reads it when first imported

try:
    import numba as _numba
except ImportError:  # pragma: no cover - numba is pinned in requirements.txt
    _numba = None


def jit_disabled() -> bool:
    """True when kernels run as plain Python (NUMBA_DISABLE_JIT=1 or no numba)."""
    return _numba is None or bool(_numba.config.DISABLE_JIT)


def njit(fn):
    """numba.njit(cache=True, fastmath=False) of fn; fn itself when the JIT is disabled."""
    if jit_disabled():
        return fn
    return _numba.njit(cache=True, fastmath=False)(fn)


def interpreted(kernel):
    """The plain-Python function of a kernel (itself when the JIT is disabled).

    For interpreted callers making many tiny calls (a comparator, a PI step), where numba's
    dispatch (about 0.3 us a call) costs more than the arithmetic; same code, same results.
    """
    return getattr(kernel, 'py_func', kernel)


def _libm_pow():
    """C's pow(x, y) from libm, for interpreted and compiled kernels alike.

    CPython's ``x ** y`` on floats is libm's pow, which is not always x * x for y = 2
    (about 1 in 1000 arguments differ in the last bit), while numba and LLVM turn ``x ** 2``
    and a call to ``pow(x, 2.0)`` into x * x. Kernels that must match the interpreted
    arithmetic bit for bit write ``libm_pow(x, 2.0)``: math.pow when interpreted, and compiled
    a call of glibc's alias ``powf64`` of the same function, which LLVM does not rewrite.
    """
    if jit_disabled():
        return math.pow
    name = 'powf64' if hasattr(ctypes.CDLL(ctypes.util.find_library('m') or 'libm.so.6'), 'powf64') else 'pow'
    from numba import types
    return types.ExternalFunction(name, types.float64(types.float64, types.float64))


libm_pow = _libm_pow()

__all__ = ['njit', 'jit_disabled', 'interpreted', 'libm_pow']
