#!/usr/bin/env bash
# Optional benchmark peers (FASTSim 3). A missing peer is reported by the benchmark, not fatal.
# fastsim pins plotly 6 for its own plotting, which the benchmark does not use; installing it
# without its dependency resolution keeps the project's pinned plotly for the reports.
set -u
BIN="$1"
"$BIN/python" -c "import fastsim" 2>/dev/null && exit 0
( "$BIN/python" -m pip install -q --no-deps "fastsim>=3.0" \
  && "$BIN/python" -m pip install -q msgpack polars typing-extensions ) \
  || echo "note: fastsim could not be installed; the peer comparison will be skipped"
exit 0
