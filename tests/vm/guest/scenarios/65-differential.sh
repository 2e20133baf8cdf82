# The differential test of the two clients over the i2c-dev model they share
# (include/contego/i2c_plan.h): one corpus of wire shapes
# (clients/wire_corpus.py: every SMBus form of the planner's table and the
# shapes beyond it, as I2C_RDWR, I2C_SMBUS and read()/write()) sent by one
# task, once through the monitor embedded in `contego run` and once through
# contego.ko, on each kind of adapter: i2c-stub (SMBus only, as many SoC
# controllers) and i2c-plain-stub (plain I2C, as the Raspberry Pi's), each
# run on a freshly loaded chip. Compared per adapter: what the program was
# told at every step, the decisions of the two audit logs, and the chip's
# registers afterwards (read through the plain i2c-dev). On the plain
# adapter the corpus also runs with another master on the bus
# (i2c-plain-stub's lose_arbitration): each client must try a call again as
# often as the descriptor's own I2C_RETRIES allow, and leave the adapter's
# own retries and timeout as they were.
. /vm/lib.sh
. /vm/inc/kmod.sh
kmod_built_or_skip
PLAIN=/lib/modules/i2c-plain-stub.ko
[ -f $PLAIN ] || { echo "VM-CHECK SKIP $SCENARIO: i2c-plain-stub.ko was not built"; exit 0; }
A=0x40
# The plain adapter's retries and timeout (ms): as its last transfer saw
# them, and now ("seen R T now R T").
TIMING=/sys/module/i2c_plain_stub/parameters/timing
# What went on the plain adapter's wire, transfer by transfer (write: clear).
WIRE=/sys/module/i2c_plain_stub/parameters/wire
# How many of the plain adapter's next transfers lose arbitration (EAGAIN);
# the corpus writes it, as the task's user.
LOSE=/sys/module/i2c_plain_stub/parameters/lose_arbitration

# A register file at 0x40 whose 48 first registers the task may write
# (auto-increment) and read (a query register makes the chip readable);
# 0xf0.. never written.
POLICY=/tmp/wire.policy
{
  echo "device chip : regmap at i2c-1 0x40 {"
  echo "  auto_increment"
  r=0
  while [ $r -lt 48 ]; do printf '  register 0x%02x r%02x : u8\n' $r $r; r=$((r + 1)); done
  echo "  query register 0x30 id : u8"
  echo "  forbid 0xF0..0xFF"
  echo "}"
  echo "task wire { period 1s; deadline 1s; wcet 10ms; priority 1 }"
  echo "allow wire -> chip"
  echo "allow wire reads chip"
} >$POLICY

# fresh NAME: the adapter's chip reloaded, all registers 0. Sets NR, its number.
fresh() {
  if [ "$1" = smbus ]; then
    stub_reload || return 1
    NR=0
  else
    rmmod i2c_plain_stub 2>/dev/null
    insmod $PLAIN chip_addr=$A || return 1
    NR=1
    wait_for /dev/i2c-1 10 || return 1
    chmod 0666 $LOSE || return 1
  fi
}

# formless_reasons KEY: the reason of each inexpressible line of KEY.jsonl,
# without the writer's own words around it (contego.ko's names the task and
# the caller), into KEY.formless; the lines whole into KEY.formless-lines.
formless_reasons() {
  python3 - $1.jsonl $1.formless-lines >$1.formless <<'PY'
import json, re, sys
lines = open(sys.argv[2], "w")
for line in open(sys.argv[1], encoding="utf-8", errors="replace"):
    line = line.strip("\0\n")
    if line.startswith("{") and json.loads(line).get("kind") == "inexpressible":
        d = json.loads(line)["detail"]
        print(d, file=lines)
        m = re.match(r"(?:contego\.ko: )?task \d+(?: \([^)]*\))?: (bus \d+: .*?)(?:; the call refused .*)?$", d)
        print(m.group(1) if m else d)
PY
}

