#!/usr/bin/env bash
# Debian packages the project needs: libtbb12 for ecospy (the ECOS engine used in the tests),
# libatomic1 for libcosimpy's libcosimc.so, libxml2, libminizip1 and libsundials-cvode6 for
# fmusim (the FMI standard's reference master, ../shared/tools/fmusim, run by the tests),
# valgrind, under which tests/fmu/test_host_failures.py
# runs the C host's failed starts, and a C compiler, with which build_fmu.py compiles the FMU's
# loader (fmu_native/loader.c) and the tests their C hosts. Installed only when missing; needs
# root or sudo.
set -euo pipefail
missing=()
for pkg in libtbb12 libatomic1 libxml2 libminizip1 libsundials-cvode6 valgrind; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done
if ! command -v cc >/dev/null && ! command -v gcc >/dev/null; then
  missing+=(gcc libc6-dev)
fi
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else
  echo "system-deps: missing ${missing[*]} and no root; install them with apt-get" >&2; exit 1
fi
echo "system-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}" >/dev/null
