# A task that keeps moving the arm's servo 0 (PCA9685 LED0, register 0x06):
# first MODE1 = 0x20 (auto-increment, awake; counted as a write), then write i
# sets off = 150 + i % 450 (inside SERVO_WINDOW). Counts the writes
# that returned success and those that failed (EIO once the audit log is
# full), writes "ok N failed M last OFF" to argv[1] every 20 writes and at
# the end; runs until argv[2] exists; argv[3]: seconds between writes;
# with argv[4] it records each write's latency in µs to that file.
import os
import sys
import time
from smbus2 import SMBus

out, stop, pause = sys.argv[1], sys.argv[2], float(sys.argv[3])
lat = open(sys.argv[4], "w") if len(sys.argv) > 4 else None
ok = failed = 0
last = -1
i = 0


def report():
    with open(out + ".tmp", "w") as f:
        f.write(f"ok {ok} failed {failed} last {last}\n")
    os.rename(out + ".tmp", out)


with SMBus(1) as bus:
    while True:
        try:
            bus.write_byte_data(0x40, 0x00, 0x20)
            ok += 1
            break
        except OSError:
            failed += 1
            time.sleep(0.01)
    while not os.path.exists(stop):
        off = 150 + i % 450
        t0 = time.perf_counter_ns()
        try:
            bus.write_i2c_block_data(0x40, 0x06, [0, 0, off & 0xFF, off >> 8])
            ok += 1
            last = off
        except OSError:
            failed += 1
        if lat:
            lat.write(f"{(time.perf_counter_ns() - t0) / 1000:.1f}\n")
        i += 1
        if i % 20 == 0:
            report()
        if pause:
            time.sleep(pause)
report()
