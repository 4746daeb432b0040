#!/usr/bin/env python3
"""Sends raw bytes as one LCM message over UDP multicast, with no LCM library:
the way any process on the host can reach clm-servod. The bytes are sent as
they are, hash and lengths included, so a test can send what lcm-gen's
encoder never would.

    send_lcm_datagram.py URL CHANNEL FILE [--skip N] [--count K]
        [--set-int64 OFFSET=VALUE ...] [--utime-now OFFSET]
        [--random-tail N] [--pause-every M] [--sign]

URL is udpm://GROUP:PORT[?...]; FILE's bytes from offset N (default 0) are
the message; it is sent K times (default 1) with increasing LCM sequence
numbers. --set-int64 writes VALUE (big-endian, as LCM encodes int64_t) at
OFFSET of the message (after --skip); --utime-now writes the wall-clock time
in microseconds there. --random-tail N: every message sent is the first N
bytes followed by 0..400 random bytes (N = 0: all random, 1..400 bytes).
--pause-every M: a 5 ms pause after every M messages, so a flood is not lost
in a socket buffer. --sign: after the patches, the message's last 32 bytes
(its `mac` field) become the HMAC-SHA256 of the channel, a NUL and the rest,
keyed with the file $CLM_SERVO_KEY_FILE names (daemon/telemetry/message_mac.hpp):
what a holder of the operators' key sends."""
import argparse
import os
import random
import socket
import struct
import sys
import time
from urllib.parse import urlparse

from lcm_wire import signed

MAGIC_SHORT = 0x4C433032  # "LC02", LCM's short-message header


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url")
    parser.add_argument("channel")
    parser.add_argument("file")
    parser.add_argument("--skip", type=int, default=0)
    parser.add_argument("--count", type=int, default=1)
    parser.add_argument("--set-int64", action="append", default=[], metavar="OFFSET=VALUE")
    parser.add_argument("--utime-now", type=int, metavar="OFFSET")
    parser.add_argument("--random-tail", type=int, metavar="N")
    parser.add_argument("--pause-every", type=int, default=0, metavar="M")
    parser.add_argument("--sign", action="store_true")
    args = parser.parse_args()
    url = urlparse(args.url)
    if url.scheme != "udpm" or not url.hostname or not url.port:
        print(f"send_lcm_datagram: error: not a udpm://GROUP:PORT URL: {args.url}", file=sys.stderr)
        return 2
    with open(args.file, "rb") as f:
        payload = bytearray(f.read()[args.skip:])
    patches = [(int(o), int(v)) for o, v in (item.split("=", 1) for item in args.set_int64)]
    if args.utime_now is not None:
        patches.append((args.utime_now, int(time.time() * 1e6)))
    for offset, value in patches:
        if offset < 0 or offset + 8 > len(payload):
            print(f"send_lcm_datagram: error: offset {offset} outside the {len(payload)}-byte message", file=sys.stderr)
            return 2
        payload[offset:offset + 8] = struct.pack(">q", value)
    if args.sign:
        with open(os.environ["CLM_SERVO_KEY_FILE"], "rb") as f:
            key = f.read()
        payload = bytearray(signed(key, args.channel, payload))
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
    for sequence in range(args.count):
        message = bytes(payload)
        if args.random_tail is not None:
            tail = random.randint(0 if args.random_tail > 0 else 1, 400)
            message = message[:args.random_tail] + os.urandom(tail)
        packet = struct.pack(">II", MAGIC_SHORT, sequence) + args.channel.encode() + b"\0" + message
        sock.sendto(packet, (url.hostname, url.port))
        if args.pause_every > 0 and (sequence + 1) % args.pause_every == 0:
            time.sleep(0.005)
    return 0


if __name__ == "__main__":
    sys.exit(main())
