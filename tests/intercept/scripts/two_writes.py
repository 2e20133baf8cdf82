# Two GoPiGo frames one second apart (fwd, then bwd): used to lose the
# monitor in between. Prints how each write ended; after the first write has
# returned, creates the file named by the optional argument (the test's cue).
import sys
import time
from smbus2 import SMBus, i2c_msg

with SMBus(1) as bus:
    bus.i2c_rdwr(i2c_msg.write(0x08, [0x01, 0x77, 0, 0, 0]))
    print("first ok", flush=True)
    if len(sys.argv) > 1:
        open(sys.argv[1], "w").close()
    time.sleep(1)
    try:
        bus.i2c_rdwr(i2c_msg.write(0x08, [0x01, 0x6B, 0, 0, 0]))
        print("second ok", flush=True)
    except OSError as e:
        print("second failed", e.errno, flush=True)
