# One pulse of the gripper (channel 5, 420 ticks) written as
# Adafruit_PCA9685's python-smbus backend writes it, four SMBus byte writes
# (ON_L, ON_H, OFF_L, OFF_H), with packet error checking on when the first
# argument is "pec": the adapter then ends each write with its PEC byte,
# which the PCA9685 takes as data (auto-increment off: it lands in the same
# register). Prints what each write was told, then "done".
# Usage: pec_pulse.py pec|plain
import sys

from smbus2 import SMBus

bus = SMBus(1)
bus.pec = 1 if sys.argv[1] == "pec" else 0
LED5_ON_L = 0x06 + 4 * 5
for i, value in enumerate([0, 0, 420 & 0xFF, 420 >> 8]):
    try:
        bus.write_byte_data(0x40, LED5_ON_L + i, value)
        print("write", hex(LED5_ON_L + i), "ok")
    except OSError as e:
        print("write", hex(LED5_ON_L + i), "err", e.errno)
print("done")