# one ADAPTER CLIENT: the corpus through CLIENT (monitor or kmod) on ADAPTER
# (smbus or plain); leaves LOGDIR/ADAPTER-CLIENT.{steps,chip,decisions}.
one() {
  key=$1-$2
  fresh $1 || { bad "$1: the chip could not be reloaded"; return 1; }
  lose=""
  [ $1 = plain ] && lose=$LOSE
  if [ $2 = monitor ]; then
    [ $1 = plain ] && monitor_timing_before=$(cat $TIMING) && echo >$WIRE
    run_logged $key contego run --policy $POLICY --bus 1=/dev/i2c-$NR --user 1000 --task wire \
      --budget-factor 0 --audit $LOGDIR/$key.jsonl -- python3 $CLIENTS/wire_corpus.py 1 $lose
    grep -v "^contego" "$OUT" >$LOGDIR/$key.steps
    [ $1 = plain ] && tr ' ' '\n' <$WIRE >$LOGDIR/$key.wire
    [ $1 = plain ] && monitor_timing_after=$(cat $TIMING)
  else
    rmmod i2c_dev
    run_logged $key-insmod insmod $KO adapters=$NR buses=1
    wait_for /dev/i2c-$NR 10 && chmod 0666 /dev/i2c-$NR
    AUDIT_LOG=$LOGDIR/$key.jsonl
    start_reader $POLICY || return 1
    run_logged $key-load contego kmod load --policy $POLICY --bind wire=task --budget-factor 0
    [ $1 = plain ] && timing_before=$(cat $TIMING) && echo >$WIRE
    run_logged $key as_task python3 $CLIENTS/wire_corpus.py $NR $lose
    grep -v "^contego" "$OUT" >$LOGDIR/$key.steps
    [ $1 = plain ] && tr ' ' '\n' <$WIRE >$LOGDIR/$key.wire
    [ $1 = plain ] && timing_after=$(cat $TIMING)
    wait_sessions_closed
    contego kmod stats >$LOGDIR/$key.stats 2>&1
    stop_reader
    back_to_i2c_dev
  fi
  i2cdump -y $NR $A b >$LOGDIR/$key.chip 2>&1
  decisions $LOGDIR/$key.jsonl wire >$LOGDIR/$key.decisions
  formless_reasons $LOGDIR/$key
}

