"""One ``njit`` for the stack's compiled per-sample kernels (numba; docs/architecture.md
"Compiled kernels (numba)").

No ``fastmath``, so compiled runs are bit-identical to interpreted ones
(``NUMBA_DISABLE_JIT=1``); the cache goes to ``NUMBA_CACHE_DIR``, by default the workspace's
``.numba_cache``. Without numba, :func:`njit` returns the function unchanged.
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
    """The plain-Python function of a kernel, for many tiny interpreted calls (numba's dispatch
    costs more than the arithmetic there)."""
    return getattr(kernel, 'py_func', kernel)


def _libm_pow():
    """C's pow(x, y) from libm, for interpreted and compiled kernels alike: LLVM rewrites
    ``x ** 2`` and ``pow(x, 2.0)`` to x * x (not always libm's result), but not glibc's ``powf64``."""
    if jit_disabled():
        return math.pow
    name = 'powf64' if hasattr(ctypes.CDLL(ctypes.util.find_library('m') or 'libm.so.6'), 'powf64') else 'pow'
    from numba import types
    return types.ExternalFunction(name, types.float64(types.float64, types.float64))


libm_pow = _libm_pow()

__all__ = ['njit', 'jit_disabled', 'interpreted', 'libm_pow']
