#!/usr/bin/env bash
# Evaluation speed and accuracy of every path (scalar and batch, f64 and f32, angles, cosines
# and vectors, one core and all cores) against numpy on the same 10^6-point grid in the same
# run (`brdf bench eval`; add --json for one JSON object), plus the flash cost of an eval-only
# Cortex-M4F program. Extra arguments go to `brdf bench eval`.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! python3 -c "import numpy" 2>/dev/null; then
  python3 -m pip install --quiet numpy || echo "numpy could not be installed; the peer will be skipped"
fi
cargo run --quiet --release -p brdf-cli -- bench eval "$@"

echo
echo "Flash cost of brdf-core on thumbv7em-none-eabihf (release, LTO): eval-only programs"
if rustup target add thumbv7em-none-eabihf >/dev/null 2>&1 && rustup component add llvm-tools >/dev/null 2>&1; then
  (cd firmware && cargo build --quiet --release -p size-probe -p brdf-fw)
  size="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-size"
  for bin in eval_cosines eval_angles; do
    text=$("$size" -A "firmware/target/thumbv7em-none-eabihf/release/$bin" | awk '$1 == ".text" {print $2}')
    echo "  $bin: .text $text bytes"
  done
  (cd firmware && cargo build --quiet --release -p brdf-fw --no-default-features --features hardware \
    --target-dir target/hardware)
  echo "Firmware brdf-fw (flash = text + data, static RAM = data + bss):"
  for build in qemu:firmware/target hardware:firmware/target/hardware; do
    "$size" "${build#*:}/thumbv7em-none-eabihf/release/brdf-fw" | tail -n 1 |
      awk -v b="${build%%:*}" '{print "  " b ": text " $1 ", data " $2 ", bss " $3 " bytes; flash " $1 + $2 ", static RAM " $2 + $3}'
  done
else
  echo "  SKIPPED: thumbv7em-none-eabihf target or llvm-tools could not be installed"
fi
