#!/usr/bin/env bash
# Instructions per evaluation on the Cortex-M4F for each model and path, and for one FIT at
# N = 256, counted exactly under QEMU (firmware/brdf-fw/src/bin/cost.rs and fitcost.rs):
# with -icount shift=0 one instruction is one virtual nanosecond and SysTick ticks every 40.
# `--trace` also counts the evaluation paths from QEMU's per-instruction log between two
# marker functions, an independent check of the SysTick figures.
set -euo pipefail
cd "$(dirname "$0")/.."
command -v qemu-system-arm >/dev/null || { echo "SKIPPED: qemu-system-arm not installed"; exit 0; }
rustup target add thumbv7em-none-eabihf >/dev/null 2>&1
(cd firmware && cargo build --quiet --release -p brdf-fw --bin cost --bin fitcost)
dir=firmware/target/thumbv7em-none-eabihf/release
run() {
  qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic -monitor none \
    -semihosting-config enable=on,target=native "$@"
}
echo "instructions per evaluation (Cortex-M4F, release + LTO; khaki parameters; 100 evaluations each):"
run -icount shift=0 -kernel "$dir/cost" | sed 's/^/  /'
echo "on-sensor fit (the firmware's FIT command):"
run -icount shift=0 -kernel "$dir/fitcost" | sed 's/^/  /'
if [[ "${1:-}" == "--trace" ]]; then
  rustup component add llvm-tools >/dev/null 2>&1
  nm="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-nm"
  start=$("$nm" "$dir/cost" | awk '$3 == "cost_marker_start" {print $1}')
  end=$("$nm" "$dir/cost" | awk '$3 == "cost_marker_end" {print $1}')
  log=$(mktemp)
  trap 'rm -f "$log"' EXIT
  run -singlestep -d exec,nochain -D "$log" -kernel "$dir/cost" >/dev/null
  python3 - "$log" "$start" "$end" <<'PY'
import re, sys
log, start, end = sys.argv[1], int(sys.argv[2], 16), int(sys.argv[3], 16)
pcs = []
for line in open(log):
    m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/", line)
    if m:
        pcs.append(int(m.group(1), 16))
print("the same paths counted from the instruction log:")
i, path = 0, 1
while True:
    try:
        s = pcs.index(start, i)
        e = pcs.index(end, s)
    except ValueError:
        break
    print(f"  path {path}: {(e - s) / 100:.1f} instructions")
    i, path = e + 1, path + 1
PY
fi
