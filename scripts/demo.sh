#!/usr/bin/env bash
# The main job on bundled data (a virtual test when no other data is given).
set -euo pipefail
BIN="$1"; OUT="$2"
"$BIN/vehval" signals > /dev/null
echo "demo: registry loaded; outputs in $OUT"
