# The arm's gripper task with python3-smbus2: one set_pwm(5, 0, PULSE) per job
# as Adafruit_PCA9685 sends it (four byte-data writes, LED5_ON_L..LED5_OFF_H:
# the chip's MODE1 auto-increment bit is off after reset, so a block write
# would only reach LED5_ON_L), for each PULSE on the command line. With --sync DIR
# it hands over to the test after each pulse: it creates DIR/sent-K and waits
# for DIR/ack-K, so the test can read the stub outside contego in between.
# --hold keeps the task alive at the end (to be killed); its pid is DIR/pid.
import os
import sys
import time
from smbus2 import SMBus

args = sys.argv[1:]
sync = hold = None
if args[:1] == ["--sync"]:
    sync, args = args[1], args[2:]
if args[:1] == ["--hold"]:
    hold, args = True, args[1:]


def handshake(name):
    if not sync:
        time.sleep(0.05)  # the job boundary
        return
    open(os.path.join(sync, "sent-" + name), "w").close()
    while not os.path.exists(os.path.join(sync, "ack-" + name)):
        time.sleep(0.02)  # also the job boundary: one pulse per job


if sync:
    with open(os.path.join(sync, "pid"), "w") as f:
        f.write(str(os.getpid()))
handshake("start")
PERIOD = 1.0  # arm.policy: the gripper's period is 1 s, one pulse per job
with SMBus(1) as bus:
    for k, pulse in enumerate(int(a) for a in args):
        # Each pulse in its own job: the monitor releases the task's jobs on
        # its 1 s period grid, so a pulse sent more than a period after the
        # previous one is in a later job, however the handshake went.
        if k > 0:
            time.sleep(PERIOD + 0.05)
        for reg, value in ((0x1A, 0), (0x1B, 0), (0x1C, pulse & 0xFF), (0x1D, pulse >> 8)):
            bus.write_byte_data(0x40, reg, value)
        print("pulse", pulse, "sent", flush=True)
        handshake(str(k))
    if hold:
        print("holding", flush=True)
        time.sleep(3600)
print("done", flush=True)
