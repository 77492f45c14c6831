"""A firmware ELF in the virtual rig with its UART on a pseudo-terminal: what a user's USB serial
port is, for tools/sma console and upload. Shared by fil_test.py and e2e_flow.py.

    with PtyBoard(vrig, elf, duration=60, extra=["--eeprom", "ee.bin"]) as board:
        subprocess.run([..., "--port", board.port])
    # leaving the block sends SIGINT: vrig ends cleanly and saves its --eeprom file
"""
import re
import signal
import subprocess
import time


class PtyBoard:
    def __init__(self, vrig, elf, duration, speed=1.0, extra=(), timeout=15.0):
        self.proc = subprocess.Popen([vrig, elf, "--pty", "--speed", f"{speed:g}", "--duration", f"{duration:g}",
                                      "--quiet", *extra],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.port = None
        end = time.time() + timeout
        while self.port is None and time.time() < end:
            m = re.search(r"UART0 on (\S+)", self.proc.stderr.readline())
            if m:
                self.port = m.group(1)
        if self.port is None:
            self.close()
            raise RuntimeError("vrig --pty did not report its pseudo-terminal")
        time.sleep(0.5)  # the firmware's banner first: bytes sent before Serial.begin are lost

    def close(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
