#!/bin/sh
# The installed tree works for people and for programs outside the project:
# `cmake --install` into a fresh prefix puts the programs, the library, its
# headers, the CMake package and radiosity.pc, the scenes and the docs in
# place; tests/consumer then builds against it with find_package(radiosity)
# and with pkg-config, and runs. Exit 77 (skipped): no pkg-config here.
#   install_consumer.sh CMAKE BUILD_DIR SOURCE_DIR WORKDIR VERSION LIBDIR CC GENERATOR [CFLAGS]
set -u
cmake=$1 build=$2 src=$3 dir=$4 version=$5 libdir=$6 cc=$7 generator=$8 cflags=${9:-}
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$dir" && mkdir -p "$dir" || exit 1
prefix=$dir/prefix
"$cmake" --install "$build" --prefix "$prefix" > "$dir/install.log" 2>&1 || fail "cmake --install: $(cat "$dir/install.log")"

for f in include/radiosity/rad_scene.h include/radiosity/rad_mesh.h include/radiosity/rad_ff_pair.h include/radiosity/rad_json.h \
         "$libdir/libradcore.a" "$libdir/cmake/radiosity/radiosityConfig.cmake" \
         "$libdir/cmake/radiosity/radiosityConfigVersion.cmake" "$libdir/pkgconfig/radiosity.pc" \
         share/radiosity/scenes/cornell_box.obj share/radiosity/scenes/cornell_box.mtl \
         share/radiosity/scenes/cornell_sphere.camera share/radiosity/scenes/README.md \
         share/doc/radiosity/README.md share/doc/radiosity/architecture.md; do
  [ -f "$prefix/$f" ] || fail "not installed: $f"
done
# Every program this build made is installed and runs from there.
for p in formfactor solve render; do
  [ -x "$build/$p" ] || continue
  out=$("$prefix/bin/$p" --version 2>&1) || fail "installed $p --version: $out"
  [ "$out" = "$p $version" ] || fail "installed $p --version said '$out'"
done
echo "ok: installed into $prefix"

# find_package(radiosity) with the prefix on CMAKE_PREFIX_PATH; no registry,
# so nothing but this prefix can answer.
"$cmake" -S "$src/tests/consumer" -B "$dir/cmake" -G "$generator" -DCMAKE_C_COMPILER="$cc" \
  -DCMAKE_C_FLAGS="$cflags" -DCMAKE_PREFIX_PATH="$prefix" -DRAD_EXPECT_VERSION="$version" \
  -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF > "$dir/cmake.log" 2>&1 || fail "consumer configure: $(cat "$dir/cmake.log")"
grep -q "radiosity $version from $prefix/" "$dir/cmake.log" || fail "found another radiosity: $(grep radiosity "$dir/cmake.log")"
"$cmake" --build "$dir/cmake" > "$dir/build.log" 2>&1 || fail "consumer build: $(cat "$dir/build.log")"
"$dir/cmake/consumer" || fail "consumer (find_package) failed"
echo "ok: find_package(radiosity) and radiosity::core"

# pkg-config, with the prefix's pkgconfig folder first.
command -v pkg-config > /dev/null || { echo "skipped: no pkg-config"; exit 77; }
PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
export PKG_CONFIG_PATH
pcv=$(pkg-config --modversion radiosity) || fail "pkg-config finds no radiosity"
[ "$pcv" = "$version" ] || fail "pkg-config --modversion radiosity said '$pcv'"
flags=$(pkg-config --cflags --libs radiosity) || fail "pkg-config --cflags --libs radiosity"
case "$flags" in *"-I$prefix/"*) ;; *) fail "pkg-config flags do not point into $prefix: $flags" ;; esac
# shellcheck disable=SC2086 # word splitting of the flags is meant
"$cc" $cflags -o "$dir/consumer_pc" "$src/tests/consumer/main.c" $flags > "$dir/cc.log" 2>&1 ||
  fail "cc \$(pkg-config --cflags --libs radiosity): $(cat "$dir/cc.log")"
"$dir/consumer_pc" || fail "consumer (pkg-config) failed"
echo "ok: pkg-config radiosity: $flags"
