# One corpus of wire shapes, for the differential test of the two clients
# (scenario 65): every form of include/contego/i2c_plan.h's table and the
# shapes beyond it, as I2C_RDWR message lists (combined reads of 1..40
# bytes, RECV_LEN block reads, process calls, three-message transfers,
# zero-length messages, ten-bit addresses), as every I2C_SMBUS size and as
# plain read()/write() after I2C_SLAVE, to a register-file chip at 0x40,
# after giving the descriptor its own I2C_RETRIES and I2C_TIMEOUT.
# With LOSE (i2c-plain-stub's lose_arbitration parameter, writable by the
# program), steps on a bus with another master: the adapter's next transfers
# lose arbitration (EAGAIN), and the descriptor's own I2C_RETRIES decide
# whether the call gets through: 3 retries ride out 3 losses, not 4; a
# descriptor with I2C_RETRIES 0, or one that never set it, is told EAGAIN
# at the first.
# With PEC on (I2C_PEC), an SMBus write carries the packet error code as one
# more byte where the adapter puts it on the wire (I2C_FUNC_SMBUS_PEC:
# i2c-plain-stub's SMBus emulation, not i2c-stub): the chip stores it in the
# register after the write's, so it must be checked as a byte of the write,
# and a write() or an I2C block write never carries one.
# Prints one line per step: what the program was told (ok and the bytes
# read, or the errno's name). Under contego.ko and under the monitor, on the
# same adapter, the two outputs must be the same.
#
# `formless`: instead, the steps whose verdicts send what the adapter has no
# form for (scenario 65 cuts i2c-stub's functionality to word and SMBus
# block writes: no byte data, no I2C block), under the policy with a register
# file at 0x40 (r08 capped: `failsafe value = 100`) and a GoPiGo at 0x08:
# each client refuses such a call before any part of it acts.
# Usage: wire_corpus.py BUS [LOSE | formless]
import errno
import fcntl
import os
import sys

from smbus2 import SMBus, i2c_msg

I2C_RETRIES = 0x0701
I2C_TIMEOUT = 0x0702
I2C_SLAVE = 0x0703
I2C_M_TEN = 0x0010
I2C_M_RECV_LEN = 0x0400
A = 0x40
bus = SMBus(int(sys.argv[1]))
LOSE = sys.argv[2] if len(sys.argv) > 2 and sys.argv[2] != "formless" else None


def rdwr(*msgs):
    bus.i2c_rdwr(*msgs)
    return [b for m in msgs if m.flags & 1 for b in list(m)]


def w(*data, addr=A):
    return i2c_msg.write(addr, list(data))


def r(n, addr=A):
    return i2c_msg.read(addr, n)


def recv_len():  # an SMBus block read's message: 33 bytes, the count preset to 1
    m = i2c_msg.read(A, 33)
    m.flags |= I2C_M_RECV_LEN
    m.buf[0] = b"\x01"
    return m


def ten_bit(m):
    m.flags |= I2C_M_TEN
    return m


def raw_write(data):
    fcntl.ioctl(bus.fd, I2C_SLAVE, A)
    return os.write(bus.fd, bytes(data))


def raw_read(n):
    fcntl.ioctl(bus.fd, I2C_SLAVE, A)
    return list(os.read(bus.fd, n))


def own_timing():  # this descriptor's own: 3 retries, 70 ms (units of 10 ms)
    fcntl.ioctl(bus.fd, I2C_RETRIES, 3)
    fcntl.ioctl(bus.fd, I2C_TIMEOUT, 7)


def losing(n, call):  # call() while the adapter's next n transfers lose arbitration
    with open(LOSE, "w") as f:
        f.write(str(n))
    return call()


def descriptor(retries=None):  # another open() of the bus, with I2C_RETRIES or without
    other = SMBus(int(sys.argv[1]))
    if retries is not None:
        fcntl.ioctl(other.fd, I2C_RETRIES, retries)
    return other


def crc8(data):  # SMBus PEC: CRC-8, polynomial x^8 + x^2 + x + 1
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def pec_bus():  # another open() of the bus, with I2C_PEC on
    other = SMBus(int(sys.argv[1]))
    other.pec = 1
    return other


def pec_landed(reg, wire):  # [1] if reg holds the PEC of `wire` written at A, else [0]
    return [1 if bus.read_byte_data(A, reg) == crc8([A << 1] + wire) else 0]


def pec_raw_write(data):
    other = pec_bus()
    fcntl.ioctl(other.fd, I2C_SLAVE, A)
    return os.write(other.fd, bytes(data))


