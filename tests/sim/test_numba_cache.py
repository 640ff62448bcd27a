"""The compiled-kernel cache follows every source change (vehval.numba_cache)."""

from __future__ import annotations

import os

from vehval import numba_cache


def test_fingerprint_changes_when_any_module_changes(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sim").mkdir(parents=True)
    kernel, layout = pkg / "sim" / "kernel.py", pkg / "sim" / "layout.py"
    kernel.write_text("def run(): pass\n")
    layout.write_text("PARAMS = ('mass',)\n")
    fp0 = numba_cache.fingerprint(pkg)
    assert len(fp0) == 16 and fp0 == numba_cache.fingerprint(pkg)
    # a callee or layout change (the kernel file untouched) gives another cache directory
    layout.write_text("PARAMS = ('mass', 'rl_a')\n")
    fp1 = numba_cache.fingerprint(pkg)
    assert fp1 != fp0
    st = layout.stat()
    os.utime(layout, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    assert numba_cache.fingerprint(pkg) != fp1


def test_configured_before_the_kernels_and_pruned(tmp_path, monkeypatch):
    import numba.core.config as config

    import vehval.sim.kernel  # noqa: F401 - the package configured the cache on import

    assert numba_cache._configured is not None
    if config.CACHE_DIR:  # not when the base directory could not be created
        assert os.path.basename(config.CACHE_DIR) == numba_cache.fingerprint()
    # pruning keeps the KEEP most recent fingerprint directories and the current one
    root = tmp_path / "cache"
    for k in range(numba_cache.KEEP + 3):
        d = root / f"{k:016x}"
        d.mkdir(parents=True)
        os.utime(d, (1_000_000 + k, 1_000_000 + k))
    numba_cache._prune(root, f"{0:016x}")
    left = sorted(p.name for p in root.iterdir())
    assert f"{0:016x}" in left and len(left) == numba_cache.KEEP + 1
    monkeypatch.setenv("VEHVAL_NUMBA_CACHE", str(root))
    assert numba_cache.base_dir() == root
