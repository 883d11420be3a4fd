#!/usr/bin/env python3
"""CiA 402 drives on an independent CANopen implementation: the Python `canopen` package.

Each node is a `canopen.LocalNode` on the simulated drive's EDS: canopen's object dictionary,
SDO server, NMT slave, heartbeat producer and PDO maps. This script adds only what canopen's
LocalNode leaves to the application: the boot-up message and the communication reset of NMT,
0x6061 following 0x6060, the PDO configuration taken from the dictionary when the node is
started (as the master wrote it over SDO), and a minimal CiA 402 power state machine of an
ideal CSP drive (position actual = the target position taken on the last SYNC).

Usage: canopen_drive.py [--interface socketcan] CHANNEL EDS OUT NODE [NODE ...]

Until SIGTERM/SIGINT. OUT receives one line per node and SYNC while the node is in Operation
enabled in mode 8: "<sync number> <node> <target position>", the SYNC number counted from the
first SYNC this process saw (1). On exit a summary goes to stderr.
"""

import argparse
import signal
import struct
import sys
import threading

import can
import can.interfaces.socketcan  # noqa: F401  (loaded here, not lazily: the VM has no pip)
import canopen

SWITCH_ON_DISABLED, READY, SWITCHED_ON, ENABLED = "switch_on_disabled", "ready", "switched_on", "enabled"
STATUS = {SWITCH_ON_DISABLED: 0x0040, READY: 0x0021, SWITCHED_ON: 0x0023, ENABLED: 0x0027}
REMOTE, VOLTAGE, FOLLOWING = 0x0200, 0x0010, 0x1000


def next_state(state, cw):
    """CiA 402 transitions of a drive without faults (quick stop = disable voltage)."""
    if cw & 0x0002 == 0 or cw & 0x0006 == 0x0002:
        return SWITCH_ON_DISABLED
    if state == SWITCH_ON_DISABLED:
        return READY if cw & 0x0087 == 0x0006 else state
    if cw & 0x008F == 0x0006:
        return READY
    if cw & 0x008F == 0x0007:
        return SWITCHED_ON if state in (READY, SWITCHED_ON, ENABLED) else state
    if cw & 0x008F == 0x000F:
        return ENABLED
    return state


class Drive:
    def __init__(self, network, node_id, eds, out, lock):
        self.network = network
        self.id = node_id
        self.out = out
        self.lock = lock
        self.node = canopen.LocalNode(node_id, canopen.objectdictionary.import_od(eds, node_id=node_id))
        network.add_node(self.node)
        # After the LocalNode's own NMT handler (which only sets its state).
        network.subscribe(0, self.on_nmt)
        self.node.add_write_callback(self.on_write)
        self.state = SWITCH_ON_DISABLED
        self.cw = 0
        self.target = 0
        self.position = 0
        self.rpdo_seen = False
        self.subscribed = None
        self.followed = 0
        self.boot()

    def boot(self):
        # INITIALISING -> boot-up message -> PRE-OPERATIONAL (heartbeat per 0x1017: off).
        self.node.nmt.send_command(0x82)
        self.node.nmt.send_command(0x80)

    def on_write(self, index, subindex, od, data):
        if index == 0x6060:
            mode = struct.unpack("<b", data)[0]
            if mode not in (0, 8):
                raise canopen.SdoAbortedError(0x06090030)
            self.node.set_data(0x6061, 0, bytes(data))

    def on_nmt(self, can_id, data, timestamp):
        cmd, target = data[0], data[1]
        if target not in (0, self.id):
            return
        if cmd in (0x81, 0x82):
            # The communication area back to the EDS; reset node: everything.
            for index in list(self.node.data_store):
                if cmd == 0x81 or index < 0x2000:
                    del self.node.data_store[index]
            self.node.nmt.stop_heartbeat()
            self.unsubscribe()
            self.rpdo_seen = False
            self.boot()
        elif cmd == 0x01:
            # Started: the PDOs as the dictionary now holds them.
            self.unsubscribe()
            self.node.rpdo.read()
            self.node.tpdo.read()
            rpdo = self.node.rpdo[1]
            rpdo.add_callback(self.on_rpdo)
            self.subscribed = rpdo

    def unsubscribe(self):
        if self.subscribed is not None:
            try:
                self.network.unsubscribe(self.subscribed.cob_id, self.subscribed.on_message)
            except (KeyError, ValueError):
                pass
            self.subscribed.callbacks.clear()
            self.subscribed = None

    def on_rpdo(self, pdo):
        for var in pdo.map:
            if var.index == 0x6040:
                self.cw = var.raw
            elif var.index == 0x607A:
                self.target = var.raw
        self.rpdo_seen = True

    def on_sync(self, number):
        if self.node.nmt.state != "OPERATIONAL":
            return
        if self.rpdo_seen:
            self.state = next_state(self.state, self.cw)
        csp = struct.unpack("<b", self.node.sdo[0x6061].raw.to_bytes(1, "little", signed=True))[0] == 8
        following = self.state == ENABLED and csp
        if following:
            self.position = self.target
            self.followed += 1
            with self.lock:
                self.out.write(f"{number} {self.id} {self.target}\n")
        sw = STATUS[self.state] | REMOTE | (VOLTAGE if self.state != SWITCH_ON_DISABLED else 0)
        if following:
            sw |= FOLLOWING
        tpdo = self.node.tpdo[1]
        if not tpdo.enabled:
            return
        for var in tpdo.map:
            if var.index == 0x6041:
                var.raw = sw
            elif var.index == 0x6064:
                var.raw = self.position
        tpdo.transmit()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--interface", default="socketcan")
    ap.add_argument("channel")
    ap.add_argument("eds")
    ap.add_argument("out")
    ap.add_argument("nodes", type=int, nargs="+")
    args = ap.parse_args()
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
        signal.signal(signal.SIGINT, lambda *_: stop.set())
    network = canopen.Network()
    network.connect(interface=args.interface, channel=args.channel)
    lock = threading.Lock()
    with open(args.out, "w") as out:
        drives = [Drive(network, n, args.eds, out, lock) for n in args.nodes]
        syncs = [0]

        def on_sync(can_id, data, timestamp):
            syncs[0] += 1
            for d in drives:
                d.on_sync(syncs[0])

        network.subscribe(0x080, on_sync)
        print(f"canopen_drive: ready: nodes {args.nodes} on {args.channel} (canopen {canopen.__version__})",
              file=sys.stderr, flush=True)
        stop.wait()
        network.disconnect()
    print(f"canopen_drive: {syncs[0]} SYNC; " + ", ".join(
        f"node {d.id}: {d.state}, {d.followed} SYNCs following, mode {d.node.sdo[0x6061].raw}" for d in drives),
        file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()
