#!/usr/bin/env python3
"""Floods a clm-servod's LCM group the way any process on the host can, with
no LCM library, and measures how long its stop takes to be acked meanwhile
(docs/reliability.md, "Command channel under flood").

    flood_lcm.py flood URL --axis A --session S --kind KIND --rate R --duration-s D [--sign]
    flood_lcm.py stop-latency URL --axis A --session S --count N [--client C]

flood: sends R datagrams a second for D seconds, in bursts every 5 ms:
  reads         GET_PARAMETER control.bandwidth_hz from made-up client ids
                (1000 of them, in turn), this session, a fresh utime;
  unauthorised  ENABLE and MOVE_TO from made-up client ids (none holds control);
  mixed         half reads, half unauthorised;
  stops-other-axis  STOP, QUICK_STOP and DISABLE in turn for the axis
                "other-axis" (not --axis), unsigned: each refused as for
                another axis, and logged (rate-limited) by the daemon;
  fragments     1 kB LCM fragments (LC03) whose header claims 2^28 - 1 bytes.
--sign: the commands carry the mac of the key $CLM_SERVO_KEY_FILE names (a
flood from a holder of the operators' key, which the command authority must
still withstand); without it they are refused as unauthenticated.
Prints one line: what was sent and at what rate.

stop-latency: sends N commands in turn STOP, QUICK_STOP, DISABLE (client C,
default 777001, sequences from the wall clock), each after the previous
one's ack, and times each from the send to its ack (CLM_SERVO_COMMAND_ACK
with the same client and sequence). Prints one line per command and one
`median_ms M max_ms X acked K/N` line; exit 1 when a command is refused or
unacked within 2 s."""
import argparse
import os
import socket
import statistics
import struct
import sys
import time
from urllib.parse import urlparse

from lcm_wire import MAGIC_FRAGMENT, MAGIC_SHORT, corpus_hash, lcm_string, short_datagram, signed

ENABLE, DISABLE, MOVE_TO, STOP, QUICK_STOP, GET_PARAMETER = 1, 2, 4, 10, 14, 16


def command(hash_bytes, axis, session, client, sequence, kind, parameter="", target_m=0.0):
    """servo_command_t, field by field as lcmtypes/servo_command_t.lcm orders them; its mac
    is zeros (anyone can send it: only a stop, quick stop or disable needs no key)."""
    return (hash_bytes + struct.pack(">qq", int(time.time() * 1e6), sequence) + lcm_string(axis) +
            struct.pack(">qqb", session, client, kind) +
            struct.pack(">dddd", target_m, 0.1, 1.0, 1000.0) + lcm_string("") + struct.pack(">bbd", 0, 0, 0.0) +
            lcm_string("") + lcm_string(parameter) + struct.pack(">d", 0.0) + bytes(32))


def fragment_datagram(sequence):
    claimed = (1 << 28) - 1
    header = struct.pack(">IIIIHH", MAGIC_FRAGMENT, sequence & 0xFFFFFFFF, claimed, 0, 0, 4097)
    return header + b"CLM_SERVO_COMMAND\0" + os.urandom(1000)


def address(url_text):
    url = urlparse(url_text)
    if url.scheme != "udpm" or not url.hostname or not url.port:
        sys.exit(f"flood_lcm: error: not a udpm://GROUP:PORT URL: {url_text}")
    return url.hostname, url.port


def sender():
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
    return sock


def flood(args):
    target = address(args.url)
    sock = sender()
    command_hash = corpus_hash("command-move-to")
    key = None
    if args.sign:
        with open(os.environ["CLM_SERVO_KEY_FILE"], "rb") as f:
            key = f.read()
    sent = 0
    start = time.monotonic()
    end = start + args.duration_s
    burst_s = 0.005
    next_burst = start
    while time.monotonic() < end:
        due = int((time.monotonic() - start) * args.rate) - sent
        for _ in range(max(due, 0)):
            client = 500000 + sent % 1000
            kind = args.kind
            if kind == "mixed":
                kind = "reads" if sent % 2 == 0 else "unauthorised"
            if kind == "fragments":
                packet = fragment_datagram(sent)
            else:
                if kind == "stops-other-axis":
                    payload = command(command_hash, "other-axis", args.session, client, sent + 1,
                                      (STOP, QUICK_STOP, DISABLE)[sent % 3])
                elif kind == "reads":
                    payload = command(command_hash, args.axis, args.session, client, sent + 1,
                                      GET_PARAMETER, parameter="control.bandwidth_hz")
                else:
                    payload = command(command_hash, args.axis, args.session, client, sent + 1,
                                      ENABLE if sent % 2 else MOVE_TO, target_m=0.01)
                if key is not None:
                    payload = signed(key, "CLM_SERVO_COMMAND", payload)
                packet = short_datagram(sent, "CLM_SERVO_COMMAND", payload)
            try:
                sock.sendto(packet, target)
            except OSError:
                pass  # a full socket buffer: the flood goes on
            sent += 1
        next_burst += burst_s
        pause = next_burst - time.monotonic()
        if pause > 0:
            time.sleep(pause)
    elapsed = time.monotonic() - start
    print(f"flood {args.kind}: {sent} datagrams in {elapsed:.2f} s ({sent / elapsed:.0f}/s)")
    return 0


