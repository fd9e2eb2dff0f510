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
"""
