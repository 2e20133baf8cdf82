# tutRPi's 6DOF arm Hand on Adafruit_PCA9685, written to make the calls the
# vendor's libraries make (facts from Adafruit_Python_PCA9685 and
# Adafruit_PureIO): PCA9685() writes ALL_LED 0, MODE2 = OUTDRV, MODE1 =
# ALLCALL and wakes the chip; set_pwm_freq(60) sleeps it, writes PRE_SCALE
# 101 and restarts; set_pwm writes ON_L, ON_H, OFF_L, OFF_H one register at a
# time. PureIO sets I2C_SLAVE before every write and reads a register with an
# I2C_RDWR write-then-read. Hand.open() is 60 % (pulse 420), Hand.close() 95 %
# (577); example.py sleeps 1 s between moves.
# Usage: sixdof_hand.py MOVE...   (MOVE: open | close); prints "done" at the end.
import fcntl
import os
import sys
import time

from smbus2 import SMBus, i2c_msg

I2C_SLAVE = 0x0703
ADDRESS = 0x40
MODE1, MODE2, PRESCALE, LED0_ON_L, ALL_LED_ON_L = 0x00, 0x01, 0xFE, 0x06, 0xFA
SLEEP, ALLCALL, OUTDRV, RESTART = 0x10, 0x01, 0x04, 0x80
HAND = 5

bus = SMBus(1)


def write8(reg, value):  # Adafruit_GPIO.I2C.Device.write8 on PureIO
    fcntl.ioctl(bus.fd, I2C_SLAVE, ADDRESS)
    os.write(bus.fd, bytes([reg, value & 0xFF]))


def read_u8(reg):  # PureIO readU8: one I2C_RDWR of {W [reg]}, {R 1}
    w, r = i2c_msg.write(ADDRESS, [reg]), i2c_msg.read(ADDRESS, 1)
    bus.i2c_rdwr(w, r)
    return list(r)[0]


def set_pwm(channel, on, off):
    write8(LED0_ON_L + 4 * channel, on & 0xFF)
    write8(LED0_ON_L + 4 * channel + 1, on >> 8)
    write8(LED0_ON_L + 4 * channel + 2, off & 0xFF)
    write8(LED0_ON_L + 4 * channel + 3, off >> 8)


def set_all_pwm(on, off):
    write8(ALL_LED_ON_L, on & 0xFF)
    write8(ALL_LED_ON_L + 1, on >> 8)
    write8(ALL_LED_ON_L + 2, off & 0xFF)
    write8(ALL_LED_ON_L + 3, off >> 8)


# PCA9685.__init__
set_all_pwm(0, 0)
write8(MODE2, OUTDRV)
write8(MODE1, ALLCALL)
time.sleep(0.005)
write8(MODE1, read_u8(MODE1) & ~SLEEP)
time.sleep(0.005)
# set_pwm_freq(60)
prescale = int(25000000.0 / 4096.0 / 60 - 1.0 + 0.5)
oldmode = read_u8(MODE1)
write8(MODE1, (oldmode & 0x7F) | SLEEP)
write8(PRESCALE, prescale)
write8(MODE1, oldmode)
time.sleep(0.005)
write8(MODE1, oldmode | RESTART)

pulses = {"open": int(150 + 60 / 100 * 450), "close": int(150 + 95 / 100 * 450)}
for i, move in enumerate(sys.argv[1:]):
    if i > 0:
        time.sleep(1)
    set_pwm(HAND, 0, pulses[move])
    print(move, pulses[move], flush=True)
print("done", flush=True)
