#!/bin/sh
# The README's example publisher against the real slamd, inside a private network namespace
# (run by ctest through scripts/netns-run). Usage: example_publisher_netns.sh SLAMD EXAMPLE SLAMCTL
set -eu
url="udpm://239.255.76.67:7667?ttl=0"
"$1" --lcm-url "$url" --log-level warn &
pid=$!
trap 'kill "$pid" 2>/dev/null || true' EXIT
# Wait for slamd's first status_t: the robot's first message (its prior) must not be missed.
"$3" status --lcm-url "$url" --timeout 10 > /dev/null
out=$("$2" "$url")
echo "$out"
echo "$out" | grep -q "pose 20 after the loop closure"
# The loop closure pulls pose 20 back to the origin to within a few centimetres.
echo "$out" | awk '{ if ($8 + 0 > 0.1 || $8 + 0 < -0.1 || $11 + 0 > 0.1 || $11 + 0 < -0.1) exit 1 }'
kill -TERM "$pid"
wait "$pid"
