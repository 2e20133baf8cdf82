# A hostile client of the monitor socket. Modes:
#   malformed SOCK N       one connection, hello as TASK (argv[4]) and then N
#                          transfer frames that do not decode (each answered kError)
#   reconnect SOCK SECONDS connect, send garbage, close, again, for SECONDS
#   idle SOCK N HOLD       open N connections that never say hello, hold them
#                          HOLD seconds (prints how many connected, and how
#                          many are still open after 0.5 s)
import socket
import struct
import sys
import time

mode, path = sys.argv[1], sys.argv[2]


def frame(kind, seq, payload=b""):
    return struct.pack("<HBBII", 0x4743, 1, kind, seq, len(payload)) + payload


def read_frame(s):
    head = b""
    while len(head) < 12:
        chunk = s.recv(12 - len(head))
        if not chunk:
            return None
        head += chunk
    _, _, kind, _, length = struct.unpack("<HBBII", head)
    body = b""
    while len(body) < length:
        chunk = s.recv(length - len(body))
        if not chunk:
            return None
        body += chunk
    return kind


if mode == "malformed":
    n, task = int(sys.argv[3]), sys.argv[4].encode()
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.connect(path)
    s.sendall(frame(1, 0, struct.pack("<H", len(task)) + task))
    read_frame(s)
    answered = 0
    t0 = time.time()
    for i in range(n):
        s.sendall(frame(3, i + 1, b"\xff\xff\xff"))  # a transfer that does not decode
        if read_frame(s) is not None:
            answered += 1
    print(f"malformed: {answered} of {n} answered in {time.time() - t0:.2f} s")
elif mode == "reconnect":
    end = time.time() + float(sys.argv[3])
    n = 0
    while time.time() < end:
        try:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.connect(path)
            s.sendall(b"\xff" * 12)
            s.close()
            n += 1
        except OSError:
            time.sleep(0.001)
    print(f"reconnect: {n} connections")
elif mode == "idle":
    n, hold = int(sys.argv[3]), float(sys.argv[4])
    conns = []
    for _ in range(n):
        try:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            s.settimeout(1)
            s.connect(path)
            conns.append(s)
        except OSError:
            break
    time.sleep(0.5)
    still = 0
    for s in conns:
        s.setblocking(False)
        try:
            s.recv(1, socket.MSG_PEEK)  # an answer or the end: refused
        except BlockingIOError:
            still += 1
        except OSError:
            pass
    print(f"idle: {len(conns)} connected, {still} still open", flush=True)
    time.sleep(hold)
