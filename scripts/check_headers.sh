#!/usr/bin/env bash
# Every system header the code includes (#include <...> in src/, tests/, bench/) must come from a
# Debian package listed in scripts/debian-packages (or from the C/C++ toolchain): a header that is
# merely present on one machine breaks the README's commands on a fresh one. `dpkg -S` says which
# package owns each header file. Exits 1 naming the headers and packages that are not listed.
set -euo pipefail
cd "$(dirname "$0")/.."

listed=" $(grep -v '^\s*#' scripts/debian-packages | tr '\n' ' ') "
failed=0
for h in $(grep -rhoE '^\s*#\s*include\s*<[^>]+>' src tests bench |
           sed -E 's/.*<([^>]+)>.*/\1/' | sort -u); do
    # The standard folders first; then a search that follows symlinks (MPI's headers are reached
    # through Debian's alternatives), and dpkg -S wants the real path.
    file=""
    for d in /usr/include /usr/include/x86_64-linux-gnu; do
        if [ -e "$d/$h" ]; then file="$d/$h"; break; fi
    done
    [ -z "$file" ] && file=$(find -L /usr/include -path "*/$h" -print -quit 2>/dev/null || true)
    [ -n "$file" ] && file=$(readlink -f "$file")
    if [ -z "$file" ]; then
        case "$h" in *.*|*/*) ;; *) continue ;; esac  # <vector> etc.: the C++ library itself
        echo "check_headers: <$h> is included but no installed package provides it" >&2
        failed=1
        continue
    fi
    owner=$(dpkg -S "$file" 2>/dev/null | head -n 1 | cut -d: -f1 | cut -d, -f1) || true
    case "$owner" in
        libc6-dev|linux-libc-dev|libstdc++-*|libgcc-*|gcc-*|g++-*) continue ;;
        "") echo "check_headers: <$h> ($file) belongs to no Debian package" >&2; failed=1 ;;
        *) if [[ "$listed" != *" $owner "* ]]; then
               echo "check_headers: <$h> comes from $owner, which scripts/debian-packages does not list" >&2
               failed=1
           fi ;;
    esac
done
[ "$failed" = 0 ] && echo "check_headers: every included system header comes from a listed package"
exit "$failed"
