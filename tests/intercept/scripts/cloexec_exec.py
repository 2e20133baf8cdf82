# Opens the bus (Python descriptors are O_CLOEXEC), then execs itself and,
# in the new image, tries to use the old descriptor number: the kernel closed
# it, so the emulation must not answer for it either.
import fcntl
import os
import sys

I2C_SLAVE = 0x0703
if len(sys.argv) == 1:
    fd = os.open("/dev/i2c-1", os.O_RDWR)
    fcntl.ioctl(fd, I2C_SLAVE, 0x40)
    print("before exec ok", flush=True)
    os.execv(sys.executable, [sys.executable, sys.argv[0], str(fd)])
fd = int(sys.argv[1])
try:
    fcntl.ioctl(fd, I2C_SLAVE, 0x40)
    os.write(fd, bytes([0x06, 0x55]))
    print("after exec still usable", flush=True)
except OSError as e:
    print("after exec errno", e.errno, flush=True)
