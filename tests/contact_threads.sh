#!/bin/sh
# Contact cutting surveys the faces on the threads, then cuts the few it
# must in face order on one (core/rad_contact.c): the mesh, its cut
# vertices and their numbers are the same for any thread count. The links
# file of --subdiv 0 holds that mesh (its leaves), so it is compared byte
# for byte at 1 and 3 threads, on Blender exports whose faces are cut
# (suzanne_table: 105 of 994 faces, pieces hidden under the head) and
# whose parallel faces nearly touch (text: near misses counted).
#   contact_threads.sh FORMFACTOR CORPUS_DIR WORKDIR
set -u
ff=$1 corpus=$2 dir=$3
mkdir -p "$dir" && cd "$dir" || exit 1
failed=0
for scene in suzanne_table text; do
  for t in 1 3; do
    OMP_NUM_THREADS=$t "$ff" "$corpus/$scene.obj" --method hierarchical --subdiv 0 --link-tol 0.1 -q \
      -o "$scene.$t.ff" 2> "$scene.$t.err" || { echo "FAIL: $scene on $t threads: $(cat "$scene.$t.err")"; exit 1; }
  done
  cmp "$scene.1.ff" "$scene.3.ff" || { echo "FAIL: $scene: 1 and 3 threads cut differently"; failed=1; }
done
[ "$failed" -eq 0 ] && echo "contacts: the same mesh for 1 and 3 threads"
exit "$failed"
