# The raw i2c-dev calls the vendor libraries end up making (the C library,
# Adafruit's PureIO backend): open /dev/i2c-N, I2C_SLAVE, write(), read().
# No smbus package needed, so these programs run wherever python3 does.
import ctypes
import fcntl
import os

I2C_SLAVE, I2C_RDWR, I2C_M_RD = 0x0703, 0x0707, 0x0001


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

    def write_then_read(self, out, n):  # PureIO's writeto_then_readfrom: one I2C_RDWR, 2 messages
        wbuf = ctypes.create_string_buffer(bytes(out), len(out))
        rbuf = ctypes.create_string_buffer(n)
        msgs = (_Msg * 2)(_Msg(self.addr, 0, len(out), ctypes.addressof(wbuf)),
                          _Msg(self.addr, I2C_M_RD, n, ctypes.addressof(rbuf)))
        fcntl.ioctl(self.fd, I2C_RDWR, _RdwrData(ctypes.addressof(msgs), 2))
        return rbuf.raw


class _Msg(ctypes.Structure):  # struct i2c_msg
    _fields_ = [("addr", ctypes.c_uint16), ("flags", ctypes.c_uint16),
                ("len", ctypes.c_uint16), ("buf", ctypes.c_void_p)]


class _RdwrData(ctypes.Structure):  # struct i2c_rdwr_ioctl_data
    _fields_ = [("msgs", ctypes.c_void_p), ("nmsgs", ctypes.c_uint32)]
