#!/usr/bin/env python3
"""Drives `clm scope` in a pseudo-terminal against a running clm-servod (or a
log) as an engineer would, and checks what it shows (tests/tools/scope_live_test.sh).

    scope_pty_check.py CLM URL WORK live   -- a move's following error: single trigger on program_running
    scope_pty_check.py CLM URL WORK log LOG -- the same window from the recorded log of that move

live: starts the scope, waits until it is armed (the part before a trigger
recorded), commands `clm ctl move-to`, waits for the capture (at most 10 s
after the scope started), exports it with the key e and quits with q. log:
replays LOG at 4x the same way, and the live window starts no later than the
log's unless the live screen said states were lost. Then, both: the CSV
window has the trigger where program_running goes 0 -> 1, the pre-trigger
fraction and the window's length, inward by at most the states' longest gap
and those said lost; every state of the CSV's e_m
lights its dot on the screen under the screen's own map (the strip's span
from the values, the window's start and length); the PNG was written.
Prints the figures; an assert names the check that failed.
"""
import csv
import math
import os
import pty
import re
import select
import struct
import subprocess
import sys
import time
import fcntl
import termios

COLUMNS, ROWS = 110, 34
WINDOW_S, PRE = 1.0, 0.2
LABEL_CELLS = 14


def start_scope(clm, source_args, work, name):
    args = [clm, "scope", *source_args, "--channels", "e_m,r_m", "--trigger", "program_running", "--level", "0.5",
            "--mode", "single", "--window-s", str(WINDOW_S), "--pre-trigger", str(PRE), "--out", work, "--name", name,
            "--no-colour"]
    pid, fd = pty.fork()
    if pid == 0:
        os.execv(clm, args)
    fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", ROWS, COLUMNS, 0, 0))
    os.kill(pid, 28)  # SIGWINCH: the size set after the start
    return pid, fd


class Screen:
    def __init__(self, pid, fd, keep_path):
        self.pid, self.fd, self.buffer, self.keep_path = pid, fd, b"", keep_path
        self.closed = None  # why the terminal stopped giving output

    def pump(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ready, _, _ = select.select([self.fd], [], [], 0.05)
            if ready:
                try:
                    self.buffer += os.read(self.fd, 1 << 16)
                except OSError as error:
                    self.closed = str(error)
                    return

    def frames(self):
        """Complete frames (those followed by another) as lists of plain lines."""
        parts = self.buffer.split(b"\x1b[H")[1:-1]
        out = []
        for part in parts:
            text = re.sub(r"\x1b\[[0-9;?]*[a-zA-Z]", "", part.decode("utf-8", "replace")).replace("\r", "")
            out.append(text.split("\n"))
        return out

    def wait_for(self, text, seconds, what):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.pump(0.1)
            for frame in reversed(self.frames()):
                if any(text in line for line in frame):
                    return frame
        tail = self.frames()[-1:] or [["(no frame)"]]
        with open(self.keep_path, "wb") as f:
            f.write(self.buffer)
        ended, status = os.waitpid(self.pid, os.WNOHANG)
        state = f"clm scope ended with status {status}" if ended else "clm scope still running"
        raise AssertionError(f"{what}: no '{text}' on the screen within {seconds} s ({len(self.buffer)} bytes shown, "
                             f"kept in {self.keep_path}; terminal closed: {self.closed}; {state}); the last frame:\n" +
                             "\n".join(tail[0]))


def dots_of(lines):
    """Lit braille dots of the plot area of strip `lines`: {(x, y)}."""
    bits = [[0x01, 0x02, 0x04, 0x40], [0x08, 0x10, 0x20, 0x80]]
    lit = set()
    for row, line in enumerate(lines):
        for cell, char in enumerate(line[LABEL_CELLS + 1:]):
            code = ord(char) - 0x2800
            assert 0 <= code <= 0xFF, f"strip row {row}: '{char}' is not a braille cell"
            for dx in range(2):
                for dy in range(4):
                    if code & bits[dx][dy]:
                        lit.add((2 * cell + dx, 4 * row + dy))
    return lit


def lost_said(frame):
    """The states the screen says its window lost in transit."""
    said = re.search(r"(\d+) missing \(lost in transit\)", "\n".join(frame))
    return int(said.group(1)) if said else 0


def check(screen_frame, csv_path, png_path, label):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows, f"{label}: {csv_path} has no rows"
    t = [float(r["t_minus_trigger_s"]) for r in rows]
    running = [float(r["program_running"]) for r in rows]
    e = [float(r["e_m"]) for r in rows]
    before = [p for tt, p in zip(t, running) if tt < 0]
    after = [p for tt, p in zip(t, running) if tt >= 0]
    assert before and all(p == 0.0 for p in before), f"{label}: program_running not 0 before the trigger: {before[-5:]}"
    assert after and after[0] == 1.0, f"{label}: program_running not 1 right after the trigger: {after[:5]}"
    gaps = [b - a for a, b in zip(t, t[1:])]
    period = min(gaps)
    # The window's ends may lie inward of their nominal times, never outward:
    # by the states lost in transit (UDP on a loaded host; the screen names
    # them) and by the deadlines a loaded host's daemon skips (no state at
    # all), as long as the longest gap between the window's states.
    lost = lost_said(screen_frame)
    slack = max(gaps) + (1 + lost) * period + 1e-9
    assert -PRE * WINDOW_S - 1e-9 <= t[0] <= -PRE * WINDOW_S + slack, \
        f"{label}: window starts at {t[0]} s, not -{PRE * WINDOW_S} s (slack {slack:.4f} s, {lost} states said lost)"
    assert (1 - PRE) * WINDOW_S - slack <= t[-1] <= (1 - PRE) * WINDOW_S + 1e-9, \
        f"{label}: window ends at {t[-1]} s, not {(1 - PRE) * WINDOW_S} s (slack {slack:.4f} s, {lost} states said lost)"
    assert max(abs(v) for v in e) > 0.0, f"{label}: e_m is zero throughout"
    assert os.path.getsize(png_path) > 10000, f"{label}: {png_path} is {os.path.getsize(png_path)} bytes"
    # The e_m strip: from the line labelled e_m to the one labelled r_m.
    starts = [k for k, line in enumerate(screen_frame) if line.startswith("e_m ")]
    ends = [k for k, line in enumerate(screen_frame) if line.startswith("r_m ")]
    assert starts and ends, f"{label}: no e_m or r_m strip on the screen"
    strip = screen_frame[starts[0]:ends[0]]
    lit = dots_of(strip)
    width, height = 2 * (COLUMNS - LABEL_CELLS - 1), 4 * len(strip)
    lo, hi = min(e), max(e)
    bottom, top = lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)
    shown_top = float(strip[1][:LABEL_CELLS].split()[1])
    assert abs(shown_top - top) <= 1e-3 * abs(top) + 1e-15, f"{label}: the strip says max {shown_top}, the values {top}"
    start = t[0] - (t[0] + PRE * WINDOW_S)  # the window's start, relative to the trigger: -PRE * WINDOW_S
    missing = []
    for tt, v in zip(t, e):
        x = math.floor((tt - start) / WINDOW_S * width)
        y = min(max(round((top - v) / (top - bottom) * (height - 1)), 0), height - 1)
        if 0 <= x < width and (x, y) not in lit:
            missing.append((tt, v, x, y))
    assert not missing, f"{label}: {len(missing)} of {len(t)} states of e_m not lit on the screen, e.g. {missing[:3]}"
    print(f"{label}: {len(t)} states ({lost} said lost, longest gap {max(gaps) * 1e3:.1f} ms) from {t[0]:.4f} to {t[-1]:.4f} s about the trigger; e_m within "
          f"[{lo:.3g}, {hi:.3g}] m, every state lit on the {len(strip)}-row strip; {os.path.basename(png_path)} written")


