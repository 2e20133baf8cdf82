# Leaves a process behind that outlives the supervised program: the program
# (this process) dies with its supervisor (PR_SET_PDEATHSIG), the process it
# forked does not. Once its parent is gone, that process opens the bus again
# and prints "orphan: " and what it got ("opened" or the errno name) to
# standard output (opening any file is a call the supervisor answers, so a
# file cannot tell). Writes the program's pid to argv[1] after a first write
# went through, then loops.
import errno
import os
import sys
import time
from smbus2 import SMBus, i2c_msg

pid_file = sys.argv[1]


def write_atomically(path, text):
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.rename(path + ".tmp", path)


with SMBus(1) as bus:
    bus.i2c_rdwr(i2c_msg.write(0x08, [0x01, 70, 80, 0, 0]))
if os.fork() == 0:
    parent = os.getppid()
    while os.getppid() == parent:
        try:
            time.sleep(0.02)
        except OSError:  # ENOSYS: the sleep is a call the supervisor answered too
            pass
    try:
        os.close(os.open("/dev/i2c-1", os.O_RDWR))
        outcome = "opened"
    except OSError as e:
        outcome = errno.errorcode.get(e.errno, str(e.errno))
    print("orphan:", outcome, flush=True)
    os._exit(0)
write_atomically(pid_file, str(os.getpid()))
while True:
    time.sleep(0.05)
