# One corpus of I2C transfers, as the vendors' libraries and i2c-tools make
# them, sent to the PCA9685 at 0x40 on /dev/i2c-BUS: SMBus calls (byte data,
# word data, I2C block), Adafruit_PureIO's raw write() after I2C_SLAVE and
# its I2C_RDWR register read, allowed, ignored and refused alike. Prints one
# line per step: what the program was told (ok and the bytes read, or the
# errno). Run under contego.ko and under the monitor, the two outputs must
# be the same (scenario 62).
# Usage: parity_corpus.py BUS
import errno
import fcntl
import os
import sys

from smbus2 import SMBus, i2c_msg

I2C_SLAVE = 0x0703
A = 0x40
bus = SMBus(int(sys.argv[1]))
LED5 = 0x1A


def raw_write(data):  # Adafruit_PureIO.write8 and friends
    fcntl.ioctl(bus.fd, I2C_SLAVE, A)
    os.write(bus.fd, bytes(data))


def rdwr_read(reg, n):  # Adafruit_PureIO.read_byte_data / readList
    w, r = i2c_msg.write(A, [reg]), i2c_msg.read(A, n)
    bus.i2c_rdwr(w, r)
    return list(r)


steps = [
    ("read MODE1 (byte data)", lambda: bus.read_byte_data(A, 0x00)),
    ("MODE2 = OUTDRV (byte data)", lambda: bus.write_byte_data(A, 0x01, 0x04)),
    ("MODE2 = INVRT (ignored by MODE2)", lambda: bus.write_byte_data(A, 0x01, 0x10)),
    ("read MODE2 (I2C_RDWR)", lambda: rdwr_read(0x01, 1)),
    ("PRE_SCALE = 101 (raw write)", lambda: raw_write([0xFE, 101])),
    ("PRE_SCALE = 3 (ignored)", lambda: raw_write([0xFE, 3])),
    ("read PRE_SCALE (I2C_RDWR)", lambda: rdwr_read(0xFE, 1)),
    ("LED5 ON_L, ON_H one at a time (staged)",
     lambda: (raw_write([LED5, 0]), raw_write([LED5 + 1, 0]))),
    ("LED5 OFF_L, OFF_H one at a time (420: commits)",
     lambda: (raw_write([LED5 + 2, 0xA4]), raw_write([LED5 + 3, 0x01]))),
    ("read LED5 OFF (word data)", lambda: bus.read_word_data(A, LED5 + 2)),
    ("MODE1 = AI | ALLCALL", lambda: bus.write_byte_data(A, 0x00, 0x21)),
    ("LED5 block write off 577 (AI on)",
     lambda: bus.write_i2c_block_data(A, LED5, [0, 0, 577 & 0xFF, 577 >> 8])),
    ("LED5 block write off 900 (out of the servo window)",
     lambda: bus.write_i2c_block_data(A, LED5, [0, 0, 900 & 0xFF, 900 >> 8])),
    ("read LED5 (I2C block, 4 bytes)", lambda: bus.read_i2c_block_data(A, LED5, 4)),
    ("LED5 OFF word write 420 (word data)", lambda: bus.write_word_data(A, LED5 + 2, 420)),
    ("TestMode register 0xFF (forbidden)", lambda: bus.write_byte_data(A, 0xFF, 1)),
    ("SUBADR1 (refused EPERM)", lambda: bus.write_byte_data(A, 0x02, 0xE2)),
    ("unknown register 0x50", lambda: bus.write_byte_data(A, 0x50, 1)),
    ("ALL_LED off (all_led, ALL_OFF_ONLY)",
     lambda: bus.write_i2c_block_data(A, 0xFA, [0, 0, 0, 0x10])),
    ("read all of LED5..LED6 (I2C_RDWR, 8 bytes)", lambda: rdwr_read(LED5, 8)),
]
for name, step in steps:
    try:
        got = step()
        print(f"{name}: ok{'' if got is None or isinstance(got, tuple) else ' ' + str(got)}",
              flush=True)
    except OSError as e:
        print(f"{name}: {errno.errorcode.get(e.errno, e.errno)}", flush=True)
print("done")
