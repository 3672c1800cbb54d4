#!/usr/bin/env bash
# Install the Debian packages the tests use, only those that are missing.
#
#   chromium  headless check that the HTML report shows every figure
#   g++       compiler for the C++ feature extraction
#
# Installs non-interactively with apt-get, as root or through sudo where sudo needs no
# password. Where neither is possible (or apt-get is absent, or the install fails) it says
# so and exits 0: the tests that need a package then skip with their own reason.
set -uo pipefail

# package:command that shows it is installed
wanted=(chromium:chromium g++:g++)

missing=()
for entry in "${wanted[@]}"; do
    pkg=${entry%%:*}
    cmd=${entry#*:}
    command -v "$cmd" >/dev/null 2>&1 || missing+=("$pkg")
done
[ ${#missing[@]} -eq 0 ] && exit 0

skip() {
    echo "system-deps: not installing ${missing[*]}: $1; the tests that need them will skip" >&2
    exit 0
}

command -v apt-get >/dev/null 2>&1 || skip "apt-get not found (not Debian or Ubuntu)"
if [ "$(id -u)" -eq 0 ]; then
    as_root=()
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
    as_root=(sudo -n)
else
    skip "not root and sudo is not available without a password"
fi

echo "system-deps: installing ${missing[*]} with apt-get" >&2
export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq >/dev/null || skip "apt-get update failed"
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null \
    || skip "apt-get install failed"
for pkg in "${missing[@]}"; do
    echo "system-deps: installed $pkg" >&2
done
