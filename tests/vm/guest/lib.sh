# Helpers shared by /init and the scenarios (sourced by busybox sh).
#
# The guest's adapter is i2c-stub, as /dev/i2c-0 (scenario 61 adds a second,
# plain-I2C one, i2c-plain-stub, as /dev/i2c-1). The example policies
# name their devices `at i2c-1`, so contego maps its bus 1 onto i2c-stub's
# node (BUS_ARGS) and the supervised programs talk to /dev/i2c-1, a node that
# (but in scenario 61) exists only inside contego's emulation. Everything read back with
# `stub_get`/`stub_word` goes through the kernel directly, outside contego:
# it is what reached the "device".

# One simulated chip per device address the scenarios use: PCA9685 (arm,
# 0x40), GoPiGo2 (0x08), line follower (0x06), tank level sensor and buzzer
# (0x48, 0x20), display (0x3c). The pump's 0x50/0x51 are left out on purpose:
# the start-failure scenario needs a policy whose device is missing.
STUB_ADDRS=0x40,0x08,0x06,0x48,0x20,0x3c
ADAPTER=/dev/i2c-0
BUS_ARGS="--bus 1=$ADAPTER"
POLICIES=/vm/policies
CLIENTS=/vm/clients
SOCK=/run/contego/monitor.sock
TASK_UID=1000
MONITOR_UID=990

# busybox sh runs its own applets before searching PATH, and busybox has
# i2c applets: these functions make the scripts' i2c commands the real
# i2c-tools. (Programs started by contego are exec'd from PATH: real too.)
for t in i2cdetect i2cget i2cset i2cdump i2ctransfer; do eval "$t() { /usr/sbin/$t \"\$@\"; }"; done

now_ms() { awk '{ printf "%d", $1 * 1000 }' /proc/uptime; }

wait_for() {  # wait_for PATH SECONDS: until PATH exists
  i=0
  while [ ! -e "$1" ]; do
    i=$((i + 1))
    [ $i -gt $(($2 * 10)) ] && return 1
    usleep 100000
  done
}

# The bus node belongs to the monitor's user alone (mode 0600), as the README's
# udev rule has it: a task's own uid cannot open it.
own_adapter() {
  wait_for $ADAPTER 10 || { echo "no $ADAPTER"; return 1; }
  chown $MONITOR_UID:$MONITOR_UID $ADAPTER && chmod 0600 $ADAPTER
}

stub_load() {
  insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS || return 1
  insmod /lib/modules/i2c-dev.ko || return 1
  own_adapter
}

# A fresh stub: every register of every chip back to zero.
stub_reload() {
  rmmod i2c_stub || { echo "VM-CHECK FAIL ${SCENARIO:-init}: i2c-stub still in use"; return 1; }
  insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS && own_adapter
}

# Safety net between scenarios: nothing a scenario started may outlive it
# (an open descriptor on the adapter would keep i2c-stub loaded).
cleanup_processes() {
  for name in contego contego-monitor python3 python3.11 i2c-write-loop i2ctransfer i2cset i2cget i2cdump \
      attack_rdwr_race attack_signal_storm attack_static attack_pid_reuse attack_identity attack_rdwr_atomic \
      kmod_sessions; do
    for pid in $(pidof $name); do kill -KILL "$pid" 2>/dev/null; done
  done
  rm -rf /run/contego
}

# ---- results ---------------------------------------------------------------
FAILS=0
CHECKS=0
ok() { CHECKS=$((CHECKS + 1)); echo "VM-CHECK PASS $SCENARIO: $*"; }
bad() { CHECKS=$((CHECKS + 1)); FAILS=$((FAILS + 1)); echo "VM-CHECK FAIL $SCENARIO: $*"; }
finish() {
  [ $CHECKS -gt 0 ] || bad "no checks ran"
  exit $FAILS
}
check() {  # check DESCRIPTION COMMAND...: passes when the command succeeds
  d=$1; shift
  if "$@"; then ok "$d"; else bad "$d"; fi
}

# ---- the adapter, read and written outside contego -------------------------
stub_get() { i2cget -y 0 "$1" "$2" b; }
stub_set() { i2cset -y 0 "$1" "$2" "$3" b; }
stub_word() {  # stub_word ADDR LOW_REG: the little-endian 16-bit value at LOW_REG, LOW_REG+1 (decimal)
  lo=$(stub_get "$1" "$2") && hi=$(stub_get "$1" "$(printf '0x%02x' $(($2 + 1)))") &&
    echo $(( (hi << 8) | lo ))
}
expect_reg() {  # expect_reg ADDR REG VALUE DESCRIPTION
  got=$(stub_get "$1" "$2")
  if [ $((got)) = $(($3)) ]; then ok "$4 (reg $2 = $got)"; else bad "$4 (reg $2 = $got, expected $3)"; fi
}
expect_word() {  # expect_word ADDR LOW_REG VALUE DESCRIPTION
  got=$(stub_word "$1" "$2")
  if [ "$got" = "$3" ]; then ok "$4 (= $got)"; else bad "$4 (= $got, expected $3)"; fi
}
snapshot() { i2cdump -y 0 "$1" b 2>&1; }

# ---- running programs ---------------------------------------------------------
LOGDIR=/tmp/${SCENARIO:-shell}
mkdir -p "$LOGDIR"
chmod 777 "$LOGDIR"

# show LABEL FILE: a program's output, indented, so the console log explains a failure
show() { sed "s/^/    | /" "$1"; }

