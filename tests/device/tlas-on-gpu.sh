#!/bin/bash
# Runs omm-app's top-level scenario (issue 14's instance test) on a machine
# with an NVIDIA GPU and no network, with and without ommcheck, for every
# way the instance reaches its buffer. Prepare, in the repository root:
#   cargo build --release -p ommcheck-tests --bin omm-app -p ommcheck-layer
#   mkdir -p .devrun && cp target/release/omm-app target/release/libVkLayer_ommcheck.so .devrun/
#   a manifest .devrun/VkLayer_ommcheck.json whose library_path is ./libVkLayer_ommcheck.so
#   Debian's loader and GL dispatch packages in .gl/ (apt-get download libvulkan1
#   libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2), where the machine lacks them.
# Writes $OUT/tlas-runs.txt: one header line and omm-app's JSON per run.
set -u
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
nvidia-smi -L
export VK_ADD_LAYER_PATH=$PWD/.devrun OMMCHECK_REPORT=error,warning,info
out=${OUT:-.}/tlas-runs.txt
for way in copy update fill compute mapped; do
  for valid in "" "--valid"; do
    for layer in "" "--layer VK_LAYER_OMMCHECK_validation"; do
      echo "=== way=$way valid=${valid:-no} layer=${layer:-none} readback=default" >> "$out"
      .devrun/omm-app tlas --way $way $valid $layer >> "$out" 2>&1; echo "exit $?" >> "$out"
    done
  done
  echo "=== way=$way valid=no layer=ommcheck readback=false" >> "$out"
  OMMCHECK_GPU_READBACK=false .devrun/omm-app tlas --way $way --layer VK_LAYER_OMMCHECK_validation >> "$out" 2>&1
  echo "exit $?" >> "$out"
done
