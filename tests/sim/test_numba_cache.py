"""The compiled-kernel cache follows every source change (vehval.numba_cache)."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

from vehval import numba_cache

SRC = Path(__file__).resolve().parents[2] / "src"


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

    import vehval.sim.kernel  # noqa: F401 - its decorators configured the cache on import

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


def test_every_kernel_is_decorated_through_the_cache():
    """No module but vehval.numba_cache takes ``njit`` (or ``jit``) from numba itself: a
    kernel decorated with numba's own would be cached where the cache is not configured."""
    bad = []
    for path in sorted((SRC / "vehval").rglob("*.py")):
        if path.name == "numba_cache.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("numba"):
                bad += [f"{path.name}:{node.lineno}" for a in node.names if a.name in ("njit", "jit")]
            elif (isinstance(node, ast.Attribute) and node.attr in ("njit", "jit")
                  and isinstance(node.value, ast.Name) and node.value.id == "numba"):
                bad.append(f"{path.name}:{node.lineno}")
    assert not bad, bad


def test_a_kernel_module_imported_alone_is_cached_in_the_version_directory(tmp_path):
    """The analysis's replay kernel, imported first in a fresh interpreter (no vehval.sim
    before it), keeps its compiled code in this source version's directory."""
    code = ("import sys\nimport vehval.analysis.replay_kernel as k\n"
            "from vehval import numba_cache\n"
            "assert 'vehval.sim.kernel' not in sys.modules\n"
            "print(numba_cache.fingerprint())\nprint(k.lagged_agreement._cache.cache_path)")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]),
               VEHVAL_NUMBA_CACHE=str(tmp_path))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    fp, cache_path = proc.stdout.split()
    assert Path(cache_path).is_relative_to(tmp_path / fp)