# run_logged LABEL COMMAND...: runs, prints output, sets RC and OUT (the output file)
run_logged() {
  label=$1; shift
  OUT=$LOGDIR/$label.out
  echo "  \$ $*"
  "$@" >"$OUT" 2>&1
  RC=$?
  show "$OUT"
  [ $RC = 0 ] || echo "    (exit $RC)"
  return 0
}

# as_task COMMAND...: run as the unprivileged control-task user (uid 1000,
# in group contego, so it may reach the monitor's socket but not the bus).
as_task() {
  cmd=""
  # an absolute program path: busybox's `exec` would prefer its own applet
  [ -x "/usr/sbin/$1" ] && { first=/usr/sbin/$1; shift; set -- "$first" "$@"; }
  for a in "$@"; do cmd="$cmd '$(echo "$a" | sed "s/'/'\\\\''/g")'"; done
  su task -s /bin/sh -c "cd /tmp && exec $cmd"
}

# under MODE POLICY TASK PROGRAM...: PROGRAM supervised by contego, either with
# the monitor embedded in `contego run` (MODE=embedded, as root: it must open
# the bus itself; the program runs as uid 1000 with `--user`, as a deployment
# runs it) or through the monitor daemon (MODE=monitor, the program and
# its supervisor as uid 1000; start_monitor first).
under() {
  mode=$1 policy=$2 task=$3; shift 3
  case $mode in
    embedded)
      contego run --policy "$POLICIES/$policy" $BUS_ARGS --user 1000 --task "$task" \
        --audit "$LOGDIR/embedded-audit.jsonl" -- "$@" ;;
    monitor)
      as_task contego run --socket $SOCK --task "$task" -- "$@" ;;
    *) echo "under: unknown mode $mode"; return 2 ;;
  esac
}

# start_monitor POLICY [ARGS...]: the daemon as the contego user, sole owner of
# the adapter, serving uid 1000; waits for its socket.
MONITOR_PID=
start_monitor() {
  policy=$1; shift
  mkdir -p /run/contego
  chown $MONITOR_UID:$MONITOR_UID /run/contego
  chmod 0750 /run/contego
  MONITOR_LOG=$LOGDIR/monitor.log
  echo "  \$ contego monitor --policy $POLICIES/$policy $BUS_ARGS --socket $SOCK --client-uid $TASK_UID $*  (as contego)"
  su contego -s /bin/sh -c "exec contego monitor --policy $POLICIES/$policy $BUS_ARGS \
    --socket $SOCK --client-uid $TASK_UID --audit $LOGDIR/monitor-audit.jsonl $*" \
    >"$MONITOR_LOG" 2>&1 &
  MONITOR_PID=$!
  if ! wait_for $SOCK 60; then
    show "$MONITOR_LOG"
    bad "monitor did not start"
    return 1
  fi
  # the socket is 0660 contego's? let the task group reach it whatever the umask
  return 0
}
stop_monitor() {  # SIGTERM, as systemd stops the unit; it must be gone within 15 s
  [ -n "$MONITOR_PID" ] || return 0
  kill -TERM $MONITOR_PID 2>/dev/null
  i=0
  while kill -0 $MONITOR_PID 2>/dev/null && [ $i -lt 150 ]; do usleep 100000; i=$((i + 1)); done
  if kill -0 $MONITOR_PID 2>/dev/null; then
    bad "contego monitor still running 15 s after SIGTERM (killed)"
    kill -KILL $MONITOR_PID
  fi
  wait $MONITOR_PID
  echo "  monitor stopped (exit $?)"
  MONITOR_PID=
}

# A directory both root and the task user can write (handshakes with clients).
sync_dir() { d=$(mktemp -d /tmp/sync.XXXXXX) && chmod 777 "$d" && echo "$d"; }
# await DIR NAME: until the client has created DIR/sent-NAME (60 s at most).
await() {  # await DIR NAME [PID]: also gives up at once when PID has exited
  i=0
  while [ ! -e "$1/sent-$2" ]; do
    i=$((i + 1))
    if [ $i -gt 600 ] || { [ -n "$3" ] && ! kill -0 "$3" 2>/dev/null; }; then
      bad "client never reached step $2"
      return 1
    fi
    usleep 100000
  done
}
ack() { touch "$1/ack-$2"; }
# the supervised program's (or monitor's) log so far, on failure
show_audit_summary() {  # the last records of each audit log, shortened, for the console
  for f in "$LOGDIR"/*audit.jsonl; do
    [ -f "$f" ] || continue
    echo "  audit $(basename "$f"), last records:"
    # tail -c seeks: the log is extended with zeros 256 KiB ahead, and reading all
    # of it under TCG is slow
    tail -c 8192 "$f" | tr -d '\000' | tail -n 6 | cut -c1-220 | sed 's/^/    | /'
  done
}

# The GoPiGo2 stub: a frame 01 cmd v1 v2 v3 arrives as an SMBus I2C-block
# write of cmd v1 v2 v3 at register 0x01, so registers 1..4 show the last frame.
gopigo_frame() {  # prints "cmd v1 v2 v3" in hex as on the stub
  for r in 1 2 3 4; do printf '%02x ' $(( $(stub_get 0x08 $r) )); done | sed 's/ $//'
}
gopigo_clear() { for r in 1 2 3 4; do stub_set 0x08 $r 0; done; }
expect_frame() {  # expect_frame "46 50 00 00" DESCRIPTION
  got=$(gopigo_frame)
  if [ "$got" = "$1" ]; then ok "$2 (stub: $got)"; else bad "$2 (stub: $got, expected $1)"; fi
}
