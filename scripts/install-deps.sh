#!/usr/bin/env bash
# Installs the Debian packages radiosity builds and tests with (bookworm).
# Runs apt-get only for what is missing; uses sudo when not root.
set -euo pipefail
# clang and libclang-rt-14-dev: libFuzzer and its sanitizer runtimes for the
# fuzz smoke run of scripts/test.sh (docs/reliability.md). dpkg-dev and
# file: cpack's .deb (dpkg-shlibdeps writes its Depends; file finds the
# programs it reads). python3-openimageio: OpenImageIO's own Python
# bindings, which tools/exrread.py reads EXR with. assimp-testmodels: the
# OBJ test files of another loader, meshes for tests/corpus.sh.
packages=(build-essential cmake pkg-config libopenmpi-dev openmpi-bin libembree-dev
          libopenimageio-dev openimageio-tools python3-numpy python3-matplotlib
          python3-openimageio clang libclang-rt-14-dev dpkg-dev file assimp-testmodels)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "install-deps: installing ${missing[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
