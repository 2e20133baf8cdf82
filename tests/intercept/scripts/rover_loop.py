# A rover control loop that never ends on its own: every 50 ms both wheel
# speeds and fwd() (the frames INV3 expects on the virtual bus's line
# follower). Writes its pid to argv[1] after its first frames went through,
# so a test knows it is running, then loops until it is killed. A failed
# write (EIO once the supervisor fail-closes) ends it with exit code 3.
import os
import sys
import time
from smbus2 import SMBus, i2c_msg

started = False
with SMBus(1) as bus:
    while True:
        try:
            for frame in ([0x01, 70, 80, 0, 0], [0x01, 71, 80, 0, 0], [0x01, 119, 0, 0, 0]):
                bus.i2c_rdwr(i2c_msg.write(0x08, frame))
        except OSError as e:
            print("write failed:", e, flush=True)
            sys.exit(3)
        if not started:
            with open(sys.argv[1] + ".tmp", "w") as f:
                f.write(str(os.getpid()))
            os.rename(sys.argv[1] + ".tmp", sys.argv[1])
            started = True
        time.sleep(0.05)
