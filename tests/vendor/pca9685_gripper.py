# A vendor-style gripper program, written to send what Adafruit_PCA9685 sends
# (PureIO backend, one register per write): the constructor (set_all_pwm(0,
# 0), MODE2 = OUTDRV, MODE1 = ALLCALL, wake), set_pwm_freq(60) (sleep,
# PRE_SCALE 101, restore, restart), then tutRPi's Hand: open (420), one job
# later close (577). Prints "done" at the end.
import time

from i2c_dev import Device

MODE1, MODE2, PRESCALE = 0x00, 0x01, 0xFE
LED0_ON_L, ALL_LED_ON_L = 0x06, 0xFA
SLEEP, ALLCALL, OUTDRV, RESTART = 0x10, 0x01, 0x04, 0x80

pca = Device(1, 0x40)


def set_all_pwm(on, off):
    pca.write8(ALL_LED_ON_L, on & 0xFF)
    pca.write8(ALL_LED_ON_L + 1, on >> 8)
    pca.write8(ALL_LED_ON_L + 2, off & 0xFF)
    pca.write8(ALL_LED_ON_L + 3, off >> 8)


def set_pwm(channel, on, off):
    base = LED0_ON_L + 4 * channel
    pca.write8(base, on & 0xFF)
    pca.write8(base + 1, on >> 8)
    pca.write8(base + 2, off & 0xFF)
    pca.write8(base + 3, off >> 8)


# PCA9685.__init__
set_all_pwm(0, 0)
pca.write8(MODE2, OUTDRV)
pca.write8(MODE1, ALLCALL)
time.sleep(0.005)
mode1 = pca.read_u8(MODE1) & ~SLEEP
pca.write8(MODE1, mode1)
time.sleep(0.005)
# set_pwm_freq(60): prescale = int(25 MHz / 4096 / 60 - 1 + 0.5) = 101
oldmode = pca.read_u8(MODE1)
pca.write8(MODE1, (oldmode & 0x7F) | SLEEP)
pca.write8(PRESCALE, 101)
pca.write8(MODE1, oldmode)
time.sleep(0.005)
pca.write8(MODE1, oldmode | RESTART)
set_pwm(5, 0, 420)  # Hand.open()
time.sleep(0.6)  # the next job (a sleep entered half a period into the job ends it)
time.sleep(0.6)
set_pwm(5, 0, 577)  # Hand.close()
print("done", flush=True)
