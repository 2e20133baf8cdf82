#!/bin/bash
# The booted Debian guest's scenario (docs/testbed.md), run by
# guest-scenario.service once multi-user.target is reached, as root, output on
# the serial console. It installs the package and sets contego up with the
# README's "Install" commands exactly as written (/vm/readme/NN.sh, extracted
# on the host; the only change: the guest's adapter is /dev/i2c-0 where the
# README's robot has /dev/i2c-1), checks what a robot's owner relies on, and
# removes and purges the package. Every check prints one line:
#   VM-CHECK PASS|FAIL booted: WHAT
# and the end VM-RESULT PASS|FAIL booted, then VM-DONE.
set -u
export DEBIAN_FRONTEND=noninteractive PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
SCENARIO=booted
FAILS=0 CHECKS=0
ok() { CHECKS=$((CHECKS + 1)); echo "VM-CHECK PASS $SCENARIO: $*"; }
bad() { CHECKS=$((CHECKS + 1)); FAILS=$((FAILS + 1)); echo "VM-CHECK FAIL $SCENARIO: $*"; }
check() { d=$1; shift; if "$@" >/dev/null 2>&1; then ok "$d"; else bad "$d"; fi; }
show() { sed 's/^/    | /' "$@"; }
A=0x40 LED5_OFF=0x1c PRESCALE=0xfe
# i2c-stub keeps byte and word writes apart: read and write LED5_OFF as bytes,
# as the PCA9685's users (and contego's safe state) write them.
word() { echo $(($(i2cget -y 0 $A $LED5_OFF) | $(i2cget -y 0 $A $((LED5_OFF + 1))) << 8)); }
set_word() { i2cset -y 0 $A $LED5_OFF $(($1 & 255)) && i2cset -y 0 $A $((LED5_OFF + 1)) $(($1 >> 8)); }
reg() { i2cget -y 0 $A "$1" 2>/dev/null; }

# Runs README block N (of the section in /vm/readme, or of DIR) as written,
# echoing each command; the robot's adapter 1 is the guest's 0.
readme() {
  local dir=${2:-/vm/readme}
  local name=${dir##*/}-$1
  echo "  README block $1 (${dir##*/}):"
  sed 's#/dev/i2c-1#/dev/i2c-0#g; s#adapters=1#adapters=0#g' "$dir/$1.sh" >"/tmp/$name.sh"
  show "/tmp/$name.sh"
  (cd /vm/pkg && bash -e -x "/tmp/$name.sh") >"/tmp/$name.out" 2>&1
  local rc=$?
  show "/tmp/$name.out" | tail -n 25
  return $rc
}

echo "VM-BOOTED $(uname -r), systemd $(systemctl --version | awk 'NR==1 { print $2 }'), $(systemctl is-system-running)"

# The "robot": a PCA9685 at 0x40 on the guest's only adapter, i2c-stub.
modprobe i2c-stub chip_addr=$A && modprobe i2c-dev ||
  { bad "modprobe i2c-stub chip_addr=$A and i2c-dev"; }
udevadm settle
i2cset -y 0 $A $PRESCALE 0x1e # the chip out of reset: 200 Hz
set_word 0

# The user's control program (the README's CONTEGO_PROGRAM): the arm's
# gripper, as python3-smbus2 drives a PCA9685 (four byte writes per pulse,
# one pulse per job of 1 s): 420, 577, 420 (the test bed's sequence), two
# writes arm.policy does not allow, and a high pulse 900 that the policy's
# fail-safe replaces by the expected 577.
mkdir -p /opt/robot
cat >/opt/robot/gripper.py <<'EOF'
import errno, os, signal, time
from smbus2 import SMBus

def attempt(what, fn):
    try:
        fn()
        print("GRIPPER", what, "ok", flush=True)
    except OSError as e:
        print("GRIPPER", what, errno.errorcode.get(e.errno, e.errno), flush=True)

with SMBus(1) as bus:
    def pulse(p):
        for reg, value in ((0x1A, 0), (0x1B, 0), (0x1C, p & 0xFF), (0x1D, p >> 8)):
            bus.write_byte_data(0x40, reg, value)
    attempt("pulse-420", lambda: pulse(420))
    time.sleep(1.05)
    attempt("pulse-577", lambda: pulse(577))
    time.sleep(1.05)
    attempt("pulse-420", lambda: pulse(420))
    time.sleep(1.05)
    attempt("prescale-3", lambda: bus.write_byte_data(0x40, 0xFE, 0x03))
    attempt("address-0x41", lambda: bus.write_byte_data(0x41, 0x00, 0x01))
    time.sleep(1.05)
    attempt("pulse-900", lambda: pulse(900))
    try:  # what the chip's LED5 off holds now, read by the program itself
        print("GRIPPER led5", bus.read_byte_data(0x40, 0x1C) | bus.read_byte_data(0x40, 0x1D) << 8, flush=True)
    except OSError as e:
        print("GRIPPER led5", errno.errorcode.get(e.errno, e.errno), flush=True)
print("GRIPPER holding", flush=True)
# SIGUSR1 (once the scenario reloaded the policy): two pulses on LED0, one
# per job: 560, then 590, which the reloaded policy's servo window refuses.
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGUSR1})
signal.sigwait({signal.SIGUSR1})
with SMBus(1) as bus:
    def pulse0(p):
        for reg, value in ((0x06, 0), (0x07, 0), (0x08, p & 0xFF), (0x09, p >> 8)):
            bus.write_byte_data(0x40, reg, value)
    attempt("after-reload led0-560", lambda: pulse0(560))
    time.sleep(1.05)
    attempt("after-reload led0-590", lambda: pulse0(590))