def run(clm, source_args, work, name, url=None):
    started = time.monotonic()
    pid, fd = start_scope(clm, source_args, work, name)
    screen = Screen(pid, fd, os.path.join(work, name + "-screen.bin"))
    if url is not None:
        # Armed: the part before a trigger is recorded, so the move's start counts.
        screen.wait_for("[armed]", 10, f"{name}: the scope armed")
        move = subprocess.run([clm, "ctl", "--lcm-url", url, "move-to", "--target-m", "0.02"], capture_output=True,
                              text=True, timeout=30)
        assert move.returncode == 0, f"{name}: clm ctl move-to exited {move.returncode}: {move.stderr.strip()}"
    # Live, the capture is to show within 10 s of the start. A log has no
    # such target: a loaded host has been seen to hold a new terminal's first
    # output back for over 10 s.
    frame = screen.wait_for("capture 1: trigger", 10 if url is not None else 60, f"{name}: the capture")
    shown_s = time.monotonic() - started
    assert url is None or shown_s <= 10.0, f"{name}: the capture was shown {shown_s:.1f} s after the scope started, more than 10 s"
    os.write(fd, b"e")
    # The export draws the PNG with matplotlib: seconds, tens of them on a loaded host.
    screen.wait_for("exported capture 1", 60, f"{name}: the export")
    os.write(fd, b"q")
    screen.pump(0.5)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, f"{name}: clm scope ended with status {status}"
    print(f"{name}: capture shown {shown_s:.1f} s after the scope started")
    check(frame, os.path.join(work, name + "-1.csv"), os.path.join(work, name + "-1.png"), name)
    return frame


def first_state_s(csv_path):
    with open(csv_path, newline="") as f:
        return float(next(csv.DictReader(f))["t_minus_trigger_s"])


def compare_with_log(work, live_frame):
    """The live capture starts no later than the same capture from the log
    recorded beside it (which has every state the logger got), unless the
    live scope said it lost states."""
    live_s, log_s = first_state_s(os.path.join(work, "live-1.csv")), first_state_s(os.path.join(work, "log-1.csv"))
    assert lost_said(live_frame) > 0 or live_s <= log_s + 1e-9, \
        f"live: the window's first state at {live_s} s, after the log's at {log_s} s, with no state said lost"
    print(f"live against log: first states at {live_s:.4f} and {log_s:.4f} s about the trigger")


def main():
    clm, url, work, mode = sys.argv[1:5]
    try:
        if mode == "live":
            frame = run(clm, ["--lcm-url", url], work, "live", url=url)
            with open(os.path.join(work, "live-frame.txt"), "w") as f:
                f.write("\n".join(frame))
        else:
            run(clm, ["--log", sys.argv[5], "--speed", "4"], work, "log")
            with open(os.path.join(work, "live-frame.txt")) as f:
                compare_with_log(work, f.read().split("\n"))
    except AssertionError as error:
        print(f"FAIL: {error}")
        sys.exit(1)


if __name__ == "__main__":
    main()
