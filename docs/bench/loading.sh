#!/bin/sh
# What loading a scene with an 8 MiB binary file costs, against reading the
# file's bytes into memory once (dd with one 8 MiB block). Needs hyperfine
# and python3; run from the workspace root. docs/cli.md records the results.
set -eu
cargo build --release -p ommcheck
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
python3 - "$dir" <<'PY'
import json, os, sys
out = sys.argv[1]
size = 8 << 20
scene = json.load(open("tests/scenes/ext-quad-valid.json"))
scene.pop("$schema", None)
for buffer in scene["buffers"]:
    if buffer["name"] == "omm-data":
        buffer["size"] = size
        buffer["contents"] = {"file": "data-8mib.bin"}
json.dump(scene, open(os.path.join(out, "scene.json"), "w"), indent=1)
head = open("tests/scenes/data/quad-2state-level3.bin", "rb").read()
open(os.path.join(out, "data-8mib.bin"), "wb").write(head + os.urandom(size - len(head)))
PY
hyperfine -N --warmup 5 --runs 60 \
    "dd if=$dir/data-8mib.bin of=/dev/null bs=8M count=1 status=none" \
    "target/release/ommcheck check $dir/scene.json --tier params" \
    "target/release/ommcheck check $dir/scene.json"