print("GRIPPER after-reload done", flush=True)
while True:
    time.sleep(3600)
EOF

# ---- the README, as written ---------------------------------------------------
blocks=$(ls /vm/readme | sed 's/\.sh$//' | sort -n)
last=$(echo "$blocks" | tail -n1)
for n in $blocks; do
  [ "$n" = "$last" ] && break # the removal, after the checks
  if readme "$n"; then ok "README Install block $n runs as written (exit 0)"; else bad "README Install block $n failed"; fi
done

# ---- installed ----------------------------------------------------------------
check "dpkg: contego installed from the local file, no network" dpkg-query -W -f='${Status}' contego
getent passwd contego >/dev/null && getent group contego-client >/dev/null &&
  ok "sysusers: user contego, group contego-client" || bad "sysusers: no user contego or group contego-client"
own=$(stat -c '%U:%G %a' /dev/i2c-0 2>&1)
[ "$own" = "contego:contego 660" ] && ok "udev rule: /dev/i2c-0 is $own" || bad "udev rule: /dev/i2c-0 is $own, not contego:contego 660"
check "contego-monitor.service active (Type=notify: READY after the safe state)" systemctl is-active contego-monitor
check "contego-run@gripper.service active" systemctl is-active contego-run@gripper
uid=$(id -u contego-gripper)
muid=$(awk '/^Uid:/ { print $2 }' /proc/"$(systemctl show -p MainPID --value contego-monitor)"/status)
[ "$muid" = "$(id -u contego)" ] && ok "the monitor runs as the user contego (uid $muid)" || bad "the monitor runs as uid $muid"
# The unit's `contego monitor --policy` compiled the policy and became the
# small daemon (same main PID): what decides is contego-monitor.
mexe=$(readlink /proc/"$(systemctl show -p MainPID --value contego-monitor)"/exe)
[ "$mexe" = /usr/bin/contego-monitor ] && ok "the unit's main process is $mexe" || bad "the unit's main process is $mexe, not /usr/bin/contego-monitor"
# The units' exposure as systemd rates it (recorded in docs/packaging.md).
for unit in contego-monitor.service contego-run@gripper.service; do
  sec=$(systemd-analyze security --no-pager "$unit" 2>&1 | grep 'Overall exposure level')
  [ -n "$sec" ] && ok "systemd-analyze security $unit: ${sec#*: }" || bad "systemd-analyze security $unit printed no exposure level"
done

# The program's own view, in its journal.
for i in $(seq 1 100); do
  journalctl -u contego-run@gripper --no-pager -o cat | grep -q 'GRIPPER holding' && break
  sleep 0.2
done
journalctl -u contego-run@gripper --no-pager -o cat >/tmp/gripper.log
show /tmp/gripper.log | tail -n 12
allowed=$(grep -a '"task_name":"gripper"' /var/log/contego/audit.jsonl | grep -ac '"decision":"allow"')
grep -q 'GRIPPER pulse-577 ok' /tmp/gripper.log && [ "$allowed" -ge 12 ] &&
  ok "the program works through the socket: pulses 420, 577, 420 allowed ($allowed writes in the audit log)" ||
  bad "the program's pulses were not allowed ($allowed allowed writes)"
[ "$(word)" = 577 ] && ok "high pulse 900 replaced on the stub by the expected 577 (i2cget: LED5 off=$(word))" ||
  bad "after the high pulse 900 LED5 off=$(word), not 577"
[ "$(reg $PRESCALE)" = 0x1e ] && ok "forbidden command (gripper's PRE_SCALE=0x03) not on the stub: i2cget PRE_SCALE=$(reg $PRESCALE)" ||
  bad "PRE_SCALE is $(reg $PRESCALE) after the gripper's forbidden write"
grep -q 'GRIPPER address-0x41 ok' /tmp/gripper.log && bad "write to 0x41 (not in the policy) succeeded" ||
  ok "write to 0x41 (not in the policy) refused: $(grep -o 'address-0x41 .*' /tmp/gripper.log)"
