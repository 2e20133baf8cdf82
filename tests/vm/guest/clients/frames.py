# Sends device frames with one of the three Python I2C libraries Debian
# ships, as an unmodified program would:
#   smbus      python3-smbus   write_i2c_block_data (ioctl I2C_SMBUS, I2C block)
#   smbus2     python3-smbus2  write_i2c_block_data (ioctl I2C_SMBUS, I2C block)
#   periphery  python3-periphery I2C.transfer       (ioctl I2C_RDWR, one write message)
# Each FRAME is REG:B1,B2,... (the GoPiGo frame 01 cmd v1 v2 v3 is 1:cmd,v1,v2,v3).
# With --sync DIR it hands over to the test after each frame (creates
# DIR/sent-K, waits for DIR/ack-K, then more than a period), so each frame is in
# a job of its own. Prints "frame K ok" or "frame K refused ERRNO".
# Usage: frames.py LIB [--sync DIR] ADDR FRAME...
import os
import sys
import time

lib, args = sys.argv[1], sys.argv[2:]
sync = None
if args[:1] == ["--sync"]:
    sync, args = args[1], args[2:]
addr = int(args[0], 0)
frames = []
for f in args[1:]:
    reg, data = f.split(":")
    frames.append((int(reg, 0), [int(b, 0) for b in data.split(",")]))

if lib == "smbus":
    import smbus
    bus = smbus.SMBus(1)
    send = lambda reg, data: bus.write_i2c_block_data(addr, reg, data)
elif lib == "smbus2":
    from smbus2 import SMBus
    bus = SMBus(1)
    send = lambda reg, data: bus.write_i2c_block_data(addr, reg, data)
elif lib == "periphery":
    from periphery import I2C
    bus = I2C("/dev/i2c-1")
    send = lambda reg, data: bus.transfer(addr, [I2C.Message([reg] + data)])
else:
    sys.exit("unknown library " + lib)


def handshake(name):
    if not sync:
        time.sleep(0.01)
        return
    open(os.path.join(sync, "sent-" + name), "w").close()
    while not os.path.exists(os.path.join(sync, "ack-" + name)):
        time.sleep(0.02)
    # The monitor releases the task's jobs on its period grid (the rover's:
    # 200 ms): a frame sent more than a period after the previous one is in a
    # job of its own, however quickly the test answered.
    time.sleep(0.21)


for k, (reg, data) in enumerate(frames):
    try:
        send(reg, data)
        print("frame", k, "ok", flush=True)
    except OSError as e:  # periphery wraps it in I2CError, an IOError
        print("frame", k, "refused", getattr(e, "errno", None), e, flush=True)
    handshake(str(k))
bus.close()
print("done", flush=True)
