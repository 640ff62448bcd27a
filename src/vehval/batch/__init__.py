"""Many tests at once: discovery, Dask execution, resumable outputs, catalog and index.

Public API: :func:`run_batch`, :func:`discover_tests`, :func:`process_test`,
:func:`test_metrics`. See ``docs/catalog.md`` for the discovery rule and the catalog.
"""

from vehval.batch.discover import TestSpec, discover_tests
from vehval.batch.metrics import test_metrics
from vehval.batch.runner import BatchSummary, run_batch
from vehval.batch.task import STEPS, process_test

__all__ = ["BatchSummary", "STEPS", "TestSpec", "discover_tests", "process_test", "run_batch",
           "test_metrics"]
