"""The C library's functions that a node process calls for its own housekeeping (glibc's malloc tuning, Linux's
thread names), found once where they exist and None where the C library has none (musl, macOS)."""
from __future__ import annotations

import ctypes
import ctypes.util


def libc_function(name: str, argtypes: list):
    """The C library's function `name` with `argtypes` and an int result, or None where there is no such function."""
    try:
        function = getattr(ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6"), name)
    except (OSError, AttributeError):
        return None
    function.argtypes, function.restype = argtypes, ctypes.c_int
    return function


__all__ = ["libc_function"]
