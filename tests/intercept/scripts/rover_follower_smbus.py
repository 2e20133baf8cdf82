# One job of the vendor's rover loop with python3-smbus (I2C_BLOCK_BROKEN
# writes of register 1), asking for speed 200 where the policy expects 80,
# then, in the next job, a digitalWrite the rover policy forbids.
import time
import smbus

bus = smbus.SMBus(1)
ADDR = 0x08
bus.write_i2c_block_data(ADDR, 1, [70, 200, 0, 0])  # set_left_speed(200)
bus.write_i2c_block_data(ADDR, 1, [71, 200, 0, 0])  # set_right_speed(200)
bus.write_i2c_block_data(ADDR, 1, [105, 0, 0, 0])   # fwd
print("job 1 sent", flush=True)
time.sleep(0.21)  # past one period (100 ms): a later job on the task's grid
try:
    bus.write_i2c_block_data(ADDR, 1, [12, 9, 1, 0])  # digital_write
    print("digital_write accepted", flush=True)
except PermissionError:
    print("digital_write refused", flush=True)
