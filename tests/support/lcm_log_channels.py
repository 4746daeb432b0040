#!/usr/bin/env python3
"""Counts the events of each channel in an LCM log file (the format lcm-logger
writes), with no LCM library; an event lcm-logger has not finished writing at
the end of the file is not counted, so the log may be read while it grows.

    lcm_log_channels.py LOG [CHANNEL]

Prints one line "CHANNEL COUNT" per channel in the log, or, with CHANNEL,
the count of that channel alone (0 if it is not in the log)."""
import struct
import sys

SYNC = 0xEDA1DA01
HEADER = struct.Struct(">IqqII")  # sync, event number, timestamp, channel length, data length


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    counts = {}
    with open(sys.argv[1], "rb") as f:
        data = f.read()
    offset = 0
    while offset + HEADER.size <= len(data):
        sync, _, _, channel_length, data_length = HEADER.unpack_from(data, offset)
        if sync != SYNC:
            print(f"lcm_log_channels: error: no sync word at byte {offset} of {sys.argv[1]}", file=sys.stderr)
            return 1
        end = offset + HEADER.size + channel_length + data_length
        if end > len(data):
            break  # still being written
        channel = data[offset + HEADER.size:offset + HEADER.size + channel_length].decode("utf-8", "replace")
        counts[channel] = counts.get(channel, 0) + 1
        offset = end
    if len(sys.argv) == 3:
        print(counts.get(sys.argv[2], 0))
    else:
        for channel, count in sorted(counts.items()):
            print(channel, count)
    return 0


if __name__ == "__main__":
    sys.exit(main())