def parse_ack(payload):
    """(sequence, client, accepted, text) of a servo_command_ack_t, or None."""
    try:
        pos = 8
        _utime, sequence = struct.unpack_from(">qq", payload, pos)
        pos += 16
        (length,) = struct.unpack_from(">i", payload, pos)
        pos += 4 + length
        _session, client, accepted = struct.unpack_from(">qqb", payload, pos)
        pos += 17
        (length,) = struct.unpack_from(">i", payload, pos)
        text = payload[pos + 4:pos + 4 + length - 1].decode(errors="replace")
        return sequence, client, bool(accepted), text
    except struct.error:
        return None


def stop_latency(args):
    group, port = address(args.url)
    listener = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    listener.bind(("", port))
    listener.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                        socket.inet_aton(group) + socket.inet_aton("0.0.0.0"))
    sock = sender()
    command_hash = corpus_hash("command-move-to")
    kinds = [(STOP, "stop"), (QUICK_STOP, "quick_stop"), (DISABLE, "disable")]
    latencies = []
    failures = 0
    for k in range(args.count):
        kind, name = kinds[k % len(kinds)]
        sequence = time.time_ns()
        packet = short_datagram(k, "CLM_SERVO_COMMAND",
                                command(command_hash, args.axis, args.session, args.client, sequence, kind))
        sent_at = time.monotonic()
        sock.sendto(packet, (group, port))
        deadline = sent_at + 2.0
        answer = None
        while answer is None and time.monotonic() < deadline:
            listener.settimeout(max(deadline - time.monotonic(), 0.001))
            try:
                data = listener.recv(70000)
            except socket.timeout:
                break
            if len(data) < 8 or struct.unpack_from(">I", data)[0] != MAGIC_SHORT:
                continue
            nul = data.find(b"\0", 8)
            if nul < 0 or data[8:nul] != b"CLM_SERVO_COMMAND_ACK":
                continue
            ack = parse_ack(data[nul + 1:])
            if ack and ack[0] == sequence and ack[1] == args.client:
                answer = ack
        if answer is None:
            print(f"{name}: no ack within 2 s")
            failures += 1
            continue
        latency_ms = (time.monotonic() - sent_at) * 1e3
        print(f"{name}: {'accepted' if answer[2] else 'REFUSED'} '{answer[3]}' after {latency_ms:.1f} ms")
        if not answer[2]:
            failures += 1
            continue
        latencies.append(latency_ms)
        time.sleep(0.02)
    if latencies:
        print(f"median_ms {statistics.median(latencies):.1f} max_ms {max(latencies):.1f} "
              f"acked {len(latencies)}/{args.count}")
    else:
        print(f"median_ms nan max_ms nan acked 0/{args.count}")
    return 1 if failures else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="mode", required=True)
    f = sub.add_parser("flood")
    f.add_argument("url")
    f.add_argument("--axis", default="axis0")
    f.add_argument("--session", type=int, default=0)
    f.add_argument("--kind", choices=["reads", "unauthorised", "mixed", "fragments", "stops-other-axis"], required=True)
    f.add_argument("--rate", type=float, required=True)
    f.add_argument("--duration-s", type=float, required=True)
    f.add_argument("--sign", action="store_true",
                   help="sign the commands with the key $CLM_SERVO_KEY_FILE names: a flood from a holder of the key")
    s = sub.add_parser("stop-latency")
    s.add_argument("url")
    s.add_argument("--axis", default="axis0")
    s.add_argument("--session", type=int, default=0)
    s.add_argument("--count", type=int, default=30)
    s.add_argument("--client", type=int, default=777001)
    args = parser.parse_args()
    return flood(args) if args.mode == "flood" else stop_latency(args)


if __name__ == "__main__":
    sys.exit(main())
