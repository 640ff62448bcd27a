#!/usr/bin/env bash
# Optional benchmark peers (FASTSim). A missing peer is reported by the benchmark, not fatal.
set -u
BIN="$1"
"$BIN/python" -c "import fastsim" 2>/dev/null && exit 0
"$BIN/python" -m pip install -q -c constraints.txt ".[bench]" 2>/dev/null \
  || "$BIN/python" -m pip install -q "fastsim>=3.0" \
  || echo "note: fastsim could not be installed; peer comparison will be skipped"
exit 0
