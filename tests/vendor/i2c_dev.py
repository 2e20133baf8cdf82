# The raw i2c-dev calls the vendor libraries end up making (the C library,
# Adafruit's PureIO backend): open /dev/i2c-N, I2C_SLAVE, write(), read().
# No smbus package needed, so these programs run wherever python3 does.
import fcntl
import os

I2C_SLAVE = 0x0703


class Device:
    def __init__(self, bus, addr):
        self.fd = os.open("/dev/i2c-%d" % bus, os.O_RDWR)
        self.addr = addr
        fcntl.ioctl(self.fd, I2C_SLAVE, addr)

    def write(self, data):
        os.write(self.fd, bytes(data))

    def read(self, n):
        return os.read(self.fd, n)

    def write8(self, reg, value):  # Adafruit_GPIO.I2C.Device.write8
        self.write([reg, value & 0xFF])

    def read_u8(self, reg):  # Adafruit_GPIO.I2C.Device.readU8 (PureIO: write, then read)
        self.write([reg])
        return self.read(1)[0]