for adapter in smbus plain; do
  one $adapter monitor && one $adapter kmod || { bad "$adapter: a run did not complete"; continue; }
  m=$LOGDIR/$adapter-monitor k=$LOGDIR/$adapter-kmod
  steps=$(($(wc -l <$k.steps) - 1))
  grep -q "^done" $m.steps && grep -q "^done" $k.steps &&
    ok "$adapter: the corpus ran to its end under both clients" || bad "$adapter: the corpus did not finish under both"
  if cmp -s $m.steps $k.steps; then
    ok "$adapter: the program was told the same at each of its $steps steps: 0 mismatches" \
      "($(grep -c ' ok' $k.steps) answered, $(grep -c ' err ENOTSUP' $k.steps) without a form on this adapter," \
      "$(grep -c ' err ' $k.steps) errors in all)"
  else
    bad "$adapter: the program was told different things (monitor <, contego.ko >):"; diff $m.steps $k.steps
  fi
  n=$(wc -l <$k.decisions)
  if [ "$n" -gt 20 ] && cmp -s $m.decisions $k.decisions; then
    ok "$adapter: both logs hold the same $n decisions: 0 mismatches"
  else
    bad "$adapter: the decisions differ ($n under contego.ko):"; diff $m.decisions $k.decisions
  fi
  # A call with no form on the adapter, refused before the core decides:
  # audited alike by both (an inexpressible line each, the same reason).
  n=$(wc -l <$k.formless)
  formless=$(grep -c ' err ENOTSUP' $k.steps)
  if [ "$n" = "$formless" ] && cmp -s $m.formless $k.formless; then
    ok "$adapter: both logs hold the same $n inexpressible lines, one per call without a form"
  else
    bad "$adapter: the inexpressible lines differ ($n under contego.ko for $formless calls; monitor <, contego.ko >):"
    diff $m.formless $k.formless
  fi
  grep -q " inexpressible=$formless " $k.stats &&
    ok "$adapter: contego.ko's counters: inexpressible=$formless" || bad "$adapter: contego.ko's counters: $(cat $k.stats)"
  if cmp -s $m.chip $k.chip; then
    ok "$adapter: the chip's registers are the same after both runs"
  else
    bad "$adapter: the chip differs:"; diff $m.chip $k.chip
  fi
  # What went on the plain adapter's wire during the program, transfer by
  # transfer: the same under both clients. The monitor's run begins with
  # contego run's own start (its probe of the device and the register
  # read-back of the regmap's shadow), before the program's first call.
  if [ $adapter = plain ]; then
    n=$(grep -c . $k.wire)
    start=$(($(grep -c . $m.wire) - n))
    tail -n "$n" $m.wire >$m.wire-program
    if [ "$n" -ge 30 ] && [ "$start" -ge 0 ] && cmp -s $m.wire-program $k.wire &&
        ! head -n "$start" $m.wire | grep -qvE '^40:(w0|w1\+r1)$'; then
      ok "plain: the same $n transfers went on the wire in the same order under both clients" \
        "(before them, the monitor's start: $start probes and register reads)"
    else
      bad "plain: the wire differs ($n transfers under contego.ko; the monitor's start: $start transfers):"
      diff $m.wire-program $k.wire
      head -n "$start" $m.wire | sort | uniq -c
    fi
    # A write and the read answering it, sent by the program as one combined
    # transfer, went out as one (a repeated start), not a write, a stop and
    # a lone read.
    grep -qx '40:w2+r1' $k.wire && grep -qx '40:w2+r1' $m.wire &&
      ok "plain: [w2][r1] kept whole, a repeated start, under both clients" ||
      bad "plain: [w2][r1] did not go out as one transfer ($(grep -c '+r' $k.wire) combined under contego.ko)"
    # Another master on the bus: what each descriptor's own I2C_RETRIES got
    # the program, under each client (the steps are compared above too).
    for c in monitor kmod; do
      f=$LOGDIR/plain-$c
      # (a step that read nothing prints "ok " and no bytes)
      grep -qE '^3 lost, I2C_RETRIES 3: rdwr write ok ?$' $f.steps &&
        grep -q '^2 lost, I2C_RETRIES 3: rdwr \[w1\]\[r2\] ok 5a [0-9a-f][0-9a-f]$' $f.steps &&
        grep -qx '2 lost, I2C_RETRIES 3: smbus read byte data ok 5a' $f.steps &&
        grep -qE '^1 lost, I2C_RETRIES 3 still \(another descriptor set 0\): rdwr write ok ?$' $f.steps &&
        ok "plain, $c: I2C_RETRIES 3 got the calls through 3 and 2 lost arbitrations" ||
        bad "plain, $c: a call with I2C_RETRIES 3 did not get through its lost arbitrations"
      grep -qx '4 lost, I2C_RETRIES 3: smbus write byte data err EAGAIN' $f.steps &&
        grep -qx '1 lost, I2C_RETRIES 0: smbus write byte data err EAGAIN' $f.steps &&
        grep -qx '1 lost, no I2C_RETRIES: smbus write byte data err EAGAIN' $f.steps &&
        ok "plain, $c: told EAGAIN after 4 losses with I2C_RETRIES 3, and at the first with 0 or none" ||
        bad "plain, $c: a call past its retries was not told EAGAIN"
      # Every try of those 7 calls on the wire, then the corpus's last step:
      # 4 + 3 + 3 + 4 + 1 + 1 + 2 tries, 14 of them lost.
      l=/EAGAIN
      want="40:w2$l 40:w2$l 40:w2$l 40:w2 40:w1+r2$l 40:w1+r2$l 40:w1+r2 40:w1+r1$l 40:w1+r1$l 40:w1+r1"
      want="$want 40:w2$l 40:w2$l 40:w2$l 40:w2$l 40:w2$l 40:w2$l 40:w2$l 40:w2 40:w1+r32 "
      got=$(grep . $f.wire | tail -n 19 | tr '\n' ' ')
      [ "$got" = "$want" ] &&
        ok "plain, $c: on the wire, 18 tries of those 7 calls, 14 lost, each tried again while its descriptor's retries allowed" ||
        bad "plain, $c: the tries on the wire are not the rule's: $got"
    done
  fi
  # I2C_PEC: on the plain adapter (i2c-core's emulation adds it) each SMBus
  # write's PEC landed in the register after it under both clients, as it
  # would without contego, and was checked as a byte of the write: the one
  # that would land in r31, which the policy does not have, was refused and
  # r31 stayed 00. No PEC from write() or an I2C block write; a read's and a
  # process call's answer's PEC is compared (the stub answers none, so
  # EBADMSG, as i2c-core says). On
  # i2c-stub (no I2C_FUNC_SMBUS_PEC) nothing carries one: smbus2 refuses
  # to turn it on.
  for c in monitor kmod; do
    f=$LOGDIR/$adapter-$c
    r31=$(awk '$1 == "30:" { print $3 }' $f.chip)
    if [ $adapter = plain ]; then
      [ "$(grep -c '^pec landed after write .* ok 01$' $f.steps)" = 4 ] &&
        grep -qx 'pec landed after write() ok 00' $f.steps &&
        grep -qx 'pec landed after i2c block ok 00' $f.steps &&
        grep -qx 'pec smbus read byte data err EBADMSG' $f.steps &&
        grep -qx 'pec smbus process call err EBADMSG' $f.steps &&
        grep -q '^pec smbus write byte data r30 err ' $f.steps && [ "$r31" = 00 ] &&
        ok "plain, $c: PEC on the wire for the 4 SMBus writes, checked (the one for r31 refused, r31 = $r31), none for write() or an I2C block write, a read's compared" ||
        bad "plain, $c: PEC not as i2c-core puts it (r31 = $r31): $(grep '^pec' $f.steps | tr '\n' ';')"
    else
      [ "$(grep -c '^pec smbus .* err None$' $f.steps)" = 8 ] &&
        ok "smbus, $c: no PEC on an adapter without it (smbus2 refuses I2C_PEC there)" ||
        bad "smbus, $c: PEC steps: $(grep '^pec' $f.steps | tr '\n' ';')"
    fi
  done
  show $k.steps
