#!/usr/bin/env bash
# The 20 reference images of a restructuring (issue 40): every scene at its defaults, and the
# options that drive frames and samples (--accumulate, --frames, --animate-to, --reseed,
# --no-bloom, --steps), drawn by this checkout and by commit REF, compared byte for byte.
#
#   bash benchmarks/reference_images.sh REF [OUT]    OUT: where the images go (default a temp)
#
# Prints "same NAME" or "DIFFERS NAME" for each and exits 1 if any differs or fails. Small
# sizes (128x128, 1k-16k particles): about 45 s a tree on llvmpipe.
set -u
cd "$(dirname "$0")/.."
ROOT=$(pwd)
REF=${1:?give the commit to compare with}
OUT=${2:-$(mktemp -d)}
PY=python3
[ -x .venv/bin/python ] && PY=$ROOT/.venv/bin/python
OLD="$OUT/tree"
git worktree add -q --detach "$OLD" "$REF" || exit 1
trap 'git -C "$ROOT" worktree remove --force "$OLD"' EXIT

draw() {  # draw TREE FOLDER
  local tree=$1 folder=$2 S="--size 128x128"
  mkdir -p "$folder"
  while read -r name args; do
    # shellcheck disable=SC2086
    (cd "$folder" && PYTHONPATH=$tree $PY -m es2particles run $args $S --out "$name" \
      >/dev/null 2>"$name.err") || echo "FAILED $name (see $folder/$name.err)"
  done <<'LIST'
dejong.png dejong --particles 16384
dejong-reseed.png dejong --reseed --particles 16384
dejong-acc.png dejong --accumulate 4 --particles 16384
dejong-reseed-acc.png dejong --reseed --accumulate 4 --particles 16384
dejong-anim.png dejong --reseed --frames 3 --animate-to 1.9,-2.1,2.2,-1.8 --particles 16384
dejong-nobloom.png dejong --no-bloom --particles 16384
clifford.png clifford --particles 16384
clifford-acc.png clifford --accumulate 2 --particles 16384
collision.png collision --particles 4096
collision-frames.png collision --frames 3 --particles 4096
collision-acc.png collision --accumulate 3 --particles 4096
fountain.png fountain --particles 1024
fountain-frames.png fountain --frames 2 --particles 1024
collision3d.png collision3d --particles 2048
collision3d-steps.png collision3d --steps 30 --particles 2048
confetti.png confetti --particles 1024
smoke.png smoke --particles 2048
smoke-frames.png smoke --frames 2 --particles 2048
wind.png wind --particles 4096
wind-frames.png wind --frames 2 --particles 4096
LIST
}

draw "$OLD" "$OUT/before"
draw "$ROOT" "$OUT/after"
code=0
for f in "$OUT"/before/*.png; do
  name=$(basename "$f")
  if cmp -s "$f" "$OUT/after/$name"; then echo "same $name"; else echo "DIFFERS $name"; code=1; fi
done
echo "images in $OUT/before and $OUT/after"
exit $code
