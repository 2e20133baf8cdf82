#!/usr/bin/env python3
"""A GoPiGo2 red line-follower loop, written from the vendor's documented
behaviour (DI_Sensors line_follow.py: calibration, weights, +-2500
thresholds, set_speed then a direction command), talking to /dev/i2c-1
through the plain i2c-dev calls the vendor's C library uses: ioctl(I2C_SLAVE),
write() of 5-byte frames, read() of the follower's 10-byte reply.

It knows nothing about contego. For demonstrations it carries a logic bomb
(--attack spoof|dos, active between --attack-from and --attack-to seconds
after start), like the compromised task of the paper's case study.
"""
import argparse
import fcntl
import os
import time

I2C_SLAVE = 0x0703
GOPIGO = 0x08
LINE_FOLLOWER = 0x06
WHITE = [767, 815, 859, 710, 700]
BLACK = [1012, 1013, 1015, 1003, 1004]
WEIGHTS = [-100, -50, 0, 50, 100]
FWD, LEFT, RIGHT, STOP, SET_LEFT, SET_RIGHT, INCREASE = 105, 97, 100, 120, 70, 71, 116


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--bus", default="/dev/i2c-1")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds to run")
    ap.add_argument("--period", type=float, default=0.2, help="loop period in seconds")
    ap.add_argument("--attack", choices=["none", "spoof", "dos"], default="none")
    ap.add_argument("--attack-from", type=float, default=0.0)
    ap.add_argument("--attack-to", type=float, default=0.0)
    args = ap.parse_args()

    fd = os.open(args.bus, os.O_RDWR)

    def write(addr, frame):
        fcntl.ioctl(fd, I2C_SLAVE, addr)
        os.write(fd, bytes(frame))

    def read(addr, n):
        fcntl.ioctl(fd, I2C_SLAVE, addr)
        return os.read(fd, n)

    start = time.monotonic()
    release = start
    while time.monotonic() - start < args.duration:
        now = time.monotonic() - start
        write(LINE_FOLLOWER, [1, 3, 0, 0, 0])
        raw = read(LINE_FOLLOWER, 10)
        values = [(raw[2 * i] << 8) | raw[2 * i + 1] for i in range(5)]
        pos = sum((v - w) * 100 / (b - w) * m for v, w, b, m in zip(values, WHITE, BLACK, WEIGHTS))
        if pos < -2500:
            speed, direction = 85, RIGHT
        elif pos > 2500:
            speed, direction = 125, LEFT
        else:
            speed, direction = 80, FWD
        right_speed = speed
        bomb = args.attack != "none" and args.attack_from <= now < args.attack_to
        if bomb and args.attack == "spoof":  # one motor off: right wheel at 0, only it driven
            right_speed, direction = 0, LEFT
        write(GOPIGO, [1, SET_LEFT, speed, 0, 0])
        time.sleep(0.1)  # set_speed waits 100 ms between the two wheels
        write(GOPIGO, [1, SET_RIGHT, right_speed, 0, 0])
        time.sleep(0.005)
        write(GOPIGO, [1, direction, 0, 0, 0])
        if bomb and args.attack == "dos":
            for _ in range(10):
                write(GOPIGO, [1, INCREASE, 0, 0, 0])
        release += args.period
        time.sleep(max(0.0, release - time.monotonic()))
    write(GOPIGO, [1, STOP, 0, 0, 0])
    os.close(fd)


if __name__ == "__main__":
    main()
