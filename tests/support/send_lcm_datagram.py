#!/usr/bin/env python3
"""Sends raw bytes as one LCM message over UDP multicast, with no LCM library:
the way any process on the host can reach clm-servod. The bytes are sent as
they are, hash and lengths included, so a test can send what lcm-gen's
encoder never would.

    send_lcm_datagram.py URL CHANNEL FILE [--skip N] [--count K]

URL is udpm://GROUP:PORT[?...]; FILE's bytes from offset N (default 0) are
the message; it is sent K times (default 1) with increasing LCM sequence
numbers."""
import argparse
import socket
import struct
import sys
from urllib.parse import urlparse

MAGIC_SHORT = 0x4C433032  # "LC02", LCM's short-message header


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url")
    parser.add_argument("channel")
    parser.add_argument("file")
    parser.add_argument("--skip", type=int, default=0)
    parser.add_argument("--count", type=int, default=1)
    args = parser.parse_args()
    url = urlparse(args.url)
    if url.scheme != "udpm" or not url.hostname or not url.port:
        print(f"send_lcm_datagram: error: not a udpm://GROUP:PORT URL: {args.url}", file=sys.stderr)
        return 2
    with open(args.file, "rb") as f:
        payload = f.read()[args.skip:]
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
    for sequence in range(args.count):
        packet = struct.pack(">II", MAGIC_SHORT, sequence) + args.channel.encode() + b"\0" + payload
        sock.sendto(packet, (url.hostname, url.port))
    return 0


if __name__ == "__main__":
    sys.exit(main())
