"""Numba kernels of hopmatch. They import only numpy, numba and ``hopmatch._config``, take
validated C-contiguous arrays and scalars, and never allocate anything of size
``Nl x Nr x Nl x Nr``.

- :mod:`.deriche`: the Canny-Deriche gradient in float32 (section 1, item 1);
- :mod:`.moravec`: Moravec directional variance and selection (eqs. 1-2);
- :mod:`.descriptor`: the mean-subtracted windows (eqs. 8-9);
- :mod:`.candidates`: the candidate pairs, the neurons (section 4's search window);
- :mod:`.similarity`: the similarity of candidate pairs (eqs. 7-9);
- :mod:`.neighbours`: the neighbour lists on a grid of cells (section 4's neighbour window);
- :mod:`.interactions`: the interaction weights (eqs. 5, 6, 10);
- :mod:`.network`: energy, local fields and dynamics (eqs. 11-13);
- :mod:`.arrays`: binary searches and growing buffers the others share.

Numba's cache keys a compiled kernel on its own file only: after editing a kernel that
kernels of another file call (``arrays``, ``similarity.contrast_admits``,
``neighbours.transposed_lists``), clear the ``__pycache__`` of this folder or set
``HOPMATCH_NUMBA_CACHE=0``, or the callers keep their stale machine code.

Compile time (the first run, issue 17; ``benchmarks/compile_times.py`` lists it per kernel):
every specialisation Numba compiles, of a kernel or of a NumPy function it calls, costs a
full compilation, so the kernels

- pass ``np.int64(0)``, not the literal ``0``, as the first value of a counter another
  kernel receives (type inference compiles the callee for ``Literal[int](0)`` too);
- copy arrays by element loops, never by slice assignment (its shape check's error
  message compiles Numba's string functions: seconds of compilation);
- sort only int64 keys in place (``a.sort()``: one specialisation of Numba's quicksort),
  and take extremes and binary searches with loops (``lower_bound``) rather than
  ``np.min``/``np.max``/``np.searchsorted``, each a family of compiled helpers;
- inline (``jit(inline=True)``) the small helpers called at one or two places, which then
  need no compilation of their own; larger ones called in several places stay apart
  (inlined, each copy is compiled again).
"""
