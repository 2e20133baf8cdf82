# python3-smbus2 with packet error checking on: auto-increment on (MODE1
# 0x21), then one byte write to 0x07 (LED0_ON_H), whose PEC the
# adapter appends, as i2c-core's emulation does on a plain adapter: the chip
# stores it in 0x08. Then a read of 0x07 with PEC, which the virtual chip
# cannot answer (it sends none): EBADMSG, as i2c-core reports it.
import errno

from smbus2 import SMBus

with SMBus(1) as bus:
    bus.write_byte_data(0x40, 0x00, 0x21)
    bus.pec = 1
    bus.write_byte_data(0x40, 0x07, 0x22)
    try:
        bus.read_byte_data(0x40, 0x07)
        print("read answered")
    except OSError as e:
        print("read", errno.errorcode.get(e.errno, e.errno))
