#!/bin/sh
# scripts/refine.sh, the refinement loop's driver: a short real loop, and
# the loud failure where formfactor's --stats lack a key the loop reads (a
# renamed key used to end the loop after one pass, exit 0, no message).
#   refine_script.sh REFINE_SH BUILD_DIR WORKDIR
# BUILD_DIR holds formfactor and solve.
set -eu
script=$1 build=$2 dir=$3
mkdir -p "$dir" && cd "$dir" && rm -rf ./*
export OMP_NUM_THREADS=2
fail() { echo "FAIL: $*"; exit 1; }

# The loop as it runs: the Cornell box from --subdiv 1, one refinement pass.
bash "$script" --build "$build" --start-subdiv 1 --passes 1 --out real 2>real.err || { cat real.err; fail "the loop failed"; }
grep -q '"final_pass": 1' real/refine.json || { cat real/refine.json; fail "the loop stopped before pass 1"; }
grep -q 'pass 1: [0-9]* patches ([0-9]* split)' real.err || { cat real.err; fail "pass 1 did not say what it split"; }
[ -s real/radiosity ] || fail "no radiosity left"

# A build whose formfactor writes its stats with KEY renamed (the real
# formfactor, then the key edited): the loop must fail naming the key.
renamed() { # renamed KEY EXPECTED_MESSAGE
  rm -rf "fake_$1" "out_$1" && mkdir "fake_$1"
  ln -s "$build/solve" "fake_$1/solve"
  cat > "fake_$1/formfactor" <<SH
#!/bin/sh
"$build/formfactor" "\$@" || exit
stats="" prev=""
for a in "\$@"; do [ "\$prev" = --stats ] && stats=\$a; prev=\$a; done
sed -i 's/"$1":/"$1_renamed":/' "\$stats"
SH
  chmod +x "fake_$1/formfactor"
  if bash "$script" --build "fake_$1" --start-subdiv 1 --passes 2 --out "out_$1" 2>"err_$1"; then
    cat "err_$1"; fail "the loop ran on with \"$1\" renamed in formfactor's stats"
  fi
  grep -q "$2" "err_$1" || { cat "err_$1"; fail "no message naming \"$1\""; }
  [ ! -e "out_$1/refine.json" ] && [ ! -e "out_$1/radiosity" ] || fail "a failed loop left its results"
  echo "\"$1\" renamed: $(tail -n 1 "err_$1")"
}
renamed patches 'have no "patches"'
renamed split 'have no "refine.split"'
renamed over_max_patches 'have no "refine.over_max_patches"'
echo "refine script: ok"