done
# I2C_RETRIES/I2C_TIMEOUT under contego.ko: the corpus's descriptor set 3
# and 70 ms; its last transfer ran with them (lent to the adapter under its
# bus lock), the adapter kept its own.
now_before=${timing_before#*now } now_after=${timing_after#*now }
case "$timing_after" in
  "seen 3 7"[0-9]" now "*)  # 70 ms in whole jiffies
    [ "$now_after" = "$now_before" ] &&
      ok "contego.ko: I2C_RETRIES 3 and I2C_TIMEOUT 7 held for the descriptor's transfers only (adapter: $timing_after; before: $timing_before)" ||
      bad "contego.ko: the adapter's own timing changed ($timing_before -> $timing_after)" ;;
  *) bad "contego.ko: the descriptor's transfers did not run with its I2C_RETRIES/I2C_TIMEOUT ($timing_after)" ;;
esac
# Under the monitor the descriptor's values never reach the adapter (setting
# them there is adapter-wide): the monitor tries again itself, so every
# transfer ran with the adapter's own, which stayed as they were.
m_before=${monitor_timing_before#*now } m_after=${monitor_timing_after#*now }
[ -n "$m_after" ] && [ "$m_after" = "$m_before" ] && [ "$monitor_timing_after" = "seen $m_before now $m_before" ] &&
  ok "monitor: the adapter's own retries and timeout untouched (adapter: $monitor_timing_after)" ||
  bad "monitor: the adapter's timing changed or was lent ($monitor_timing_before -> $monitor_timing_after)"

# ---- What the verdicts send, without a form --------------------------------
# i2c-stub cut to word and count-prefixed block writes (no byte data, no I2C
# block): the core's writes of a register map, one [register, value]
# message per register, have no form there, while the program's word write
# has, and so has a GoPiGo frame whose second byte counts the rest. A call
# whose verdicts would send such a part (a substitute, or an allowed word
# written register by register beside another write) is refused by both
# clients before any part of it acts (EOPNOTSUPP), and both audit an
# `inexpressible` line. The first step's frame would otherwise have landed
# before the word failed at the bus.
NF_FUNCS=0x066f0000 # quick, byte, read byte data, word data, SMBus block write, I2C block read
NF_POLICY=/tmp/noform.policy
{
  echo "device chip : regmap at i2c-1 0x40 {"
  echo "  auto_increment"
  r=0
  while [ $r -lt 16 ]; do printf '  register 0x%02x r%02x : u8\n' $r $r; r=$((r + 1)); done
  echo "}"
  echo "device motors : gopigo2 at i2c-1 0x08"
  echo "task wire { period 1s; deadline 1s; wcet 10ms; priority 1 }"
  echo "allow wire -> chip"
  echo "allow wire -> motors"
  echo "invariant CAP on chip.r08: require value <= 100 else failsafe value = 100"
} >$NF_POLICY

# nf_one CLIENT: the corpus's formless steps through CLIENT on the cut stub;
# leaves LOGDIR/noform-CLIENT.{steps,chip,decisions,formless}.
nf_one() {
  key=noform-$1
  rmmod i2c_stub && insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS functionality=$NF_FUNCS &&
    own_adapter || { bad "i2c-stub could not be loaded with functionality $NF_FUNCS"; return 1; }
  if [ $1 = monitor ]; then
    run_logged $key contego run --policy $NF_POLICY $BUS_ARGS --user 1000 --task wire \
      --budget-factor 0 --audit $LOGDIR/$key.jsonl -- python3 $CLIENTS/wire_corpus.py 1 formless
    grep -v "^contego" "$OUT" >$LOGDIR/$key.steps
  else
    rmmod i2c_dev
    run_logged $key-insmod insmod $KO adapters=0 buses=1
    wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
    AUDIT_LOG=$LOGDIR/$key.jsonl
    start_reader $NF_POLICY || return 1
    run_logged $key-load contego kmod load --policy $NF_POLICY --bind wire=task --budget-factor 0
    run_logged $key as_task python3 $CLIENTS/wire_corpus.py 0 formless
    grep -v "^contego" "$OUT" >$LOGDIR/$key.steps
    wait_sessions_closed
    stop_reader
    back_to_i2c_dev
  fi
  { i2cdump -y 0 0x40 b; i2cdump -y 0 0x08 b; } >$LOGDIR/$key.chip 2>&1
  decisions $LOGDIR/$key.jsonl wire >$LOGDIR/$key.decisions
  formless_reasons $LOGDIR/$key
}

if nf_one monitor && nf_one kmod; then
  m=$LOGDIR/noform-monitor k=$LOGDIR/noform-kmod
  grep -q "^done" $m.steps && grep -q "^done" $k.steps &&
    ok "formless: the steps ran to their end under both clients" || bad "formless: the steps did not finish under both"
  refused=$(grep -c "^formless .* err ENOTSUP$" $k.steps)
  if cmp -s $m.steps $k.steps && [ "$refused" = 4 ] && [ "$(grep -c ' ok' $k.steps)" = 2 ]; then
    ok "formless: both clients told the program the same at each step: the 4 calls whose verdicts' writes have no form EOPNOTSUPP, the 2 controls ok"
  else
    bad "formless: the program was told (monitor <, contego.ko >):"; diff $m.steps $k.steps; show $k.steps
  fi
  if cmp -s $m.chip $k.chip; then ok "formless: the chips are the same after both runs"; else bad "formless: the chips differ:"; diff $m.chip $k.chip; fi
  # Nothing of a refused call reached the chip: the frame before the word
  # (0x08's register 0x47), the word (0x40's 0x04), the substitutes (0x08).
  # The controls did: 0x08's 0x46 (the frame's count, as i2c-stub keeps an
  # SMBus block write) and 0x40's 0x00.
  reg() { awk -v row="$(printf '%02x:' $(($2 & 0xf0)))" -v col=$(($2 % 16 + 2)) \
    '$1 == row { print $col }' "$1"; }
  for c in monitor kmod; do
    f=$LOGDIR/noform-$c.chip
    sed -n '/^     0  1/,/^f0:/p' $f | head -17 >$f.40
    sed -n '/^     0  1/,/^f0:/p' $f | tail -17 >$f.08
    got="$(reg $f.08 0x47) $(reg $f.40 0x04) $(reg $f.40 0x08) $(reg $f.08 0x46) $(reg $f.40 0x00)"
    [ "$got" = "00 00 00 02 11" ] &&
      ok "formless ($c): nothing of the refused calls reached the chip (0x08:47 0x40:04 0x40:08 = 00 00 00), the controls did (0x08:46 = 02, 0x40:00 = 11)" ||
      bad "formless ($c): the chip holds $got (0x08:47 0x40:04 0x40:08 0x08:46 0x40:00; expected 00 00 00 02 11)"
  done
  n=$(wc -l <$k.formless)
  if [ "$n" = 4 ] && cmp -s $m.formless $k.formless; then
    ok "formless: both logs hold the same 4 inexpressible lines: $(head -n 1 $k.formless)"
    show $k.formless-lines
  else
    bad "formless: the inexpressible lines differ ($n under contego.ko; monitor <, contego.ko >):"
    diff $m.formless $k.formless
  fi
  if cmp -s $m.decisions $k.decisions; then
    ok "formless: both logs hold the same $(wc -l <$k.decisions) decisions (the refused calls' transfer-dropped among them)"
  else
    bad "formless: the decisions differ:"; diff $m.decisions $k.decisions
  fi
else
  bad "formless: a run did not complete"
fi

# ---- A reload's safe state, without a form ---------------------------------
# A reload drives no safe state, so both clients check instead that every
# safe state of the new policy has a form on its adapter: chip's `safe
# r00(0)` is a [register, value] write, which the cut stub has none for (no
# byte data). Refused, the policy in force kept; the same reload without it
# goes through. Nothing written either way.
NF_SAFE=/tmp/noform-safe.policy
sed 's/^}$/  safe r00(0)\n}/' $NF_POLICY >$NF_SAFE
NF_REFUSED="the safe state of chip (i2c-1 0x40) has no form on its adapter"
rmmod i2c_stub && insmod /lib/modules/i2c-stub.ko chip_addr=$STUB_ADDRS functionality=$NF_FUNCS &&
  own_adapter || bad "i2c-stub could not be loaded with functionality $NF_FUNCS"
cp $NF_POLICY $POLICIES/noform.policy
if start_monitor noform.policy; then
  run_logged nf_reload_safe contego reload --policy $NF_SAFE --socket $SOCK
  [ $RC = 1 ] && grep -q "$NF_REFUSED: write 2 at 0x40: .*; the running policy stays" "$OUT" &&
    ok "monitor: a reload whose safe state has no form is refused: $(cat "$OUT")" ||
    bad "monitor: the reload of a formless safe state: exit $RC: $(cat "$OUT")"
  run_logged nf_reload_plain contego reload --policy $NF_POLICY --socket $SOCK
  [ $RC = 0 ] && ok "monitor: the reload without it is taken" || bad "monitor: the plain reload: exit $RC"
  stop_monitor
  grep "\"kind\":\"reload-refused\"" $LOGDIR/monitor-audit.jsonl | grep -q "$NF_REFUSED" &&
    ok "monitor: the refusal is in the audit log" || bad "monitor: no reload-refused record naming chip"
fi
rmmod i2c_dev
run_logged nf_reload_insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
AUDIT_LOG=$LOGDIR/noform-reload.jsonl
start_reader $NF_POLICY
run_logged nf_reload_load contego kmod load --policy $NF_POLICY --bind wire=task --budget-factor 0
run_logged nf_kreload_safe contego kmod reload --policy $NF_SAFE --bind wire=task --budget-factor 0
[ $RC = 1 ] && grep -q "refused: $NF_REFUSED (a load in place drives none" "$OUT" &&
  grep -q "the policy in force stays" "$OUT" &&
  ok "contego.ko: a reload whose safe state has no form is refused: $(cat "$OUT")" ||
  bad "contego.ko: the reload of a formless safe state: exit $RC: $(cat "$OUT")"
dmesg | grep -q "contego: load in place refused: the safe state of device(s) 0x1 has no form on its adapter" &&
  ok "contego.ko: the kernel log says which" || bad "contego.ko: no refused load in place in the kernel log"
run_logged nf_kreload_plain contego kmod reload --policy $NF_POLICY --bind wire=task --budget-factor 0
[ $RC = 0 ] && ok "contego.ko: the reload without it is taken" || bad "contego.ko: the plain reload: exit $RC: $(cat "$OUT")"
run_logged nf_kreload_stats contego kmod stats
grep -q "loads=2 refused_loads=1" "$OUT" && ok "contego.ko: counted: the load, the reload taken, the one refused" ||
  bad "contego.ko: counters after the reloads: $(cat "$OUT")"
stop_reader
grep '"kind":"policy-load-refused"' $AUDIT_LOG | grep -q "withdrawn after its load.*safe state of device(s) 0 (" &&
  ok "contego.ko: the log records the withdrawn load in place and names the device" ||
  bad "contego.ko: no withdrawn load in place in the module's log"
run_logged nf_reload_verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the log across the refused and the taken reload" ||
  bad "contego audit exit $RC"
back_to_i2c_dev

# ---- contego.ko: a latched device and the operator's reset ----------------
# Two refused writes latch the chip (its safe state driven, every later
# command ignored); `kmod status` says LATCHED; `contego kmod reset chip`
# clears it, as `contego reset` does for the monitor, after its record.
LATCH_POLICY=/tmp/latch.policy
{
  echo "device chip : regmap at i2c-1 0x40 {"
  echo "  auto_increment"
  echo "  register 0x00 r00 : u8"
  echo "  register 0x01 r01 : u8"
  echo "  query register 0x30 id : u8"
  echo "  safe r00(0)"
  echo "  latch after 2 violations within 30s"
  echo "}"
  echo "task wire { period 1s; deadline 1s; wcet 10ms; priority 1 }"
  echo "allow wire -> chip"
  echo "allow wire reads chip"
  echo "invariant CAP on chip.r01: require value <= 100 else reject"
} >$LATCH_POLICY
stub_reload
rmmod i2c_dev
run_logged latch_insmod insmod $KO adapters=0 buses=1
wait_for /dev/i2c-0 10 && chmod 0666 /dev/i2c-0
AUDIT_LOG=$LOGDIR/latch.jsonl
PROM=$LOGDIR/kmod.prom
start_reader $LATCH_POLICY --metrics-file $PROM --metrics-interval 1
run_logged latch_load contego kmod load --policy $LATCH_POLICY --bind wire=task --budget-factor 0
run_logged latch_bad1 as_task i2cset -y 0 $A 0x01 200
run_logged latch_bad2 as_task i2cset -y 0 $A 0x01 200
run_logged latch_status contego kmod status
grep -q "^LATCHED:  chip (i2c-1 0x40) (held in the safe state; .contego kmod reset DEVICE. clears it)" "$OUT" &&
  contego kmod stats | grep -q " latched=0x1$" &&
  ok "contego.ko: two violations latch the chip: $(grep LATCHED "$OUT")" || bad "kmod status after two violations: $(cat "$OUT")"
prom_says() {  # prom_says LINE: waits up to 3 s for the reader's metrics file to hold LINE
  i=0
  until grep -qx "$1" $PROM 2>/dev/null; do i=$((i + 1)); [ $i -gt 30 ] && return 1; usleep 100000; done
}
prom_says 'contego_device_latched{device="chip"} 1' && grep -qE '^contego_kmod_refused_total [1-9]' $PROM &&
  grep -qx 'contego_kmod_audit_reader 1' $PROM &&
  ok "kmod audit --metrics-file: the latch and the refusals in Prometheus's format" ||
  bad "the reader's metrics after the latch: $(cat $PROM 2>&1 | grep -v '^#' | tr '\n' ';')"
run_logged latch_held as_task i2cset -y 0 $A 0x01 60
run_logged latch_nosuch contego kmod reset nosuch
[ $RC = 2 ] && grep -q "the policy in force has no device 'nosuch'" "$OUT" &&
  ok "kmod reset of an unknown device: exit 2, named" || bad "kmod reset nosuch: exit $RC: $(cat "$OUT")"
run_logged latch_reset contego kmod reset chip
[ $RC = 0 ] && grep -q "^contego kmod reset: chip was latched; its latch is cleared" "$OUT" &&
  contego kmod stats | grep -q " latched=0x0$" &&
  ok "contego kmod reset chip: $(cat "$OUT")" || bad "kmod reset chip: exit $RC: $(cat "$OUT")"
held=$(as_task i2cget -y 0 $A 0x01)
run_logged latch_after as_task i2cset -y 0 $A 0x01 50
after=$(as_task i2cget -y 0 $A 0x01)
[ "$held" = 0x00 ] && [ $RC = 0 ] && [ "$after" = 0x32 ] &&
  ok "the write sent while latched did not land (r01 = $held); after the reset r01 = 50 lands ($after)" ||
  bad "after the reset: r01 was $held (expected 0x00), the write exit $RC, r01 now $after (expected 0x32)"
prom_says 'contego_device_latched{device="chip"} 0' && ok "the metrics follow the reset (latched 0)" ||
  bad "the reader's metrics after the reset: $(grep latched $PROM)"
run_logged latch_again contego kmod reset chip
grep -q "chip was not latched" "$OUT" && ok "a second reset: not latched" || bad "second reset: $(cat "$OUT")"
stop_reader
run_logged latch_unrecorded contego kmod reset chip
[ $RC = 1 ] && grep -q "its record could not be taken (is .contego kmod audit. running?); nothing was reset" "$OUT" &&
  ok "with no audit reader a reset is refused: $(cat "$OUT")" || bad "kmod reset with no reader: exit $RC: $(cat "$OUT")"
grep '"kind":"reset"' $AUDIT_LOG | grep -q "device 0 (chip) at bus 1 0x40 reset by uid 0 (pid [0-9]*); it was latched" &&
  ok "the log records the reset: who, which device, that it was latched" || bad "no reset record in the module's log"
run_logged latch_verify contego audit $AUDIT_LOG
[ $RC = 0 ] && ok "contego audit verifies the log across the latch and the reset" || bad "contego audit exit $RC"
back_to_i2c_dev

rmmod i2c_plain_stub 2>/dev/null
stub_reload
finish
