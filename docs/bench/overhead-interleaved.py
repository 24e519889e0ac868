#!/usr/bin/env python3
"""The layer overhead of issue 18's params-floor target, interleaved.

Runs `omm-app overhead` over the Khronos Mock ICD with no layer, ommcheck at
one tier (default `params`) and the Khronos validation layer, one process
each, interleaved round by round over builds of 1, 10^3 and 10^5 micromap
triangles with 1 and 64 usage entries, so that load on the machine falls on
all three alike. Prints a markdown table of each call's median per
configuration and ommcheck's overhead over the Khronos layer's (each less
the no-layer time). The Khronos layer's two errors that come from the Mock
ICD's zero limits and zero buffer addresses (03793, 03802) are muted through
a vk_layer_settings.txt, so its BLAS figure is the cost of checking.

Needs target/release/omm-app and target/layer (`cargo xtask layer`;
`cargo build --release -p ommcheck-tests --bin omm-app`) and the variables
OMMCHECK_TEST_MOCK_ICD (the Mock ICD's manifest) and
OMMCHECK_TEST_KHRONOS_LAYER (the Khronos layer's manifest directory).

usage: docs/bench/overhead-interleaved.py ROUNDS ITERATIONS [TIER]
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile

MUTED = (
    "VUID-VkAccelerationStructureBuildGeometryInfoKHR-type-03793,"
    "VUID-vkCmdBuildAccelerationStructuresKHR-pInfos-03802"
)
SHAPES = [(t, k) for t in (1, 1000, 100000) for k in (1, 64)]
CONFIGS = {
    "none": [],
    "ommcheck": ["--layer", "VK_LAYER_OMMCHECK_validation"],
    "khronos": ["--layer", "VK_LAYER_KHRONOS_validation"],
}
CALLS = [
    ("cmd_build_micromaps", "`vkCmdBuildMicromapsEXT`"),
    ("build_micromaps", "`vkBuildMicromapsEXT` (host)"),
    ("cmd_build_acceleration_structures", "`vkCmdBuildAccelerationStructuresKHR` (BLAS, EXT attachment)"),
]


def main():
    rounds, iterations = int(sys.argv[1]), sys.argv[2]
    tier = sys.argv[3] if len(sys.argv) > 3 else "params"
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    settings = tempfile.mkdtemp()
    with open(os.path.join(settings, "vk_layer_settings.txt"), "w") as f:
        f.write(f"khronos_validation.message_id_filter = {MUTED}\n")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VK_", "OMMCHECK_"))}
    env.update(
        NODEVICE_SELECT="1",
        VK_DRIVER_FILES=os.environ["OMMCHECK_TEST_MOCK_ICD"],
        VK_ADD_LAYER_PATH=os.path.join(root, "target", "layer") + os.pathsep
        + os.environ["OMMCHECK_TEST_KHRONOS_LAYER"],
        VK_LAYER_SETTINGS_PATH=settings,
        OMMCHECK_TIER=tier,
    )
    app = os.path.join(root, "target", "release", "omm-app")
    runs = {}
    for r in range(rounds):
        for triangles, entries in SHAPES:
            for config, layers in CONFIGS.items():
                out = subprocess.run(
                    [app, "overhead", "--iterations", iterations, "--usage-entries",
                     str(entries), "--triangles", str(triangles)] + layers,
                    env=env, capture_output=True, text=True, check=True,
                ).stdout
                result = json.loads(out.strip().splitlines()[-1])
                messages = [m["id"] for m in result["messages"] if m["phase"] != "teardown"]
                ns = [result["results"]["ns_per_call"][key] for key, _ in CALLS]
                runs.setdefault((triangles, entries, config), []).append((ns, messages))
        print(f"round {r + 1} of {rounds} done", file=sys.stderr, flush=True)
    print(f"| micromap triangles | usage entries | call | no layer | ommcheck `{tier}` | Khronos "
          "| ommcheck overhead ÷ Khronos overhead |")
    print("| ---: | ---: | --- | ---: | ---: | ---: | ---: |")
    for triangles, entries in SHAPES:
        for i, (_, name) in enumerate(CALLS):
            med = {c: statistics.median(ns[i] for ns, _ in runs[(triangles, entries, c)])
                   for c in CONFIGS}
            ratio = (med["ommcheck"] - med["none"]) / (med["khronos"] - med["none"])
            print(f"| {triangles} | {entries} | {name} | {med['none']:.1f} ns "
                  f"| {med['ommcheck']:.0f} ns | {med['khronos']:.0f} ns | {ratio:.2f}× |")
    received = sorted({(key[2], m) for key, rs in runs.items() for _, ms in rs for m in ms})
    print("\nMessages received:", ", ".join(f"{c}: {m}" for c, m in received) or "none")


if __name__ == "__main__":
    main()
