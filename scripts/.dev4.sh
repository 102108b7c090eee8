#!/bin/bash
cmake -S . -B /tmp/b -DCMAKE_BUILD_TYPE=Release -DRAD_WITH_RENDER=OFF -DCMAKE_CUDA_ARCHITECTURES=90 > $OUT/cmake.log 2>&1
cmake --build /tmp/b -j16 > $OUT/build.log 2>&1 || { tail -50 $OUT/build.log; exit 1; }
git log --oneline | head -1
FF=/tmp/b/formfactor
Q="--method hierarchical --uniform-leaves --quad-rtol 1e-5 --shadow-rays 8"
for r in 1 2 3 4 5 6 7; do
  /usr/bin/time -f "quickstart auto wall %e" $FF $Q --radiosity /dev/shm/cb_auto.rad --stats $OUT/st_auto.json 2> $OUT/err_auto.log
  tail -1 $OUT/err_auto.log | grep wall; python3 -c "import json;d=json.load(open('$OUT/st_auto.json'));t=d['times'];print('   ',d['backend'],{k:round(v,3) for k,v in t.items() if k!='load'})"
done
grep "backend auto" $OUT/err_auto.log
for r in 1 2 3; do /usr/bin/time -f "quickstart cuda wall %e" $FF $Q --backend cuda --radiosity /dev/shm/cb_cuda.rad 2>&1 | grep wall; done
for r in 1 2 3; do /usr/bin/time -f "link-tol 1.5e-2 auto wall %e" $FF $Q --link-tol 1.5e-2 --radiosity /dev/shm/cb15.rad 2>&1 | grep wall; done
/tmp/b/tests/radiosity_close /dev/shm/cb_auto.rad /dev/shm/cb_cuda.rad 1e-5 | tail -1
S="scenes/cornell_sphere.obj --method hierarchical --subdiv 6 --uniform-leaves --link-tol 1e-3"
for r in 1 2 3; do /usr/bin/time -f "sphere L6 1e-3 wall %e peak %M KB" $FF $S --radiosity /dev/shm/s6.rad 2>&1 | grep -E "wall"; done
ctest --test-dir /tmp/b -L gpu -j4 --output-on-failure > $OUT/ctest_gpu.log 2>&1; grep -E "tests passed|Failed|FAIL" $OUT/ctest_gpu.log | head
grep -A3 "auto takes" $OUT/ctest_gpu.log | head -3
