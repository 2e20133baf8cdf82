# A long-running program that starts a short-lived thread per job, each
# sending one PCA9685 write (LED0_ON_L, the job number) on a shared bus
# handle. Prints "done N" after N jobs.
import sys
import threading
from smbus2 import SMBus

jobs = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
with SMBus(1) as bus:
    for job in range(jobs):
        t = threading.Thread(target=bus.write_byte_data, args=(0x40, 0x06, job & 0xFF))
        t.start()
        t.join()
print("done", jobs, flush=True)
