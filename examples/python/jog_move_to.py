#!/usr/bin/env python3
"""Jog and move-to over interpd's control socket (the standard library only).

Start the daemon first, e.g. `target/release/interpd run --no-shm --socket /tmp/x.sock`, then
`python3 examples/python/jog_move_to.py /tmp/x.sock`. It moves X and Y to a position
(time-synchronised), jogs X continuously and changes the jog while moving, stops the jog,
jogs Z by a distance, and prints the events and the final position.
"""

import json
import socket
import sys
import time


class Interpd:
    """A minimal JSON-RPC 2.0 client for the interpd control socket."""

    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.connect(path)
        self.file = self.sock.makefile("rb")
        self.next_id = 0
        self.events = []  # notifications that arrived while waiting for an answer

    def call(self, method, params=None):
        self.next_id += 1
        msg = {"jsonrpc": "2.0", "id": self.next_id, "method": method}
        if params is not None:
            msg["params"] = params
        self.sock.sendall(json.dumps(msg).encode() + b"\n")
        while True:
            reply = json.loads(self.file.readline())
            if "id" not in reply:
                self.events.append(reply["params"])
                continue
            if "error" in reply:
                raise RuntimeError(f'{reply["error"]["code"]}: {reply["error"]["message"]}')
            return reply["result"]

    def wait_event(self, name, timeout_s=30.0):
        until = time.monotonic() + timeout_s
        while time.monotonic() < until:
            for i, e in enumerate(self.events):
                if e["event"] == name:
                    return self.events.pop(i)
            self.call("status")  # reads any events queued meanwhile
            time.sleep(0.01)
        raise TimeoutError(f"no {name} event within {timeout_s} s")


def main():
    c = Interpd(sys.argv[1] if len(sys.argv) > 1 else "/tmp/x.sock")
    c.call("subscribe")
    r = c.call("motion.move_to", {"target": {"X": 40.0, "Y": -12.5}, "velocity_factor": 0.8})
    print(f"move_to: {r['duration_s']:.4f} s")
    print(c.wait_event("jog_done"))
    c.call("motion.jog", {"axes": {"X": 50.0}})  # mm/s, until jog_stop
    time.sleep(0.4)
    c.call("motion.jog", {"axes": {"X": -20.0, "Y": 10.0}})  # replans from the moving state
    time.sleep(0.4)
    c.call("motion.jog_stop")
    print(c.wait_event("jog_done"))
    c.call("motion.jog", {"axes": {"Z": 1.5}, "mode": "distance"})
    print(c.wait_event("jog_done"))
    st = c.call("status")
    print("state", st["state"], "position", [round(p, 4) for p in st["position"]])


if __name__ == "__main__":
    main()
