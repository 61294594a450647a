#!/usr/bin/env bash
# Fresh-clone timings of a make target, trees one after the other (docs/performance.md):
#   scripts/fresh_clone.sh TARGET LABEL=COMMIT [LABEL=COMMIT ...]     e.g. test base=de6810f new=HEAD
# Per tree: git clone of this repository, git checkout COMMIT, then an empty NUMBA_CACHE_DIR and
# /usr/bin/time -v make TARGET; prints the wall seconds, user and system time and peak memory.
# Run it with nothing else running on the machine.
set -u
repo=$(git -C "$(dirname "$0")/.." rev-parse --show-toplevel)
target=$1; shift
for spec in "$@"; do
  label=${spec%%=*}; commit=${spec#*=}
  dir=$(mktemp -d /tmp/fresh-clone-$target-$label-XXXX)
  git clone -q "$repo" "$dir/repo" && git -C "$dir/repo" checkout -q "$commit"
  start=$(date +%s)
  ( cd "$dir/repo" && NUMBA_CACHE_DIR="$dir/numba-cache" /usr/bin/time -v make "$target" \
      > "$dir/log" 2>&1 )
  end=$(date +%s)
  echo "$(date -u +%H:%M) make $target $label ($commit): $((end - start)) s wall;" \
       "$(grep -E 'Elapsed|Maximum resident|User time|System time' "$dir/log" | tr -s ' ' | tr '\n' ';')" \
       "log: $dir/log"
done
