# A gripper program written to send what Adafruit's current PCA9685 driver
# (adafruit-circuitpython-pca9685 on Blinka, PureIO underneath) sends: the
# constructor's reset (MODE1 = 0, All-Call off), the frequency setter (MODE1
# read back through one I2C_RDWR write-then-read, SLEEP, PRE_SCALE 101 for
# 60 Hz, wake, then RESTART | AI), and each channel as one 5-byte
# auto-increment write [LEDn_ON_L, on_lo, on_hi, off_lo, off_hi]. The legacy
# Adafruit_PCA9685 writes one register per call instead. Moves the hand
# (channel 5) through the pulses given (default 420 577), one per second.
# Prints "done" at the end.
import sys
import time

from i2c_dev import Device

MODE1, PRESCALE, LED0_ON_L = 0x00, 0xFE, 0x06
SLEEP, AUTO_INCREMENT, RESTART = 0x10, 0x20, 0x80

pca = Device(1, 0x40)


def duty(channel, on, off):
    pca.write([LED0_ON_L + 4 * channel, on & 0xFF, on >> 8, off & 0xFF, off >> 8])


pca.write([MODE1, 0x00])  # PCA9685.reset()
# PCA9685.frequency = 60: prescale = int(25 MHz / 4096 / 60 + 0.5) - 1 = 101
old = pca.write_then_read([MODE1], 1)[0]
pca.write([MODE1, (old & 0x7F) | SLEEP])
pca.write([PRESCALE, 101])
pca.write([MODE1, old])
time.sleep(0.005)
pca.write([MODE1, old | RESTART | AUTO_INCREMENT])
for i, pulse in enumerate(int(p) for p in (sys.argv[1:] or ["420", "577"])):
    if i:
        time.sleep(1.0)
    duty(5, 0, pulse)
print("done")
