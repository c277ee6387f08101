#!/usr/bin/env bash
# Instructions per six-parameter evaluation on the Cortex-M4F, counted exactly under QEMU:
# firmware/brdf-fw/src/bin/cost.rs runs each path 100 times between two marker functions,
# QEMU logs every executed instruction (-singlestep -d exec), and this script counts the
# instructions between the markers.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v qemu-system-arm >/dev/null || { echo "SKIPPED: qemu-system-arm not installed"; exit 0; }
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1
rustup component add llvm-tools >/dev/null 2>&1
(cd firmware && cargo build --quiet --release -p brdf-fw --bin cost)
elf=firmware/target/thumbv7em-none-eabihf/release/cost
nm="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-nm"
start=$("$nm" "$elf" | awk '$3 == "cost_marker_start" {print $1}')
end=$("$nm" "$elf" | awk '$3 == "cost_marker_end" {print $1}')
log=$(mktemp)
trap 'rm -f "$log"' EXIT
qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
  -semihosting-config enable=on,target=native -singlestep -d exec,nochain -D "$log" -kernel "$elf"
python3 - "$log" "$start" "$end" <<'PY'
import re, sys
log, start, end = sys.argv[1], int(sys.argv[2], 16), int(sys.argv[3], 16)
pcs = []
for line in open(log):
    m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/", line)
    if m:
        pcs.append(int(m.group(1), 16))
names = {1: "exact f32 from angles", 2: "exact f32 from cosines"}
i, path = 0, 1
print("instructions per evaluation (Cortex-M4F, release + LTO, libm; 100 evaluations each):")
while True:
    try:
        s = pcs.index(start, i)
        e = pcs.index(end, s)
    except ValueError:
        break
    print(f"  {names.get(path, path)}: {(e - s) / 100:.1f}")
    i, path = e + 1, path + 1
PY
