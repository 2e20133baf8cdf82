# The vendor's red line follower as its own code runs it, written to make the
# calls DI's libraries make (facts from the GoPiGo and DI_Sensors sources):
# - gopigo.py (2018): every command is smbus write_i2c_block_data(0x08, 1,
#   [cmd, v1, v2, v3]) followed by a 5 ms sleep; set_speed(s) is
#   set_left_speed(s), a 100 ms sleep, set_right_speed(s); stop() at exit;
# - DI_Sensors line_sensor.py: before each read, detect_line_follower() (a
#   one-byte read probe, then [0x12] and a 20-byte name read), then
#   [01 03 00 00 00] and a 10-byte read, each its own I2C_RDWR transfer
#   (python-periphery);
# - line_follow.py: set_speed(150) once, then a free-running loop with no
#   sleep of its own: 85 + right() left of the line, 125 + left() right of
#   it, 80 + fwd() on it.
# Usage: di_line_follow.py SECONDS [--flood]   prints "done N" (iterations).
# --flood also runs a spoofing thread in the same process that sends
# increase_speed() frames back to back (the paper's DoS burst).
import atexit
import sys
import threading
import time

import smbus
from periphery import I2C

GOPIGO, LINE = 0x08, 0x06
WHITE = [767, 815, 859, 710, 700]
BLACK = [1012, 1013, 1015, 1003, 1004]
MULTIPLIERS = [-100, -50, 0, 50, 100]

bus = smbus.SMBus(1)
lock = threading.Lock()  # smbus.SMBus is one descriptor; the library is not thread-safe


def write_i2c_block(block):
    with lock:
        bus.write_i2c_block_data(GOPIGO, 1, block)
    time.sleep(0.005)


def set_left_speed(s):
    write_i2c_block([70, s, 0, 0])


def set_right_speed(s):
    write_i2c_block([71, s, 0, 0])


def set_speed(s):
    set_left_speed(s)
    time.sleep(0.1)
    set_right_speed(s)


def fwd():
    write_i2c_block([105, 0, 0, 0])


def left():
    write_i2c_block([97, 0, 0, 0])


def right():
    write_i2c_block([100, 0, 0, 0])


def stop():
    write_i2c_block([120, 0, 0, 0])


def read_sensor():
    i2c = I2C("/dev/i2c-1")
    try:
        i2c.transfer(LINE, [I2C.Message([0], read=True)])  # detect_line_follower()
        i2c.transfer(LINE, [I2C.Message([0x12])])
        i2c.transfer(LINE, [I2C.Message([0] * 20, read=True)])
        i2c.transfer(LINE, [I2C.Message([1, 3, 0, 0, 0])])
        reply = I2C.Message([0] * 10, read=True)
        i2c.transfer(LINE, [reply])
    finally:
        i2c.close()
    raw = reply.data
    return [raw[2 * i] * 256 + raw[2 * i + 1] for i in range(5)]


def line_position(values):
    return sum((v - w) * 100 / (b - w) * m for v, w, b, m in zip(values, WHITE, BLACK, MULTIPLIERS))


flooding = True


def flood():
    while flooding:
        write_i2c_block([116, 0, 0, 0])  # increase_speed()


seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 3
atexit.register(stop)
set_speed(150)
if "--flood" in sys.argv:
    threading.Thread(target=flood, daemon=True).start()
iterations = 0
end = time.monotonic() + seconds
while time.monotonic() < end:
    curr = line_position(read_sensor())
    if curr < -2500:
        set_speed(85)
        right()
    elif curr > 2500:
        set_speed(125)
        left()
    else:
        set_speed(80)
        fwd()
    iterations += 1
flooding = False
print("done", iterations, flush=True)
