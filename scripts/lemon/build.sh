#!/bin/sh
# Builds the LEMON benchmark driver (needs Debian's liblemon-dev; not a test dependency).
# Usage: scripts/lemon/build.sh [out-dir]   (default: target/lemon)
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-"$here/../../target/lemon"}
mkdir -p "$out"
${CXX:-g++} -O2 -DNDEBUG -std=c++14 -o "$out/lemon_matching" "$here/lemon_matching.cpp" -lemon 2>/dev/null \
  || ${CXX:-g++} -O2 -DNDEBUG -std=c++14 -o "$out/lemon_matching" "$here/lemon_matching.cpp"
echo "$out/lemon_matching"
