#!/usr/bin/env python3
"""Records SDO frame sequences between two independent CANopen implementations' halves: the
`canopen` package's SDO client (RemoteNode) and its SDO server (LocalNode on the simulated
drive's EDS), over python-can's in-process virtual bus.

Usage: record_sdo.py EDS_FILE > canopen/tests/sdo_python_canopen.txt
(recorded with canopen 2.4.1 and python-can 4.6.1)

Output: one transfer per block; `# name` starts a block, then `C xxx#DATA` (client → server)
and `S xxx#DATA` (server → client) in bus order, `= result` the client's outcome.
"""

import sys
import time

import can
import canopen

NODE = 3


def network(bus):
    net = canopen.Network(bus)
    net.notifier = can.Notifier(bus, net.listeners, 0.01)
    return net


def main(path):
    od = canopen.objectdictionary.import_od(path, node_id=NODE)
    spy = can.Bus(interface="virtual", channel="sdo")
    server = network(can.Bus(interface="virtual", channel="sdo"))
    client = network(can.Bus(interface="virtual", channel="sdo"))
    server.create_node(NODE, od)
    remote = client.add_node(NODE, od)
    remote.sdo.RESPONSE_TIMEOUT = 1.0

    def block(name, action):
        print(f"# {name}")
        try:
            result = action()
            result = "ok" if result is None else "ok " + result.hex().upper()
        except canopen.SdoAbortedError as e:
            result = f"abort 0x{e.code:08X}"
        time.sleep(0.1)
        while (m := spy.recv(0.05)) is not None:
            if m.arbitration_id not in (0x580 + NODE, 0x600 + NODE):
                continue  # the LocalNode's heartbeat, which it starts once 0x1017 is written
            side = "C" if m.arbitration_id == 0x600 + NODE else "S"
            print(f"{side} {m.arbitration_id:03X}#{bytes(m.data).hex().upper()}")
        print(f"= {result}")

    block("expedited upload of the vendor-ID 0x1018:1", lambda: remote.sdo.upload(0x1018, 1))
    block("segmented upload of the device name 0x1008", lambda: remote.sdo.upload(0x1008, 0))
    block("expedited download of the heartbeat time 0x1017 = 100 ms",
          lambda: remote.sdo.download(0x1017, 0, (100).to_bytes(2, "little")))
    block("segmented download of 0x1017 = 250 ms",
          lambda: remote.sdo.download(0x1017, 0, (250).to_bytes(2, "little"), force_segment=True))
    block("upload of 0x1017 after the writes", lambda: remote.sdo.upload(0x1017, 0))
    block("upload of an object that does not exist 0x2000", lambda: remote.sdo.upload(0x2000, 0))
    block("download to a sub-index that does not exist 0x1018:9",
          lambda: remote.sdo.download(0x1018, 9, b"\x01\x00\x00\x00"))
    block("expedited download of modes of operation 0x6060 = 8", lambda: remote.sdo.download(0x6060, 0, b"\x08"))
    for net in (client, server):
        net.disconnect()
    spy.shutdown()


if __name__ == "__main__":
    main(sys.argv[1])
