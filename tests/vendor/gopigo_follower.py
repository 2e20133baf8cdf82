# A vendor-style rover program, written to send what DI's drivers send:
# the line-sensor driver (DI_Sensors red line follower: board probe 0x12 and
# a 20-byte read, then 01 03 00 00 00 and a 10-byte read), the line-follow
# loop (line_follow.py: set_speed = set_left_speed + set_right_speed, then
# right / left / fwd from the position) and gopigo.py's status queries
# (volt, fw_ver, enc_read, us_dist, read_motor_speed: a 5-byte frame with the
# dummy register byte 1, then two one-byte reads). Ends with stop().
# Usage: gopigo_follower.py [ITERATIONS]; prints "done N" at the end.
import sys
import time

from i2c_dev import Device

WHITE = [767, 815, 859, 710, 700]
BLACK = [1012, 1013, 1015, 1003, 1004]
WEIGHTS = [-100, -50, 0, 50, 100]


def cmd(gpg, c, v1=0, v2=0, v3=0):
    gpg.write([1, c, v1, v2, v3])


def query(gpg, c, v1=0):
    cmd(gpg, c, v1)
    time.sleep(0.005)
    return gpg.read(1)[0] * 256 + gpg.read(1)[0]


def read_line(line):
    line.read(1)  # detect_line_follower(): a one-byte read probe ...
    line.write([0x12])  # ... then the board name
    line.read(20)
    line.write([1, 3, 0, 0, 0])
    raw = line.read(10)
    return [raw[2 * i] * 256 + raw[2 * i + 1] for i in range(5)]


def position(values):  # the vendor's formula, in integers as the policy has it
    total = 0
    for v, w, b, m in zip(values, WHITE, BLACK, WEIGHTS):
        total += int((v - w) * 100 / (b - w)) * m
    return total


iterations = int(sys.argv[1]) if len(sys.argv) > 1 else 4
gpg = Device(1, 0x08)
line = Device(1, 0x06)
print("fw", query(gpg, 20), "volt", query(gpg, 118), flush=True)
for i in range(iterations):
    pos = position(read_line(line))
    if pos < -2500:
        speed, direction = 85, 100  # right
    elif pos > 2500:
        speed, direction = 125, 97  # left
    else:
        speed, direction = 80, 105  # fwd
    cmd(gpg, 70, speed)
    cmd(gpg, 71, speed)
    cmd(gpg, direction)
    query(gpg, 53, 0)  # enc_read(0)
    query(gpg, 117, 15)  # us_dist(15)
    query(gpg, 114)  # read_motor_speed
    # One iteration per 200 ms period. Two sleeps: the monitor starts a new
    # job at a sleep entered at least half a period after the job began.
    time.sleep(0.11)
    time.sleep(0.15)
cmd(gpg, 120)  # atexit: stop()
print("done", iterations, flush=True)
