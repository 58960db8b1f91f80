#!/usr/bin/env bash
# Writes the whole of docs/measurements/rsm.md (issue 5's RSM measurements); the work is done by
# scripts/measure-rsm.py, which see for options (--sections, --out, --allow-dirty) and environment.
export MEASURE_RSM_ARGV0=${MEASURE_RSM_ARGV0:-scripts/measure-rsm.sh}
exec python3 "$(dirname "$0")/measure-rsm.py" "$@"