err=$(setpriv --reuid="$uid" --regid=nogroup --groups="$(getent group contego-client | cut -d: -f3)" \
  python3 -c 'import os, errno
try:
    os.open("/dev/i2c-0", os.O_RDWR); print("opened")
except OSError as e:
    print(errno.errorcode[e.errno])' 2>&1)
[ "$err" = EACCES ] && ok "contego-gripper cannot open /dev/i2c-0 itself: $err" || bad "contego-gripper opening /dev/i2c-0: $err"
# `contego doctor` on the installed robot, as root: the node is the
# monitor's alone, the monitor answers at its socket, no problem.
contego doctor >/tmp/doctor.out 2>&1
rc=$?
show /tmp/doctor.out
[ $rc = 0 ] && grep -q '^\[ ok \] /dev/i2c-0 .*(the monitor.s alone)' /tmp/doctor.out &&
  grep -q '^\[ ok \] a monitor answers at /run/contego/monitor.sock' /tmp/doctor.out &&
  ok "contego doctor: the node the monitor's alone, the monitor answering, exit 0" ||
  bad "contego doctor on the installed system (exit $rc)"

# ---- audit log and journal ----------------------------------------------------
n=$(wc -l </var/log/contego/audit.jsonl 2>/dev/null || echo 0)
[ "$n" -gt 0 ] && ok "audit log fills: /var/log/contego/audit.jsonl has $n records ($(stat -c '%U:%G %a' /var/log/contego/audit.jsonl))" ||
  bad "no audit log under /var/log/contego"
viol=$(grep -av '"decision":"allow"' /var/log/contego/audit.jsonl | grep -c '"kind":"decision"')
[ "$viol" -gt 0 ] && ok "the violations are in the audit log ($viol records)" || bad "no violation in the audit log"
journalctl -u contego-monitor --no-pager -o cat >/tmp/monitor.log
show /tmp/monitor.log | tail -n 8
grep -qE 'contego: task .*: (ignore|failsafe|reject) of' /tmp/monitor.log && ok "violations in the journal: $(grep -cE 'contego: task .*: (ignore|failsafe|reject) of' /tmp/monitor.log) lines (journalctl -u contego-monitor)" ||
  bad "no violation in the journal (journalctl -u contego-monitor)"
# Structured: each violation an entry with a priority, its MESSAGE_ID and the
# policy's names as fields; the start a notice with the image's hash; the
# catalog explains them (journalctl -x).
journalctl -u contego-monitor CONTEGO_KIND=decision --no-pager -o export >/tmp/decisions.export
grep -aE '^(PRIORITY|MESSAGE_ID|CONTEGO_[A-Z_]+)=' /tmp/decisions.export | head -n 9 | show
grep -aqx 'MESSAGE_ID=334d55ae757948bf9f52f566d57d4744' /tmp/decisions.export &&
  grep -aqE '^PRIORITY=[45]$' /tmp/decisions.export && grep -aqx 'CONTEGO_TASK=gripper' /tmp/decisions.export &&
  grep -aqE '^CONTEGO_VERDICT=(ignore|failsafe|reject)$' /tmp/decisions.export &&
  ok "journal entries: $(grep -ac '^MESSAGE_ID=334d55ae757948bf9f52f566d57d4744$' /tmp/decisions.export) decisions with PRIORITY, MESSAGE_ID and CONTEGO_TASK/DEVICE/RULE/VERDICT (journalctl CONTEGO_KIND=decision)" ||
  bad "no structured decision entry in the journal"
journalctl -u contego-monitor CONTEGO_KIND=start -p notice --no-pager -o export >/tmp/start.export
grep -aqE '^CONTEGO_IMAGE_SHA256=[0-9a-f]{64}$' /tmp/start.export &&
  ok "the start entry is a notice with CONTEGO_IMAGE_SHA256 (journalctl CONTEGO_KIND=start -p notice)" ||
  bad "no start entry with the image's hash in the journal"
journalctl --list-catalog 2>/dev/null | grep -q '^334d55ae757948bf9f52f566d57d4744 ' &&
  ok "the journal's catalog explains the monitor's entries (journalctl --list-catalog)" ||
  bad "contego.catalog is not in the journal's catalog"

# ---- the status group: read-only, through its own socket ----------------------
# An operator in contego-status reads `contego status` with no option (the
# monitor's socket is out of reach, the status socket is tried next) and can
# do nothing else there; a user outside the group is refused at connect.
useradd --system --no-create-home --groups contego-status viewer 2>/dev/null
useradd --system --no-create-home outsider 2>/dev/null
st=$(runuser -u viewer -- contego status 2>&1)
echo "$st" | grep -q 'gripper' && echo "$st" | grep -q 'sessions 1' &&
  ok "a member of contego-status reads the status: $(echo "$st" | grep -m1 'gripper' | sed 's/^ *//')" ||
  bad "a member of contego-status cannot read the status: $st"
st=$(runuser -u viewer -- contego reset arm --socket /run/contego-status/status.sock 2>&1)
rc=$?
[ $rc != 0 ] && echo "$st" | grep -q 'status requests only' &&
  ok "the status socket refuses a reset from contego-status: $st" ||
  bad "a reset through the status socket: exit $rc, $st"
st=$(runuser -u outsider -- contego status 2>&1)
rc=$?
[ $rc != 0 ] && ok "a user outside contego-status is refused: $st" ||
  bad "a user outside contego-status read the status"
[ "$(stat -c '%G %a' /run/contego-status)" = "contego-status 2750" ] &&
  ok "/run/contego-status is 2750, group contego-status (tmpfiles.d)" ||
  bad "/run/contego-status is $(stat -c '%G %a' /run/contego-status)"

# ---- --require-signed, with the installed daemon ------------------------------
# contego-monitor as a robot runs it from a signed bundle (here on a virtual
# bus beside the unit's monitor): an unsigned bundle and a changed one are
# refused before anything is driven; the signed one starts, and a reload
# refuses an unsigned or wrongly signed bundle while the signed policy stays.
if [ -f /vm/signed/robot.pub ]; then
  keys=/tmp/keys; mkdir -p $keys; cp /vm/signed/robot.pub $keys/
  rs() { contego-monitor --require-signed --keys-dir $keys --virtual-bus 1 --audit /tmp/rs.jsonl "$@"; }
  out=$(rs --bundle /vm/signed/unsigned.bundle --socket /tmp/rs.sock 2>&1)
  rc=$?
  [ $rc = 2 ] && echo "$out" | grep -q 'has no signature' &&
    ok "--require-signed refuses an unsigned bundle (exit 2): $(echo "$out" | head -n1 | cut -c1-150)" ||
    bad "--require-signed with an unsigned bundle: exit $rc, $out"
  out=$(rs --bundle /vm/signed/changed.bundle --socket /tmp/rs.sock 2>&1)
  rc=$?
  [ $rc = 2 ] && echo "$out" | grep -q 'does not match the signed data' &&
    ok "--require-signed refuses a changed bundle (exit 2): $(echo "$out" | head -n1 | cut -c1-150)" ||
    bad "--require-signed with a changed bundle: exit $rc, $out"
  contego-monitor --require-signed --keys-dir $keys --virtual-bus 1 --audit /tmp/rs.jsonl \
    --bundle /vm/signed/arm.bundle --socket /tmp/rs.sock >/tmp/rs.out 2>&1 &
  rspid=$!
  for i in $(seq 1 100); do [ -S /tmp/rs.sock ] && break; sleep 0.1; done
  grep -aq 'signed by key ID' /tmp/rs.jsonl 2>/dev/null &&
    ok "the signed bundle starts under --require-signed: $(grep -ao 'signed by key ID [0-9A-F]*' /tmp/rs.jsonl | head -n1)" ||
    bad "the signed bundle did not start: $(cat /tmp/rs.out)"
  out=$(contego reload --bundle /vm/signed/unsigned.bundle --socket /tmp/rs.sock 2>&1)
  rc=$?
  [ $rc = 1 ] && echo "$out" | grep -q 'require-signed' &&
    ok "a reload of an unsigned bundle is refused (exit 1), the signed policy stays" ||
    bad "a reload of an unsigned bundle: exit $rc, $out"
  out=$(contego reload --bundle /vm/signed/changed.bundle --socket /tmp/rs.sock 2>&1)
  rc=$?
  [ $rc = 1 ] && ok "a reload of a wrongly signed bundle is refused (exit 1): $(echo "$out" | cut -c1-150)" ||
    bad "a reload of a wrongly signed bundle: exit $rc, $out"
  kill $rspid; wait $rspid 2>/dev/null
else
  echo "  skipped: the --require-signed checks (no minisign on the host when the guest was made)"
fi

# ---- reload in place: a changed limit while the program runs ------------------
led0() { echo $(($(i2cget -y 0 $A 0x08) | $(i2cget -y 0 $A 0x09) << 8)); }
hash_of_status() { contego status --json | python3 -c 'import json, re, sys; print(re.search("SHA-256 ([0-9a-f]{64})", json.load(sys.stdin)["policy"])[1])'; }
mpid=$(systemctl show -p MainPID --value contego-monitor)
gpid=$(systemctl show -p MainPID --value contego-run@gripper)
old=$(hash_of_status)
led5_before=$(word)
printf 'task broken {\n' >/tmp/broken.policy
contego reload --policy /tmp/broken.policy >/tmp/reload-broken.out 2>&1
rc=$?
[ $rc = 2 ] && grep -q 'does not compile' /tmp/reload-broken.out &&
  ok "contego reload of a policy that does not compile: exit 2, $(head -n1 /tmp/reload-broken.out)" ||
  bad "contego reload of a broken policy: exit $rc"
contego check /etc/contego/robot.policy --emit-bundle /tmp/robot.bundle >/dev/null 2>&1
python3 - /tmp/robot.bundle /tmp/bad.bundle <<'PY'
import hashlib, json, sys
b = json.load(open(sys.argv[1]))
image = bytearray.fromhex(b["image"])
image[-1] ^= 0xFF  # the image's last byte: its checksum no longer holds
b["image"], b["image_sha256"] = image.hex(), hashlib.sha256(image).hexdigest()
json.dump(b, open(sys.argv[2], "w"))
PY
contego reload --bundle /tmp/bad.bundle >/tmp/reload-bad.out 2>&1
rc=$?
[ $rc = 1 ] && [ "$(hash_of_status)" = "$old" ] &&
  ok "a corrupt image refused (exit 1), the old policy stays: $(head -n1 /tmp/reload-bad.out | cut -c1-160)" ||
  bad "a corrupt bundle's reload: exit $rc, policy now $(hash_of_status)"
sed -i 's/^const SERVO_MAX = 600 /const SERVO_MAX = 580 /' /etc/contego/robot.policy
if contego reload --policy /etc/contego/robot.policy >/tmp/reload.out 2>&1; then
  ok "contego reload --policy /etc/contego/robot.policy: $(cut -c1-200 /tmp/reload.out)"
else
  bad "contego reload failed: $(cat /tmp/reload.out)"
fi
new=$(hash_of_status)
# The program (no procps in the guest: its pid from /proc).
for p in /proc/[0-9]*; do
  [ "$(tr '\0' ' ' <"$p/cmdline" 2>/dev/null)" = "/usr/bin/python3 /opt/robot/gripper.py " ] &&
    kill -USR1 "${p#/proc/}"
done
for i in $(seq 1 100); do
  journalctl -u contego-run@gripper --no-pager -o cat | grep -q 'GRIPPER after-reload done' && break
  sleep 0.2
done
journalctl -u contego-run@gripper --no-pager -o cat | grep 'after-reload' | show
[ "$(systemctl show -p MainPID --value contego-monitor)" = "$mpid" ] &&
  [ "$(systemctl show -p MainPID --value contego-run@gripper)" = "$gpid" ] &&
  ok "the monitor (pid $mpid) and the supervised program's unit (pid $gpid) kept running through the reload" ||
  bad "a reload restarted the monitor or the program"
[ "$new" != "$old" ] && grep -a '"kind":"reload"' /var/log/contego/audit.jsonl | grep -q "$old -> $new" &&
  ok "the reload record names both images: ${old:0:12}... -> ${new:0:12}... (contego status names the new one)" ||
  bad "no reload record with both hashes (status: $new)"
[ "$(word)" = "$led5_before" ] &&
  ! sed -n '/"kind":"reload"/,$p' /var/log/contego/audit.jsonl | grep -q '"kind":"safe-state"' &&
  ok "no safe state driven by the reload (LED5 off stays $led5_before)" ||
  bad "the reload drove the safe state (LED5 off $led5_before -> $(word))"
[ "$(led0)" = 560 ] && grep -a '"rule_name":"SERVO_WINDOW"' /var/log/contego/audit.jsonl | grep -q '"fields":\[0,590,' &&
  ok "the new limit is in effect: LED0 560 allowed, 590 ignored by the reloaded SERVO_WINDOW (LED0 off=$(led0))" ||
  bad "after the reload LED0 off=$(led0), the 590 pulse not refused by the new window"

# ---- stop: the safe state -----------------------------------------------------
set_word 0x41 # anything but the safe state
systemctl stop contego-monitor
[ "$(word)" = 420 ] && ok "systemctl stop contego-monitor drives the safe state (LED5 off=420)" ||
  bad "after systemctl stop LED5 off=$(word), not 420"
check "contego-run@gripper stopped with the monitor" sh -c '! systemctl is-active -q contego-run@gripper'

# ---- restart: the chain stays verifiable --------------------------------------
systemctl start contego-monitor contego-run@gripper || bad "systemctl start contego-monitor failed"
gpid=$(systemctl show -p MainPID --value contego-run@gripper)
# The restart takes the metrics file (docs/deployment.md, "Metrics").
sed -i 's#^CONTEGO_MONITOR_OPTS="\(.*\)"$#CONTEGO_MONITOR_OPTS="\1 --metrics-file /run/contego-metrics/contego.prom"#' /etc/default/contego
grep -q 'metrics-file' /etc/default/contego || bad "--metrics-file not added to /etc/default/contego"
systemctl restart contego-monitor || bad "systemctl restart contego-monitor failed"
check "contego-monitor active after restart" systemctl is-active contego-monitor
# The task units follow the monitor: restarted with it (PartOf=), and back
# by themselves after a monitor that was killed is started again by systemd.
active_gripper() {
  for i in $(seq 1 100); do
    systemctl is-active -q contego-monitor && systemctl is-active -q contego-run@gripper &&
      [ "$(systemctl show -p MainPID --value contego-run@gripper)" != "$1" ] && return 0
    sleep 0.2
  done
  return 1
}
active_gripper "$gpid" && ok "systemctl restart contego-monitor restarts contego-run@gripper after it (PartOf=)" ||
  bad "contego-run@gripper not back after systemctl restart contego-monitor ($(systemctl is-active contego-run@gripper))"
gpid=$(systemctl show -p MainPID --value contego-run@gripper)
systemctl kill -s KILL contego-monitor
active_gripper "$gpid" && ok "after SIGKILL of the monitor, systemd starts it again and contego-run@gripper comes back" ||
  bad "after SIGKILL of the monitor: monitor $(systemctl is-active contego-monitor), gripper $(systemctl is-active contego-run@gripper)"

# ---- the fleet's tools: node_exporter serves the metrics, the journal ships ----
# The metrics file, as docs/deployment.md sets it up (the restart above took
# --metrics-file from /etc/default/contego), scraped over loopback.
for i in $(seq 1 50); do [ -s /run/contego-metrics/contego.prom ] && break; sleep 0.2; done
prometheus-node-exporter --web.listen-address=127.0.0.1:9111 \
  --collector.textfile.directory=/run/contego-metrics >/tmp/node-exporter.log 2>&1 &
nepid=$!
for i in $(seq 1 100); do
  curl -sf http://127.0.0.1:9111/metrics >/tmp/scrape.txt 2>/dev/null && grep -q '^contego_info' /tmp/scrape.txt && break
  sleep 0.2
done
kill $nepid 2>/dev/null
grep '^contego_' /tmp/scrape.txt | head -n 6 | show
grep -q '^contego_decisions_total{' /tmp/scrape.txt && grep -q '^contego_info{.*image_sha256="[0-9a-f]\{64\}"' /tmp/scrape.txt &&
  ok "node_exporter's textfile collector serves the monitor's metrics (curl http://127.0.0.1:9111/metrics: $(grep -c '^contego_' /tmp/scrape.txt) contego_ samples)" ||
  bad "the metrics are not served by node_exporter ($(stat -c '%U:%G %a' /run/contego-metrics/contego.prom 2>&1))"
# The journal's structured entries to a systemd-journal-remote on loopback.
mkdir -p /var/log/journal/remote
/lib/systemd/systemd-journal-remote --listen-http=127.0.0.1:19532 --output=/var/log/journal/remote/ \
  >/tmp/journal-remote.log 2>&1 &
jrpid=$!
sleep 1
timeout 60 /lib/systemd/systemd-journal-upload --url=http://127.0.0.1:19532 --follow=no \
  --save-state=/tmp/journal-upload.state >/tmp/journal-upload.log 2>&1
rc=$?
sleep 1
kill $jrpid 2>/dev/null
n=$(journalctl -D /var/log/journal/remote CONTEGO_KIND=decision CONTEGO_TASK=gripper --no-pager -o export 2>/dev/null |
  grep -ac '^MESSAGE_ID=334d55ae757948bf9f52f566d57d4744$')
[ $rc = 0 ] && [ "$n" -gt 0 ] &&
  ok "systemd-journal-upload -> systemd-journal-remote (loopback): $n decision entries of the gripper received with their fields (journalctl -D /var/log/journal/remote CONTEGO_KIND=decision)" ||
  bad "the journal's entries did not reach systemd-journal-remote (upload exit $rc, $n decisions received)"
journalctl -D /var/log/journal/remote CONTEGO_KIND=reload --no-pager -o cat 2>/dev/null | head -n 1 | cut -c1-160 | show
sleep 1
if contego audit /var/log/contego/audit.jsonl >/tmp/audit.out 2>&1; then
  ok "after stop, start and restart: contego audit verifies the chain ($(wc -l </var/log/contego/audit.jsonl) records)"
else
  bad "contego audit: the chain does not verify after restart"
fi
show /tmp/audit.out | tail -n 5

# ---- the kernel client: contego-dkms, the README's commands ------------------
# DKMS builds contego.ko here, against this kernel's headers; the module then
# checks the same program, run as its user with no `contego run`. What the
# chip holds is read back through i2c-dev once the module is unloaded (the
# module answers root, bound to no task, with the policy's deny).
kmod_blocks=$(ls /vm/readme-kmod 2>/dev/null | sed 's/\.sh$//' | sort -n)
if [ -z "$kmod_blocks" ]; then
  echo "VM-CHECK SKIP $SCENARIO: kernel client: no contego-dkms package given (booted.sh --dkms-deb)"
else
  kmod_last=$(echo "$kmod_blocks" | tail -n1)
  t0=$(date +%s)
  for n in $kmod_blocks; do
    [ "$n" = "$kmod_last" ] && break
    if readme "$n" /vm/readme-kmod; then ok "README kernel-client block $n runs as written (exit 0)"
    else bad "README kernel-client block $n failed"; dmesg | tail -n 5; fi
  done
  echo "  kernel client set up in $(($(date +%s) - t0)) s (DKMS build under this guest's CPU)"
  kver=$(uname -r)
  grep -q "contego/.*$kver.*: installed" /tmp/readme-kmod-1.out &&
    ok "dkms status: contego installed for $kver ($(grep -o 'contego/[^ ,]*' /tmp/readme-kmod-1.out | head -n1))" ||
    bad "dkms status does not show contego installed for $kver"
  ko=$(modinfo -n contego 2>/dev/null)
  case $ko in
  /lib/modules/$kver/updates/dkms/contego.ko*) ok "modprobe loaded DKMS's build: $ko" ;;
  *) bad "contego.ko is not DKMS's (modinfo -n: '$ko')" ;;
  esac
  check "contego.ko loaded in place of i2c-dev" sh -c 'grep -q "^contego " /proc/modules && ! grep -q "^i2c_dev " /proc/modules'
  udevadm settle
  own=$(stat -c '%U:%G %a' /dev/i2c-0 2>&1)
  [ "$own" = "root:root 666" ] && ok "udev rule keeps off contego.ko's node: /dev/i2c-0 is $own" ||
    bad "contego.ko's /dev/i2c-0 is $own, not root:root 666"
  check "contego-kmod-audit.service active" systemctl is-active contego-kmod-audit
  check "contego-kmod-load.service active: the policy loaded with CONTEGO_KMOD_OPTS" systemctl is-active contego-kmod-load
  # An edited policy goes in by a restart; one the module's verifier refuses
  # leaves the loaded one in force and the unit failed.
  cp /etc/contego/robot.policy /tmp/robot.policy.good
  systemctl restart contego-kmod-load && ok "systemctl restart contego-kmod-load loads the policy again" ||
    bad "systemctl restart contego-kmod-load failed"
  echo 'this is not a policy' >/etc/contego/robot.policy
  systemctl restart contego-kmod-load 2>/dev/null && bad "contego-kmod-load accepted a broken policy" ||
    ok "a broken policy: contego-kmod-load fails ($(systemctl is-active contego-kmod-load)), the module keeps the old one"
  # One the module refuses (the arm moved to 0x41, where nothing answers: a
  # HAT not yet powered) is tried again every 2 s: once the policy can be
  # loaded, the unit is active again without a hand.
  sed 's/^device arm : pca9685 at i2c-1 0x40/device arm : pca9685 at i2c-1 0x41/' \
    /tmp/robot.policy.good >/etc/contego/robot.policy
  systemctl restart contego-kmod-load 2>/dev/null && bad "contego-kmod-load loaded a policy whose arm is absent"
  sleep 3
  state=$(systemctl show -p ActiveState --value contego-kmod-load)/$(systemctl show -p NRestarts --value contego-kmod-load)
  cp /tmp/robot.policy.good /etc/contego/robot.policy
  i=0
  until systemctl is-active -q contego-kmod-load; do
    i=$((i + 1)); [ $i -gt 20 ] && break
    sleep 0.5
  done
  case "$state" in
  activating/[1-9]*) systemctl is-active -q contego-kmod-load &&
    ok "a load refused for an absent device is tried again (state/restarts: $state); with the policy fixed the unit is active again by itself" ||
    bad "contego-kmod-load did not come back after the policy was fixed ($(systemctl is-active contego-kmod-load))" ;;
  *) bad "a refused load is not tried again: ActiveState/NRestarts $state" ;;
  esac
  journalctl -u contego-kmod-load --no-pager -o cat | tail -n 6 | show
  kaudit=/var/log/contego/kmod-audit.jsonl
  # The program as its unit would run it: its own user, nothing else. It holds
  # (sleeps) after its commands; its end is a session's end (safe state).
  # The robot's /dev/i2c-1 is the guest's /dev/i2c-0 (where the monitor
  # mapped it for the program, the module serves the adapter's own number).
  sed 's/SMBus(1)/SMBus(0)/' /opt/robot/gripper.py >/opt/robot/gripper-kmod.py
  setpriv --reuid=contego-gripper --regid=nogroup --clear-groups \
    python3 /opt/robot/gripper-kmod.py >/tmp/kgripper.log 2>&1 &
  gpid=$!
  for i in $(seq 1 150); do grep -q 'GRIPPER holding' /tmp/kgripper.log && break; sleep 0.2; done
  kill $gpid 2>/dev/null
  wait $gpid 2>/dev/null
  out=$(cat /tmp/kgripper.log)
  echo "$out" | show
  echo "$out" | grep -q 'GRIPPER pulse-577 ok' &&
    ok "the program, run as contego-gripper with no contego run: pulses 420, 577, 420 land" ||
    bad "the program's pulses under contego.ko did not land"
  echo "$out" | grep -q 'GRIPPER led5 577' &&
    ok "high pulse 900 replaced by the expected 577 (the program reads LED5 off=577 back)" ||
    bad "after the high pulse 900 the program read $(echo "$out" | grep -o 'led5 .*')"
  echo "$out" | grep -q 'GRIPPER address-0x41 E' &&
    ok "contego.ko: write to 0x41 (not in the policy) refused: $(echo "$out" | grep -o 'address-0x41 .*')" ||
    bad "contego.ko: write to 0x41 (not in the policy): $(echo "$out" | grep -o 'address-0x41 .*')"
  i2cset -y 0 $A $PRESCALE 0x03 >/dev/null 2>&1 && bad "root, bound to no task, wrote PRE_SCALE through contego.ko" ||
    ok "root, bound to no task: i2cset is refused by contego.ko"
  # The node is 0666, so reads matter too: a read needs the access matrix's `reads`.
  i2cget -y 0 $A $PRESCALE >/dev/null 2>&1 && bad "root, bound to no task, read PRE_SCALE through contego.ko" ||
    ok "root, bound to no task: i2cget is refused too (the node is open, the policy is not)"
  sleep 1 # the reader's last records
  allowed=$(grep -a '"task_name":"gripper"' $kaudit 2>/dev/null | grep -ac '"decision":"allow"')
  viol=$(grep -a '"kind":"decision"' $kaudit 2>/dev/null | grep -avc '"decision":"allow"')
  [ "$allowed" -ge 12 ] && [ "$viol" -ge 2 ] &&
    ok "kmod audit log: $allowed of the gripper's writes allowed, $viol decisions refused or replaced ($kaudit)" ||
    bad "kmod audit log: $allowed allowed, $viol other decisions"
  contego audit $kaudit >/tmp/kaudit.out 2>&1 && ok "contego audit verifies $kaudit's chain ($(wc -l <$kaudit) records)" ||
    { bad "contego audit: $kaudit's chain does not verify"; show /tmp/kaudit.out | tail -n 5; }
  # The module's state as Prometheus metrics (docs/kernel-client.md,
  # "Counters"): the reader's unit takes --metrics-file from
  # /etc/default/contego, as the monitor's does.
  # (The README's steps wrote the file anew: the line is added, as a user would.)
  echo 'CONTEGO_KMOD_AUDIT_OPTS="--metrics-file /run/contego-metrics/contego-kmod.prom"' >>/etc/default/contego
  systemctl restart contego-kmod-audit
  kprom=/run/contego-metrics/contego-kmod.prom
  for i in $(seq 1 50); do [ -s $kprom ] && break; sleep 0.2; done
  grep -q '^contego_info{client="contego.ko",image_sha256="[0-9a-f]\{64\}",loaded="1"} 1$' $kprom &&
    grep -qE '^contego_kmod_checks_total [1-9]' $kprom && grep -qx 'contego_kmod_audit_reader 1' $kprom &&
    ok "contego-kmod-audit.service writes the module's metrics ($kprom: $(grep -c '^contego_' $kprom) samples, $(grep '^contego_kmod_checks_total' $kprom))" ||
    bad "no kmod metrics at $kprom: $(systemctl is-active contego-kmod-audit) $(head -c 300 $kprom 2>&1)"
  if readme "$kmod_last" /vm/readme-kmod; then ok "README kernel-client block $kmod_last (removal) runs as written"
  else bad "README kernel-client block $kmod_last failed"; fi
  check "removal: contego.ko unloaded, its units off" sh -c '! grep -q "^contego " /proc/modules &&
    ! systemctl is-active -q contego-kmod-load && ! systemctl is-enabled -q contego-kmod-audit'
  check "purge: no contego.ko left for $kver" sh -c "! modinfo -n contego && ! find /lib/modules/$kver -name 'contego.ko*' | grep -q ."
  check "purge: DKMS knows no contego" sh -c '[ -z "$(dkms status contego)" ]'
  # i2c-dev again, to read the chip and for the monitor's part below.
  modprobe i2c-dev && udevadm settle
  [ "$(word)" = 420 ] && ok "unloading contego.ko drove the safe state (LED5 off=420)" || bad "after unloading LED5 off=$(word)"
  [ "$(reg $PRESCALE)" = 0x1e ] && ok "PRE_SCALE=0x1e: neither the gripper's nor root's forbidden write reached the chip" ||
    bad "PRE_SCALE is $(reg $PRESCALE) after contego.ko"
  own=$(stat -c '%U:%G %a' /dev/i2c-0 2>&1)
  [ "$own" = "contego:contego 660" ] && ok "i2c-dev's /dev/i2c-0 is the monitor's again: $own" ||
    bad "i2c-dev's /dev/i2c-0 is $own"
  systemctl enable --now contego-monitor contego-run@gripper >/dev/null 2>&1 ||
    bad "the monitor does not start again after the kernel client"