steps = [
    ("I2C_RETRIES 3, I2C_TIMEOUT 7", own_timing),
    # I2C_RDWR writes: byte data, word data, I2C block, SMBus block, too long.
    ("rdwr write 2 (byte data)", lambda: rdwr(w(0x02, 0x11))),
    ("rdwr write 3 (word data)", lambda: rdwr(w(0x03, 0x22, 0x33))),
    ("rdwr write 9 (I2C block)", lambda: rdwr(w(0x05, *range(1, 9)))),
    ("rdwr write 5 counted", lambda: rdwr(w(0x08, 3, 0xA, 0xB, 0xC))),
    ("rdwr write 33", lambda: rdwr(w(0x00, *range(0x40, 0x60)))),
    ("rdwr write 34 counted (SMBus block)", lambda: rdwr(w(0x00, 32, *range(0x60, 0x80)))),
    ("rdwr write 40", lambda: rdwr(w(0x00, *range(0x80, 0x80 + 39)))),
    ("rdwr write 1 (send byte)", lambda: rdwr(w(0x02))),
    ("rdwr write 0 (quick)", lambda: rdwr(w())),
    ("rdwr read 0 (quick read)", lambda: rdwr(r(0))),
    # Combined reads.
    ("rdwr [w1][r1]", lambda: rdwr(w(0x02), r(1))),
    ("rdwr [w1][r2]", lambda: rdwr(w(0x02), r(2))),
    ("rdwr [w1][r16]", lambda: rdwr(w(0x00), r(16))),
    ("rdwr [w1][r32]", lambda: rdwr(w(0x00), r(32))),
    ("rdwr [w1][r40]", lambda: rdwr(w(0x00), r(40))),
    ("rdwr [w1][RECV_LEN]", lambda: rdwr(w(0x08), recv_len())),
    ("rdwr [w3][r2] (process call)", lambda: rdwr(w(0x04, 0x34, 0x12), r(2))),
    ("rdwr [w4][RECV_LEN] (block process call)", lambda: rdwr(w(0x08, 2, 0x5, 0x6), recv_len())),
    ("rdwr [w2][r1]", lambda: rdwr(w(0x02, 0x44), r(1))),
    ("rdwr [w1][w1][r1]", lambda: rdwr(w(0x02, 0x55), w(0x02), r(1))),
    ("rdwr [w1][r1][w2]", lambda: rdwr(w(0x03), r(1), w(0x04, 0x66))),
    ("rdwr lone r1 (receive byte)", lambda: rdwr(r(1))),
    ("rdwr lone r4", lambda: rdwr(r(4))),
    ("rdwr lone RECV_LEN", lambda: rdwr(recv_len())),
    ("rdwr [w1][r1] other address", lambda: rdwr(w(0x02, addr=0x41), r(1, addr=0x41))),
    ("rdwr ten-bit write", lambda: rdwr(ten_bit(w(0x02, 0x11)))),
    ("rdwr forbidden register", lambda: rdwr(w(0xF0, 0x01))),
    # I2C_SMBUS, every size.
    ("smbus write quick", lambda: bus.write_quick(A)),
    ("smbus write byte", lambda: bus.write_byte(A, 0x06)),
    ("smbus read byte", lambda: bus.read_byte(A)),
    ("smbus write byte data", lambda: bus.write_byte_data(A, 0x06, 0x77)),
    ("smbus read byte data", lambda: bus.read_byte_data(A, 0x06)),
    ("smbus write word data", lambda: bus.write_word_data(A, 0x09, 0x1234)),
    ("smbus read word data", lambda: bus.read_word_data(A, 0x09)),
    ("smbus process call", lambda: bus.process_call(A, 0x0B, 0x5678)),
    ("smbus write block data", lambda: bus.write_block_data(A, 0x0D, [1, 2, 3])),
    ("smbus read block data", lambda: bus.read_block_data(A, 0x0D)),
    ("smbus block process call", lambda: bus.block_process_call(A, 0x0D, [2, 9, 8])),
    ("smbus write i2c block 8", lambda: bus.write_i2c_block_data(A, 0x10, list(range(0x21, 0x29)))),
    ("smbus read i2c block 8", lambda: bus.read_i2c_block_data(A, 0x10, 8)),
    ("smbus read i2c block 32", lambda: bus.read_i2c_block_data(A, 0x00, 32)),
    ("smbus write byte data forbidden", lambda: bus.write_byte_data(A, 0xF1, 1)),
    # read() and write() after I2C_SLAVE.
    ("write() 3", lambda: raw_write([0x18, 0x31, 0x32])),
    ("write() 40", lambda: raw_write([0x00] + list(range(0xA0, 0xA0 + 39)))),
    ("read() 1", lambda: raw_read(1)),
    ("read() 4", lambda: raw_read(4)),
    ("read() 0", lambda: raw_read(0)),
    # I2C_PEC on: each write's PEC in the register after it, where the wire has one.
    ("pec smbus write byte data", lambda: pec_bus().write_byte_data(A, 0x1A, 0x61)),
    ("pec landed after write byte data", lambda: pec_landed(0x1B, [0x1A, 0x61])),
    ("pec smbus write word data", lambda: pec_bus().write_word_data(A, 0x1C, 0x6362)),
    ("pec landed after write word data", lambda: pec_landed(0x1E, [0x1C, 0x62, 0x63])),
    ("pec smbus write byte", lambda: pec_bus().write_byte(A, 0x1F)),
    ("pec landed after write byte", lambda: pec_landed(0x1F, [0x1F])),
    ("pec smbus write block data", lambda: pec_bus().write_block_data(A, 0x14, [0x64, 0x65])),
    ("pec landed after write block data", lambda: pec_landed(0x17, [0x14, 2, 0x64, 0x65])),
    ("pec write() 2", lambda: pec_raw_write([0x18, 0x66])),
    ("pec landed after write()", lambda: pec_landed(0x19, [0x18, 0x66])),
    ("pec smbus write i2c block 1", lambda: pec_bus().write_i2c_block_data(A, 0x12, [0x67])),
    ("pec landed after i2c block", lambda: pec_landed(0x13, [0x12, 0x67])),
    ("pec smbus read byte data", lambda: pec_bus().read_byte_data(A, 0x1A)),
    ("pec smbus process call", lambda: pec_bus().process_call(A, 0x0B, 0x5678)),
    # The PEC of a write at r30 would land in r31, a register the policy does not have.
    ("pec smbus write byte data r30", lambda: pec_bus().write_byte_data(A, 0x30, 0x68)),
]
if LOSE:
    steps += [
        ("3 lost, I2C_RETRIES 3: rdwr write", lambda: losing(3, lambda: rdwr(w(0x20, 0x5A)))),
        ("2 lost, I2C_RETRIES 3: rdwr [w1][r2]", lambda: losing(2, lambda: rdwr(w(0x20), r(2)))),
        ("2 lost, I2C_RETRIES 3: smbus read byte data",
         lambda: losing(2, lambda: bus.read_byte_data(A, 0x20))),
        ("4 lost, I2C_RETRIES 3: smbus write byte data",
         lambda: losing(4, lambda: bus.write_byte_data(A, 0x21, 0x5B))),
        ("1 lost, I2C_RETRIES 0: smbus write byte data",
         lambda: losing(1, lambda: descriptor(0).write_byte_data(A, 0x22, 0x5C))),
        ("1 lost, no I2C_RETRIES: smbus write byte data",
         lambda: losing(1, lambda: descriptor().write_byte_data(A, 0x23, 0x5D))),
        ("1 lost, I2C_RETRIES 3 still (another descriptor set 0): rdwr write",
         lambda: losing(1, lambda: rdwr(w(0x24, 0x5E)))),
    ]
