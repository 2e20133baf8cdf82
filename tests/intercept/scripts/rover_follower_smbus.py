# One job of the vendor's rover loop with python3-smbus (I2C_BLOCK_BROKEN
# writes of register 1), asking for speed 150 where the policy expects 80,
# then, in the next job, a digitalWrite the rover policy forbids.
import time
import smbus

bus = smbus.SMBus(1)
ADDR = 0x08
bus.write_i2c_block_data(ADDR, 1, [70, 150, 0, 0])  # set_left_speed(150)
bus.write_i2c_block_data(ADDR, 1, [71, 150, 0, 0])  # set_right_speed(150)
bus.write_i2c_block_data(ADDR, 1, [105, 0, 0, 0])   # fwd
print("job 1 sent", flush=True)
time.sleep(0.21)  # one period (200 ms): the next job on the task's grid
try:
    bus.write_i2c_block_data(ADDR, 1, [12, 9, 1, 0])  # digital_write
    print("digital_write accepted", flush=True)
except PermissionError:
    print("digital_write refused", flush=True)
