"""Numba kernels of hopmatch. They import only numpy, numba and ``hopmatch._config``, take
validated C-contiguous arrays and scalars, and never allocate anything of size
``Nl x Nr x Nl x Nr``."""
