# Replays Adafruit_PCA9685's register writes with python3-smbus2 (byte-data
# writes): init, an attempted frequency change (PRE_SCALE), then
# set_pwm(5, 0, 577) as four single-register writes.
from smbus2 import SMBus

ADDR = 0x40
with SMBus(1) as bus:
    bus.write_byte_data(ADDR, 0x01, 0x04)  # MODE2
    bus.write_byte_data(ADDR, 0x00, 0x01)  # MODE1: all-call on, awake
    mode1 = bus.read_byte_data(ADDR, 0x00)
    bus.write_byte_data(ADDR, 0x00, (mode1 & 0x7F) | 0x10)  # sleep
    try:
        bus.write_byte_data(ADDR, 0xFE, 0x03)  # ~1526 Hz: refused by the policy
        print("prescale written")
    except PermissionError:
        print("prescale refused")
    bus.write_byte_data(ADDR, 0x00, mode1)
    for reg, value in ((0x1A, 0), (0x1B, 0), (0x1C, 577 & 0xFF), (0x1D, 577 >> 8)):
        bus.write_byte_data(ADDR, reg, value)
    print("off", bus.read_byte_data(ADDR, 0x1C) | (bus.read_byte_data(ADDR, 0x1D) << 8))
