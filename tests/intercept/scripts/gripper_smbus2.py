# The arm's gripper task with python3-smbus2: set_pwm(5, 0, 420) as one
# auto-increment block write of LED5 (the gripper may not read the
# controller back), then, next job, a PRE_SCALE write the
# gripper may not make.
import time
from smbus2 import SMBus

ADDR = 0x40
with SMBus(1) as bus:
    bus.write_i2c_block_data(ADDR, 0x1A, [0, 0, 420 & 0xFF, 420 >> 8])
    print("pulse sent", flush=True)
    time.sleep(0.05)
    try:
        bus.write_byte_data(ADDR, 0xFE, 0x03)
        print("prescale written", flush=True)
    except PermissionError:
        print("prescale refused", flush=True)