steps += [("final [w1][r32]", lambda: rdwr(w(0x00), r(32)))]

formless_steps = [
    # Both writes allowed: the frame has its form (a count-prefixed SMBus
    # block write), the core's writes of the word, one per register, none.
    ("formless rdwr [frame 0x08][w3 r04] (allowed)",
     lambda: rdwr(w(0x47, 0x02, 0x00, 0x00, addr=0x08), w(0x04, 0x11, 0x22))),
    # r08 = 200 substituted by 100: the core writes r08 and r09 apart.
    ("formless smbus write word data r08 (substituted)", lambda: bus.write_word_data(A, 0x08, 200)),
    ("formless rdwr [w3 r08] (substituted)", lambda: rdwr(w(0x08, 200, 0x00))),
    ("formless write() 3 r08 (substituted)", lambda: raw_write([0x08, 200, 0x00])),
    # Controls: each goes out, in the form the program's call has.
    ("formless rdwr [frame 0x08] alone", lambda: rdwr(w(0x46, 0x02, 0x00, 0x00, addr=0x08))),
    ("formless smbus write word data r00 (allowed, as sent)", lambda: bus.write_word_data(A, 0x00, 0x2211)),
]
if len(sys.argv) > 2 and sys.argv[2] == "formless":
    steps = formless_steps

for name, step in steps:
    try:
        got = step()
        if isinstance(got, int):
            got = [got]
        print(name, "ok", " ".join("%02x" % b for b in (got or [])))
    except OSError as e:
        print(name, "err", errno.errorcode.get(e.errno, e.errno))
    sys.stdout.flush()
print("done")
