#!/usr/bin/env bash
# Render a report offline in headless Chromium and save a full-page PNG (checks that the page and
# every embedded figure render with no network). Needs Debian's chromium: apt-get install chromium.
# Usage: tools/screenshot_report.sh results/report.html [out.png] [height_px]
set -euo pipefail
report="$(realpath "$1")"
out="${2:-${report%.html}.png}"
height="${3:-12000}"
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --hide-scrollbars --window-size=1200,"$height" \
  --screenshot="$(realpath -m "$out")" "file://$report" 2>/dev/null
echo "wrote $out"
