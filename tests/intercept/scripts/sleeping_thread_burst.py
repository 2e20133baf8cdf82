# A task with two threads (python3-smbus2): the main thread writes MODE2 of
# the PCA9685 at 0x40 every 10 ms for SECONDS, far more than a budget of 3
# per 200 ms job; a second thread only sleeps half a period (100 ms) over
# and over. A sleeping thread must not end the task's job: the task gets its
# declared budget per period, not one per sleep.
# Prints "sent N" when the main thread is done.
import sys
import threading
import time
from smbus2 import SMBus, i2c_msg

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 2.0
done = threading.Event()


def sleeper():
    while not done.is_set():
        time.sleep(0.1)


t = threading.Thread(target=sleeper)
t.start()
sent = 0
with SMBus(1) as bus:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        bus.i2c_rdwr(i2c_msg.write(0x40, [0x01, 0x04]))  # MODE2: OUTDRV
        sent += 1
        time.sleep(0.01)
done.set()
t.join()
print("sent", sent, flush=True)
