#!/bin/bash
# Keyed `stewart emulate` + `stewart rig` measurements in a row on loopback, both at their
# default (real-time) priority, one line per run: the exit code, the host loop's largest period
# per run (report `link[].timing`), the emulator's latest tick (over the whole run, and while
# a session was being commanded) and slowest physics step, and the fault if any.
#
#   BUSY=2 scripts/stall_campaign.sh ...   runs it with that many busy loops on the host
#
#   scripts/stall_campaign.sh [BINARY] [RUNS] [DIR]
#
# defaults: target/release/stewart, 20, a temporary directory. The scenario is the default rig
# description with a 5 s tare and a 5 s loaded run (docs/rig.md, "Real-time priority").
set -u
BIN=${1:-target/release/stewart}; N=${2:-20}; DIR=${3:-$(mktemp -d)}
BIN=$(realpath "$BIN"); mkdir -p "$DIR"; cd "$DIR" || exit 1
printf '[run]\ntare_duration_s = 5.0\n' > c.toml
busy=()
for _ in $(seq 1 "${BUSY:-0}"); do yes > /dev/null & busy+=($!); done
trap '[ ${#busy[@]} -gt 0 ] && kill "${busy[@]}"' EXIT
[ -f k.key ] || "$BIN" key new --out k.key > /dev/null 2>&1
for i in $(seq 1 "$N"); do
  port=$((17000 + RANDOM % 2000))
  "$BIN" emulate --listen "udp://127.0.0.1:$port" --key k.key --config c.toml \
      > "emu$i.out" 2> "emu$i.err" &
  emulator=$!
  sleep 1
  "$BIN" rig --connect "udp://127.0.0.1:$port" --key k.key --no-prompt --config c.toml \
      --duration 5 --report "r$i.json" --log "l$i.mcap" --quiet > "rig$i.out" 2> "rig$i.err"
  code=$?
  kill -INT "$emulator"; wait "$emulator" 2> /dev/null
  python3 - "$i" "$code" "r$i.json" "emu$i.out" "rig$i.err" <<'PY'
import json, re, sys
i, code, report, emu, err = sys.argv[1:]
try:
    r = json.load(open(report))
    host = ", ".join("%s %.2f ms" % (l["run"], (l["timing"]["nominal_period_s"]
                     + l["timing"]["jitter_max_s"]) * 1e3) for l in r["link"])
except (OSError, ValueError, KeyError):
    host = "-"
text = open(emu).read()
m = re.search(r"the latest ([0-9.]+) ms late", text)
commanded = re.search(r"([0-9.]+) ms while commanded", text)
step = re.search(r"the slowest physics step ([0-9.]+) ms", text)
fault = [l for l in open(err).read().splitlines() if l.startswith(("fault", "error", "repeated"))]
print(f"run {i}: exit {code}; host largest period: {host}; emulator latest tick: "
      f"{m.group(1) + ' ms' if m else '-'}, {commanded.group(1) + ' ms' if commanded else '-'} while commanded (slowest step {step.group(1) + ' ms' if step else '-'})"
      f"{'; ' + fault[0][:160] if fault else ''}")
PY
done
