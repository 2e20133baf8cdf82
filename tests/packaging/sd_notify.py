#!/usr/bin/env python3
"""contego monitor speaks systemd's notify protocol (Type=notify unit):
READY=1 once it serves, WATCHDOG=1 within the watchdog period, STOPPING=1 on
SIGTERM. A datagram socket stands in for systemd's ($NOTIFY_SOCKET).
Usage: sd_notify.py CONTEGO SOURCE_DIR   (exit 77: built without libsystemd)"""
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time


def main():
    contego, src = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "notify")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        sock.bind(path)
        sock.settimeout(1.0)
        env = dict(os.environ, NOTIFY_SOCKET=path, WATCHDOG_USEC="400000")
        proc = subprocess.Popen(
            [contego, "monitor", "--policy", os.path.join(src, "policies/rover.policy"),
             "--virtual-bus", "1", "--socket", os.path.join(tmp, "monitor.sock"),
             "--audit", os.path.join(tmp, "audit.jsonl")],
            env=env, stderr=subprocess.PIPE, text=True)
        seen, deadline = [], time.time() + 30
        try:
            while time.time() < deadline and not ("READY=1" in seen and seen.count("WATCHDOG=1") >= 2):
                try:
                    seen += sock.recv(4096).decode().split("\n")
                except socket.timeout:
                    if proc.poll() is not None:
                        break
            proc.send_signal(signal.SIGTERM)
            end = time.time() + 10
            while time.time() < end and "STOPPING=1" not in seen:
                try:
                    seen += sock.recv(4096).decode().split("\n")
                except socket.timeout:
                    pass
        finally:
            proc.kill() if proc.poll() is None else None
            err = proc.communicate()[1]
        if not seen and "serving" in err:
            print("sd_notify: SKIP: contego built without libsystemd")
            return 77
        for want in ("READY=1", "WATCHDOG=1", "STOPPING=1"):
            if want not in seen:
                print(f"sd_notify: FAIL: no {want}; got {seen}\n{err}")
                return 1
        print(f"sd_notify: ok ({seen.count('WATCHDOG=1')} watchdog pings)")
        return 0


if __name__ == "__main__":
    sys.exit(main())
