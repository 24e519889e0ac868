#!/bin/sh
# What checking a multi-GiB micromap bake costs, against reading its files
# once: `big_bake` writes the scene (GIB GiB of data and triangle array,
# default 4) into target/big-bake/ (DIR/big-bake/ with DIR set: a disk with
# room), a copy of the scene whose buffers are 4 KiB
# larger than their files is added, and each command runs RUNS times
# (default 7), interleaved, with the page cache warm, then 5 times cold
# (the bake's own files dropped from the page cache before each run:
# posix_fadvise DONTNEED, which leaves everyone else's cache alone). Peak
# memory from /usr/bin/time. The files are deleted at the end. Needs
# python3 and /usr/bin/time; run from the workspace root. docs/cli.md
# records the results.
set -eu
gib=${GIB:-4}
runs=${RUNS:-7}
cargo build --release -p ommcheck --bin ommcheck --example big_bake
ommcheck=$PWD/target/release/ommcheck
dir=$(realpath -m "${DIR:-target}")/big-bake
trap 'rm -rf "$dir"' EXIT
target/release/examples/big_bake "$dir" --gib "$gib"
cd "$dir"
python3 - <<'PY'
import json
scene = json.load(open("big-bake.json"))
for buffer in scene["buffers"][:2]:
    buffer["size"] += 4096
json.dump(scene, open("big-bake-padded.json", "w"))
PY
files="big-bake.data.bin big-bake.triangles.bin"
bench() { # RUNS EVICT(0|1) NAME=COMMAND...
    python3 - "$@" <<'PY'
import os, shlex, statistics, subprocess, sys, time
runs, evict, commands = int(sys.argv[1]), sys.argv[2] == "1", sys.argv[3:]
files = ["big-bake.data.bin", "big-bake.triangles.bin"]
times = {c: [] for c in commands}
for _ in range(runs):
    for c in commands:
        if evict:
            for f in files:
                fd = os.open(f, os.O_RDONLY)
                os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
                os.close(fd)
        start = time.perf_counter()
        subprocess.run(shlex.split(c.split("=", 1)[1]), stdout=subprocess.DEVNULL, check=True)
        times[c].append(time.perf_counter() - start)
for c, t in times.items():
    print(f"{c.split('=')[0]:22} min {min(t):.3f}  median {statistics.median(t):.3f}  max {max(t):.3f} s")
PY
}
cat $files > /dev/null
echo "warm, $runs runs each:"
bench "$runs" 0 "cat-both=cat $files" "cat-triangles=cat big-bake.triangles.bin" \
    "params=$ommcheck check big-bake.json --tier params" "content=$ommcheck check big-bake.json" \
    "padded-params=$ommcheck check big-bake-padded.json --tier params" \
    "padded-content=$ommcheck check big-bake-padded.json"
echo "cold, 5 runs each:"
bench 5 1 "cat-both=cat $files" "cat-triangles=cat big-bake.triangles.bin" \
    "params=$ommcheck check big-bake.json --tier params" "content=$ommcheck check big-bake.json" \
    "padded-content=$ommcheck check big-bake-padded.json"
cat $files > /dev/null
for scene in big-bake big-bake-padded; do
    for tier in params content; do
        /usr/bin/time -f "$scene $tier: max RSS %M KB" "$ommcheck" check "$scene.json" --tier "$tier" > /dev/null
    done
done
