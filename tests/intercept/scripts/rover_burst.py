# A runaway rover loop: N set_left_speed(80) frames back to back, never
# sleeping (python3-smbus2). Prints "sent N" when every write returned.
import sys
from smbus2 import SMBus, i2c_msg

frames = int(sys.argv[1]) if len(sys.argv) > 1 else 30
with SMBus(1) as bus:
    for _ in range(frames):
        bus.i2c_rdwr(i2c_msg.write(0x08, [0x01, 70, 80, 0, 0]))
print("sent", frames, flush=True)
