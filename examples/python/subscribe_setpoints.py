#!/usr/bin/env python3
"""Reads interpd's setpoint stream from shared memory with the iceoryx2 package from PyPI.

    python3 -m pip install iceoryx2==0.10.0
    python3 examples/python/subscribe_setpoints.py [--prefix interpd] [--samples N]
                                                   [--timeout S] [--until-finished]

Subscribes to the iceoryx2 publish-subscribe service `<prefix>/setpoints` (default
`interpd/setpoints`) and prints one line per setpoint:

    cycle time_ns flags s_mm v_mm_s pos[0] ... pos[n_axes-1]

Floats are printed with repr(), the shortest text that reads back as the same double, so the
output can be compared exactly with what a Rust subscriber receives. The first line on stdout
is `# subscribed to <service>` once the subscriber exists (nothing published before it is
seen, apart from the one latest sample iceoryx2 keeps as history). Exits 0 after --samples
setpoints (default 100), at the first setpoint flagged FINISHED (--until-finished) or when
--timeout seconds have passed (exit 0 if anything was received by then, else 1). With
--until-finished a sample count applies only when --samples is given: the daemon publishes a
setpoint every cycle, also while it stands before a program starts, so a default count would
end the reading before the program does.

The payload is `interpd_protocol::shm::Setpoints` (protocol/src/shm.rs): #[repr(C)], 288 bytes,
alignment 8, no padding, iceoryx2 type name "interpd::Setpoints". iceoryx2 connects a
subscriber only if type name, size and alignment all match the publisher's, so a change on one
side shows up as an open error here rather than as garbage values.
"""

import argparse
import ctypes
import sys
import time

import iceoryx2 as iox2

# protocol/src/lib.rs MAX_AXES: length of the per-axis arrays.
MAX_AXES = 9
# protocol/src/shm.rs PAYLOAD_VERSION.
PAYLOAD_VERSION = 1
# protocol/src/shm.rs `qos`: both sides ask for the same service settings, whichever starts first.
HISTORY_SIZE = 1
SUBSCRIBER_BUFFER_SIZE = 64
MAX_PUBLISHERS = 2
MAX_SUBSCRIBERS = 8
# protocol/src/shm.rs `flags`.
FLAG_FINISHED = 1 << 3
# Setpoints read without --samples and without --until-finished (0.4 s at a 4 ms cycle).
DEFAULT_SAMPLES = 100
# How long to sleep when nothing is queued, s (a 4 ms cycle; the queue holds 64 cycles).
POLL_S = 0.001


class Setpoints(ctypes.Structure):
    """One setpoint per interpolation cycle; field for field `interpd_protocol::shm::Setpoints`."""

    _fields_ = [
        ("version", ctypes.c_uint32),
        ("n_axes", ctypes.c_uint32),
        ("cycle", ctypes.c_uint64),
        ("time_ns", ctypes.c_uint64),  # CLOCK_MONOTONIC: the cycle's deadline
        ("publish_ns", ctypes.c_uint64),  # CLOCK_MONOTONIC: when it was published
        ("flags", ctypes.c_uint32),
        ("line", ctypes.c_uint32),
        ("s_mm", ctypes.c_double),
        ("v_mm_s", ctypes.c_double),
        ("a_mm_s2", ctypes.c_double),
        ("feed_override", ctypes.c_double),
        ("pos", ctypes.c_double * MAX_AXES),  # mm or deg, axis order of the machine file
        ("vel", ctypes.c_double * MAX_AXES),
        ("acc", ctypes.c_double * MAX_AXES),
    ]

    @staticmethod
    def type_name() -> str:
        """The name the Rust publisher registers (`#[type_name("interpd::Setpoints")]`)."""
        return "interpd::Setpoints"


assert ctypes.sizeof(Setpoints) == 288 and ctypes.alignment(Setpoints) == 8


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--prefix", default="interpd", help="iceoryx2 service prefix (default: interpd)")
    p.add_argument(
        "--samples",
        type=int,
        help=f"exit after this many setpoints (default {DEFAULT_SAMPLES}; with --until-finished, no limit unless given)",
    )
    p.add_argument("--timeout", type=float, default=10.0, help="give up after this many seconds (default 10)")
    p.add_argument(
        "--until-finished",
        action="store_true",
        help="exit at the first setpoint flagged FINISHED (no sample limit unless --samples is given)",
    )
    args = p.parse_args()
    if (args.samples is not None and args.samples < 1) or not args.timeout > 0:
        p.error("--samples must be ≥ 1 and --timeout > 0")
    if args.samples is None and not args.until_finished:
        args.samples = DEFAULT_SAMPLES
    return args


def open_subscriber(prefix: str):
    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    node = iox2.NodeBuilder.new().create(iox2.ServiceType.Ipc)
    service = (
        node.service_builder(iox2.ServiceName.new(f"{prefix}/setpoints"))
        .publish_subscribe(Setpoints)
        .history_size(HISTORY_SIZE)
        .subscriber_max_buffer_size(SUBSCRIBER_BUFFER_SIZE)
        .max_publishers(MAX_PUBLISHERS)
        .max_subscribers(MAX_SUBSCRIBERS)
        .open_or_create()
    )
    return node, service.subscriber_builder().buffer_size(SUBSCRIBER_BUFFER_SIZE).create()


def line(sp: Setpoints) -> str:
    pos = " ".join(repr(sp.pos[k]) for k in range(sp.n_axes))
    return f"{sp.cycle} {sp.time_ns} {sp.flags} {sp.s_mm!r} {sp.v_mm_s!r} {pos}"


def main() -> int:
    args = parse_args()
    try:
        node, subscriber = open_subscriber(args.prefix)
    except Exception as e:  # iceoryx2 raises its own exception types per failure
        print(f"subscribe_setpoints: cannot subscribe to {args.prefix}/setpoints: {e!r}", file=sys.stderr)
        return 1
    print(f"# subscribed to {args.prefix}/setpoints", flush=True)
    received = 0
    deadline = time.monotonic() + args.timeout
    while time.monotonic() < deadline:
        sample = subscriber.receive()
        if sample is None:
            time.sleep(POLL_S)
            continue
        sp = Setpoints.from_buffer_copy(sample.payload().contents)
        sample.delete()  # hand the chunk back to the publisher at once
        if sp.version != PAYLOAD_VERSION or sp.n_axes > MAX_AXES:
            print(f"subscribe_setpoints: payload version {sp.version}, {sp.n_axes} axes: not understood", file=sys.stderr)
            return 1
        print(line(sp), flush=False)
        received += 1
        counted = args.samples is not None and received >= args.samples
        if counted or (args.until_finished and sp.flags & FLAG_FINISHED):
            break
    sys.stdout.flush()
    del subscriber, node
    if received == 0:
        print(f"subscribe_setpoints: nothing received on {args.prefix}/setpoints in {args.timeout} s", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
