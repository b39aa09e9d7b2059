"""Per-process LRU memo of values built from files (motor files, back-EMF tables).

Keyed by the file's real path and a digest of its bytes, so an edited file is read again;
an unreadable file is never cached. Values are shared: callers must not change them.
"""
from __future__ import annotations

import hashlib
import os
from collections import OrderedDict
from typing import Any, Callable, Hashable

import numpy as np

MAX_ENTRIES = 64

_memo: OrderedDict = OrderedDict()


def file_stamp(path) -> tuple | None:
    """(real path, BLAKE2b digest of the bytes) of the file at path, or None if it cannot be read."""
    try:
        with open(path, 'rb') as f:
            digest = hashlib.blake2b(f.read(), digest_size=16).digest()
    except (OSError, TypeError, ValueError):
        return None
    return os.path.realpath(path), digest


def memo(key: Hashable, build: Callable[[], Any]) -> Any:
    """build() once per key; a build that raises stores nothing."""
    try:
        _memo.move_to_end(key)
        return _memo[key]
    except KeyError:
        pass
    value = _memo[key] = build()
    while len(_memo) > MAX_ENTRIES:
        _memo.popitem(last=False)
    return value


def from_file(kind: str, path, build: Callable[[], Any], *extra: Hashable) -> Any:
    """build() for the file at path, memoised by (kind, the file's stamp, str(path), extra)."""
    stamp = file_stamp(path)
    if stamp is None:
        return build()
    return memo((kind, stamp, str(path), *extra), build)


def frozen(array: np.ndarray) -> np.ndarray:
    """The array, made read-only (a shared value must not change under another caller)."""
    array.setflags(write=False)
    return array


def clear() -> None:
    """Forget every memoised value."""
    _memo.clear()
