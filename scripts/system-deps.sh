#!/usr/bin/env bash
# Debian packages the project needs at run time: libtbb12 for ecospy (the second co-simulation
# master used in the tests). Installed only when missing; needs root or sudo.
set -euo pipefail
missing=()
for pkg in libtbb12; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else
  echo "system-deps: missing ${missing[*]} and no root; install them with apt-get" >&2; exit 1
fi
echo "system-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
