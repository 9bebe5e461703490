#!/bin/sh
# Runs blossomquad's solver and LEMON on the same graph files, one after the other, and prints
# a table: solver wall time (s), our solver CPU time (s; steadier on a shared machine), peak
# RSS (MB), cost agreement, LEMON/blossomquad ratio (wall times).
# Usage: scripts/lemon/compare.sh graph1.txt [graph2.txt ...]
# Env: SOLVE (path to the solve_matching example binary), LEMON (path to lemon_matching);
# defaults build both (cargo build --release --example solve_matching, scripts/lemon/build.sh).
# SOLVE_ARGS: extra arguments of solve_matching, e.g. "--given-order" (our solver keeps the
# file's vertex numbering, as the recombination does on graphs it numbered in Morton order).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root="$here/../.."
tdir=${CARGO_TARGET_DIR:-"$root/target"}
if [ -z "${SOLVE:-}" ]; then
  (cd "$root" && cargo build --release --example solve_matching >/dev/null 2>&1)
  SOLVE="$tdir/release/examples/solve_matching"
fi
if [ -z "${LEMON:-}" ]; then
  LEMON=$("$here/build.sh" "$tdir/lemon")
fi
field() { sed -n "s/.*$1=\([^ ]*\).*/\1/p" | head -n1; }
rss() { sed -n 's/.*Maximum resident set size (kbytes): \([0-9]*\).*/\1/p' | head -n1; }
printf '%-28s %9s %9s %8s %8s %9s %8s %7s %s\n' file n ours_s ours_cpu ours_MB lemon_s lemon_MB ratio same_cost
for f in "$@"; do
  # shellcheck disable=SC2086 # SOLVE_ARGS is a list of words
  o=$(/usr/bin/time -v "$SOLVE" "$f" ${SOLVE_ARGS:-} 2>&1 || true)
  l=$(/usr/bin/time -v "$LEMON" "$f" 2>&1 || true)
  n=$(echo "$o" | field n)
  ot=$(echo "$o" | field time_s); ocpu=$(echo "$o" | field cpu_s); oc=$(echo "$o" | field cost); om=$(echo "$o" | rss)
  lt=$(echo "$l" | field time_s); lc=$(echo "$l" | field cost); lm=$(echo "$l" | rss)
  ver=$(echo "$o" | field verified)
  ratio=$(awk -v a="$lt" -v b="$ot" 'BEGIN { if (b > 0) printf "%.1f", a / b; else print "-" }')
  same=no; [ "$oc" = "$lc" ] && same=yes
  printf '%-28s %9s %9s %8s %8d %9s %8d %7s %s (verified=%s)\n' "$(basename "$f")" "$n" "$ot" \
    "$ocpu" $((om / 1024)) "$lt" $((lm / 1024)) "$ratio" "$same" "$ver"
done
