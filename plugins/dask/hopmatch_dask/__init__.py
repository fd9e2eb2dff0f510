"""hopmatch_dask: match many stereo pairs on a Dask cluster.

- :func:`match_pairs` ``(pairs, client=None, **params)``: futures of :class:`PairResult`
  (with a client) or a lazy ``dask.bag.Bag`` (without);
- :func:`run_batch`: PAIRS.csv-style batches written to a folder, one ``<name>.csv`` per
  pair (the columns of ``hopmatch match``) and ``summary.csv``; reruns skip finished pairs;
- :func:`read_pairs`: read PAIRS.csv (``left,right[,name]``);
- ``hopmatch batch`` on the command line (:mod:`hopmatch_dask.cli`).

Runs on an embedded ``distributed.LocalCluster`` or on any cluster given by its scheduler
address. See ``docs/cluster.md``.
"""

from __future__ import annotations

from .batch import BatchReport, Outcome, check_params, local_cluster, match_pairs, run_batch
from .pairs import Pair, PairsFileError, as_pairs, read_pairs
from .results import COLUMNS, SUMMARY_COLUMNS, complete_rows
from .tasks import ImageReadError, PairResult, read_image

__all__ = [
    "BatchReport",
    "COLUMNS",
    "ImageReadError",
    "Outcome",
    "Pair",
    "PairResult",
    "PairsFileError",
    "SUMMARY_COLUMNS",
    "as_pairs",
    "check_params",
    "complete_rows",
    "local_cluster",
    "match_pairs",
    "read_image",
    "read_pairs",
    "run_batch",
]
