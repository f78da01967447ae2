#!/usr/bin/env bash
# fogmap set-up on Debian 12 as root: installs the missing Debian packages, configures CMake
# (Release) and builds with 2 jobs, then either renders the default scene (`render`) or runs the
# default test suite through ctest (`test`; heavy validation is behind the CTest label "heavy").
set -euo pipefail
cd "$(dirname "$0")/.."

action="${1:-render}"
mapfile -t packages < <(grep -v '^\s*#' scripts/debian-packages | grep -v '^\s*$')
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "fogmap: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}" </dev/null
fi

# Every system header the code includes must come from a package installed above (a header only
# present on the developer's machine once broke this script on a fresh one).
bash scripts/check_headers.sh

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2

case "$action" in
  render)
    ./build/fogmap render scenes/smoke.json -o out/smoke.exr
    ;;
  test)
    cd build && ctest -LE heavy --output-on-failure -j2
    ;;
  *)
    echo "usage: scripts/bootstrap.sh [render|test]" >&2
    exit 2
    ;;
esac
