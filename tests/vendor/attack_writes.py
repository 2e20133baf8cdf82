# Raw writes to I2C devices, as an attacker's code in a task's process makes
# them (Adafruit_PureIO's way: I2C_SLAVE, then write(2)). Each argument is
# [N*]ADDR:BYTES, e.g. 0x08:01,46,c8,00,00 (set_left_speed(200) with the
# GoPiGo library's framing) or 10*0x08:01,74,00,00,00 (ten increase_speed).
# A write that fails is counted, not fatal. Prints "done N failed".
# Usage: attack_writes.py WRITE...
import fcntl
import os
import sys

from smbus2 import SMBus

I2C_SLAVE = 0x0703
bus = SMBus(1)
failed = 0
for arg in sys.argv[1:]:
    times, _, spec = arg.rpartition("*")
    addr, _, data = spec.partition(":")
    payload = bytes(int(b, 16) for b in data.split(","))
    for _ in range(int(times) if times else 1):
        try:
            fcntl.ioctl(bus.fd, I2C_SLAVE, int(addr, 16))
            os.write(bus.fd, payload)
        except OSError:
            failed += 1
print("done", failed, "failed")
