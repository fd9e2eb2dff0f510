"""The single Numba policy of hopmatch: every kernel is compiled through :func:`jit`.

- ``fastmath`` is on without ``nnan``/``ninf``: NaN and infinity keep their IEEE meaning, so
  kernels that see NaN (masked or unknown values) stay correct.
- Kernels whose results are compared bit-for-bit with a NumPy reference use
  ``jit(exact=True)``: no fastmath at all, so the order of floating-point operations is the
  one written in the source.
- ``cache=True`` writes compiled machine code next to the package (or to
  ``NUMBA_CACHE_DIR``); set ``HOPMATCH_NUMBA_CACHE=0`` to turn it off. When the package
  folder is read-only (a system-wide install) and ``NUMBA_CACHE_DIR`` is unset, caching is
  off rather than failing at import.
- Every kernel is ``nogil``, so hopmatch objects can run in concurrent threads.
- A helper whose callers must round as if its body were written in place is compiled
  ``jit(inline=True)`` (inlined in Numba's IR, before fastmath can reassociate it apart).
"""

from __future__ import annotations

import os
from pathlib import Path

import numba

FASTMATH: frozenset[str] = frozenset({"nsz", "arcp", "contract", "afn", "reassoc"})
def _cache_wanted() -> bool:
    if os.environ.get("HOPMATCH_NUMBA_CACHE", "1").strip().lower() in {"0", "false", "no"}:
        return False
    if os.environ.get("NUMBA_CACHE_DIR"):
        return True
    return os.access(Path(__file__).resolve().parent / "_kernels", os.W_OK)


CACHE: bool = _cache_wanted()


def jit(*signature, exact: bool = False, inline: bool = False):
    """Decorate a kernel with hopmatch's Numba policy (``nopython``, ``nogil``, cached).

    ``inline=True`` inlines the kernel into its callers in Numba's IR, before LLVM sees
    either: the callers' code is then what it would be with the body written in place, so a
    small helper shared by two loops rounds exactly as the loops did when each held its own
    copy (compiled apart, fastmath may reassociate the helper's sums another way).
    """
    return numba.njit(
        *signature,
        cache=CACHE,
        nogil=True,
        fastmath=False if exact else set(FASTMATH),
        error_model="numpy",
        inline="always" if inline else "never",
    )
