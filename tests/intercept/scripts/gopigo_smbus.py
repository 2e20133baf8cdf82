# Replays the old GoPiGo Python library's wire sequence with python3-smbus:
# set_speed(150) = frames 70 and 71 as I2C_BLOCK_BROKEN writes of register 1,
# fwd = 105, a digitalWrite (12) and read_motor_speed (114) + two byte reads.
import smbus

bus = smbus.SMBus(1)
ADDR = 0x08
bus.write_i2c_block_data(ADDR, 1, [70, 150, 0, 0])
bus.write_i2c_block_data(ADDR, 1, [71, 150, 0, 0])
bus.write_i2c_block_data(ADDR, 1, [105, 0, 0, 0])
bus.write_i2c_block_data(ADDR, 1, [12, 9, 1, 0])
print("digitalWrite ignored")
bus.write_i2c_block_data(ADDR, 1, [114, 0, 0, 0])
right = bus.read_byte(ADDR)
left = bus.read_byte(ADDR)
print("speeds", left, right)
