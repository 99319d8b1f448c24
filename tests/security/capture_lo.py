#!/usr/bin/env python3
"""Captures every frame on a network interface with an AF_PACKET socket (no tcpdump needed).

    capture_lo.py <interface> <output file> <max seconds>

Writes each frame as a 4-byte little-endian length and the frame's bytes, until SIGTERM /
SIGINT or <max seconds>. Prints "ready" once the socket listens, and at the end the frames,
bytes and the kernel's count of frames it dropped because this reader was too slow.
"""
import signal
import socket
import struct
import sys
import time

ETH_P_ALL = 0x0003
SOL_PACKET = 263
PACKET_STATISTICS = 6


def main() -> int:
    """Capture until stopped; return the exit status."""
    interface, path, limit_s = sys.argv[1], sys.argv[2], float(sys.argv[3])
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32 << 20)
    sock.bind((interface, 0))
    sock.settimeout(0.1)
    frames = total = 0
    end = time.monotonic() + limit_s
    with open(path, "wb") as out:
        print("ready", flush=True)
        while not stop and time.monotonic() < end:
            try:
                data = sock.recv(1 << 18)
            except socket.timeout:
                continue
            out.write(struct.pack("<I", len(data)))
            out.write(data)
            frames += 1
            total += len(data)
    _, dropped = struct.unpack("II", sock.getsockopt(SOL_PACKET, PACKET_STATISTICS, 8))
    print(f"captured {frames} frames, {total} bytes, {dropped} dropped by the kernel", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
