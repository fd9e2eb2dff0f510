"""Fixtures of the plugin tests."""

from __future__ import annotations

import pytest

#: Seconds any wait on a test's Dask cluster may take.
DASK_TIMEOUT = 60


@pytest.fixture(scope="module")
def client(request):
    """A ``distributed.Client`` of a LocalCluster on 127.0.0.1 serving the test module:
    ``DASK_WORKERS`` worker processes (a module constant; 1 when absent) of one thread
    each, no dashboard."""
    distributed = pytest.importorskip("distributed", reason="needs dask[distributed] "
                                      "(pip install 'hopmatch[all]')")
    n_workers = getattr(request.module, "DASK_WORKERS", 1)
    with distributed.LocalCluster(n_workers=n_workers, threads_per_worker=1,
                                  dashboard_address=None, processes=True,
                                  host="127.0.0.1") as cluster, \
            distributed.Client(cluster, timeout=DASK_TIMEOUT) as c:
        c.wait_for_workers(n_workers, timeout=DASK_TIMEOUT)
        yield c
