#!/usr/bin/env bash
# Renders docs/*.dot to docs/*.svg (Debian: graphviz).
set -euo pipefail
cd "$(dirname "$0")"
for f in *.dot; do dot -Tsvg "$f" -o "${f%.dot}.svg"; done
