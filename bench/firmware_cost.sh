#!/usr/bin/env bash
# Instructions per evaluation for each model and path, and for one FIT at N = 256, counted
# exactly under QEMU (firmware/core-cost: src/bin/cost.rs and fitcost.rs) on three cores:
# the Cortex-M4F the firmware ships for (mps2-an386), a Cortex-M33 (mps2-an505) and a
# Cortex-M0+ without FPU (QEMU's microbit, a Cortex-M0: the same ARMv6-M instruction set;
# RAM enlarged to 64 KiB). The boards are the ones brdf_link::firmware::Core names.
# With -icount shift=0 one instruction is one virtual nanosecond and SysTick counts them
# (core-cost/src/ticks.rs).
#   bash bench/firmware_cost.sh            # evaluation paths on all three, FIT on M4F and M33
#   bash bench/firmware_cost.sh --m0-fit   # also the FIT on the M0+ (about 4 minutes)
#   bash bench/firmware_cost.sh --trace    # also count the paths from QEMU's instruction log
#                                          # between two marker functions (independent check)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v qemu-system-arm >/dev/null || { echo "SKIPPED: qemu-system-arm not installed"; exit 0; }
m0_fit=false trace=false
for a in "$@"; do
  case "$a" in
    --m0-fit) m0_fit=true ;;
    --trace) trace=true ;;
    *) echo "usage: bash bench/firmware_cost.sh [--m0-fit] [--trace]" >&2; exit 2 ;;
  esac
done
cores=(
  "Cortex-M4F|thumbv7em-none-eabihf|-machine mps2-an386 -cpu cortex-m4"
  "Cortex-M33|thumbv8m.main-none-eabihf|-machine mps2-an505 -cpu cortex-m33"
  "Cortex-M0+|thumbv6m-none-eabi|-machine microbit -global nrf51-soc.sram-size=65536"
)
run() {
  local machine="$1"; shift
  # shellcheck disable=SC2086
  qemu-system-arm $machine -nographic -monitor none \
    -semihosting-config enable=on,target=native "$@"
}
if $trace; then
  rustup component add llvm-tools >/dev/null 2>&1
  nm="$(rustc --print sysroot)/lib/rustlib/$(rustc -vV | sed -n 's/^host: //p')/bin/llvm-nm"
  log=$(mktemp)
  trap 'rm -f "$log" "$log.syms"' EXIT
fi
for core in "${cores[@]}"; do
  IFS='|' read -r name target machine <<<"$core"
  rustup target add "$target" >/dev/null 2>&1
  (cd firmware && cargo build --quiet --release -p core-cost --target "$target")
  dir=firmware/target/$target/release
  echo "== $name ($target; QEMU $machine)"
  echo "instructions per evaluation (release + LTO, opt-level s; khaki parameters; 100 evaluations each):"
  run "$machine" -icount shift=0 -kernel "$dir/cost" | sed 's/^/  /'
  if [[ "$name" != "Cortex-M0+" ]] || $m0_fit; then
    echo "on-sensor fit (the firmware's FIT command):"
    run "$machine" -icount shift=0 -kernel "$dir/fitcost" | sed 's/^/  /'
  fi
  if $trace; then
    "$nm" -n --defined-only "$dir/cost" >"$log.syms"
    run "$machine" -singlestep -d exec,nochain -D "$log" -kernel "$dir/cost" >/dev/null
    python3 - "$log" "$log.syms" <<'PY'
import bisect, re, sys
log, syms = sys.argv[1], sys.argv[2]
table = sorted((int(f[0], 16), f[2]) for f in (l.split() for l in open(syms)) if len(f) == 3)
addrs = [a for a, _ in table]
start = next(a for a, n in table if n == "cost_marker_start")
end = next(a for a, n in table if n == "cost_marker_end")
pcs = []
for line in open(log):
    m = re.search(r"\[[0-9a-f]+/([0-9a-f]+)/", line)
    if m:
        pcs.append(int(m.group(1), 16))
def soft_float(pc):
    # compiler-builtins' software floating point (and the integer helpers it calls).
    name = table[bisect.bisect_right(addrs, pc & ~1) - 1][1]
    return "compiler_builtins" in name or name.startswith(("__aeabi_", "__clz"))
print("the same paths counted from the instruction log (share in software floating point):")
i, path, spans = 0, 0, {}
while True:
    try:
        s = pcs.index(start, i)
        e = pcs.index(end, s)
    except ValueError:
        break
    soft = sum(soft_float(pc) for pc in pcs[s:e])
    print(f"  path {path}: {(e - s) / 100:.1f} instructions ({100 * soft / (e - s):.0f}%)")
    spans[path] = (s, e)
    i, path = e + 1, path + 1
# Where path 2 (six exact from cosines) and path 4 (the 256-node table from cosines) spend
# their instructions: per function, with the calls (entries at the function's first address)
# and instructions per call. Path 0 is the measuring loop alone.
starts = {a: n for a, n in table}
for path in (2, 4):
    calls, count = {}, {}
    for pc in pcs[spans[path][0]:spans[path][1]]:
        name = table[bisect.bisect_right(addrs, pc & ~1) - 1][1]
        count[name] = count.get(name, 0) + 1
        if (pc & ~1) in starts:
            calls[name] = calls.get(name, 0) + 1
    print(f"path {path} by function (instructions per evaluation, calls, instructions per call):")
    for name, k in sorted(count.items(), key=lambda x: -x[1])[:6]:
        c = calls.get(name, 0)
        per = f"{k / c:.0f}" if c else "-"
        print(f"  {k / 100:8.1f} {c / 100:6.1f} {per:>5}  {name[:100]}")
PY
  fi
done