fi

# ---- remove, then the README's purge ------------------------------------------
set_word 0x41
if apt-get remove -q contego >/tmp/remove.out 2>&1; then ok "apt-get remove contego"; else bad "apt-get remove contego"; show /tmp/remove.out; fi
[ "$(word)" = 420 ] && ok "remove stopped the monitor: safe state (LED5 off=420)" || bad "after remove LED5 off=$(word)"
check "remove: /usr/bin/contego gone" test ! -e /usr/bin/contego
own=$(stat -c '%U:%G %a' /dev/i2c-0 2>&1)
case $own in
  root:*) ok "remove gave /dev/i2c-0 back to the system's own rules: $own" ;;
  *) bad "remove left /dev/i2c-0 as $own, not root's" ;;
esac
check "remove: no contego process left" sh -c '! pgrep -x "contego|contego-monitor"'
check "remove: conffiles kept (/etc/default/contego)" test -e /etc/default/contego
if readme "$last"; then ok "README Install block $last (removal) runs as written"; else bad "README Install block $last failed"; fi
check "purge: dpkg knows no contego" sh -c '! dpkg-query -W -f="\${Status}" contego 2>/dev/null | grep -q "[a-z]"'
left=$(find / -xdev \( -path /proc -o -path /sys -o -path /vm -o -path /tmp -o -path /etc/apt/apt.conf.d \) -prune -o -name '*contego*' -print 2>/dev/null |
  grep -v -e '^/etc/contego/robot.policy$' -e '^/etc/contego/run/gripper.conf$' -e '^/opt/robot' -e '^/etc/contego$' -e '^/etc/contego/run$')
[ -z "$left" ] && ok "purge: no file of contego's left (the admin's own policy and program config stay in /etc/contego)" ||
  bad "purge left: $(echo $left)"
check "purge: no dangling unit symlinks" sh -c '! find /etc/systemd -xtype l -name "contego*" | grep -q .'
getent passwd contego >/dev/null && ok "purge: the system users stay (Debian's convention for system users)" || ok "purge: user contego removed"

[ $CHECKS -gt 0 ] || bad "no checks ran"
if [ $FAILS = 0 ]; then echo "VM-RESULT PASS booted ($CHECKS checks)"; else echo "VM-RESULT FAIL booted ($FAILS of $CHECKS checks failed)"; fi
echo "VM-DONE"
sync
systemctl poweroff -ff
