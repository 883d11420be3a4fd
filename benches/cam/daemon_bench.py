#!/usr/bin/python3
"""Issue 41's daemon runs: a long cusp trochoid and the 1 000 000-move dense program streamed
through `interpd run` with the simulated plant, as a machine would run them.

    cargo build --release -p interpd -p sim-plant
    /usr/bin/python3 benches/cam/daemon_bench.py target/release [--only cusp_long dense1m]
        [--machine benches/cam/family_machine.toml]

Per program: the daemon (its own socket and iceoryx2 prefix, the programs directory a temporary
one) and `sim-plant` start; `program.load` checks the program, `motion.start` runs it to the
end. Printed: the load time, the motion time, the `underrun` events, `status.lookahead` at the
end (the look-ahead thread's longest step and the least motion queued), the daemon's peak
resident memory (VmHWM) and its warnings. The figures the issue asks: 0 underruns, longest
step <= 40 ms, peak memory <= 300 MB.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "examples", "python"))
import family  # noqa: E402
from jog_move_to import Interpd  # noqa: E402  (the control API's client, docs/control-api.md)

RUN_TIMEOUT_S = 1800


def cusp_long(path):
    """The family's cusp trochoid (seed 1) with a centre travel of 500 mm: about 300 000 moves
    of 2.3 um along some 690 mm of path, issue 41's 300 000-move cusp trochoid."""
    family.CUSP_CENTRE_MM = (500.0, 500.0)
    text, _, _, desc = family.make("cusp", 1, 0.0023)
    with open(path, "w") as f:
        f.write(text)
    return desc["moves"]


def dense1m(path):
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "gen-examples.py"), "--cam-dense", "0.002",
                    "1000000", path], check=True, capture_output=True)
    return 1_000_000


PROGRAMS = {"cusp_long": cusp_long, "dense1m": dense1m}


def peak_rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def run(bindir, name, machine, tmp):
    program = os.path.join(tmp, f"{name}.ngc")
    moves = PROGRAMS[name](program)
    sock = os.path.join(tmp, f"{name}.sock")
    prefix = f"interpd-bench/{name}{os.getpid()}"
    log = open(os.path.join(tmp, f"{name}.log"), "w")
    daemon = subprocess.Popen([os.path.join(bindir, "interpd"), "run", "--config", machine, "--socket", sock,
                               "--service-prefix", prefix], cwd=tmp, stdout=subprocess.DEVNULL, stderr=log)
    plant = None
    try:
        t0 = time.time()
        while not os.path.exists(sock):
            if daemon.poll() is not None or time.time() - t0 > 20:
                raise RuntimeError(f"interpd run did not start: {open(log.name).read()[-2000:]}")
            time.sleep(0.05)
        plant = subprocess.Popen([os.path.join(bindir, "sim-plant"), "--config", machine, "--service-prefix", prefix],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        c = Interpd(sock)
        c.call("subscribe")
        t0 = time.time()
        c.call("program.load", {"path": os.path.basename(program)})
        load_s = time.time() - t0
        c.call("motion.start")
        t0 = time.time()
        while True:
            st = c.call("status")
            if st["state"] in ("finished", "error", "idle") and time.time() - t0 > 1.0:
                break
            if time.time() - t0 > RUN_TIMEOUT_S:
                raise RuntimeError("the run did not finish")
            time.sleep(0.5)
        wall_s = time.time() - t0
        peak = peak_rss_mb(daemon.pid)
        underruns = [e for e in c.events if e.get("event") == "underrun"]
        return dict(program=name, moves=moves, state=st["state"], load_s=load_s, run_wall_s=wall_s,
                    underruns=len(underruns), lookahead=st.get("lookahead"), peak_rss_mb=peak,
                    last_error=st.get("last_error"))
    finally:
        if plant:
            plant.terminate()
            plant.wait()
        daemon.terminate()
        daemon.wait()
        log.close()
        warnings = [l for l in open(log.name) if "WARN" in l or "ERROR" in l]
        print(f"{name}: {len(warnings)} warnings in the daemon's log", *warnings[:10], sep="\n  ")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bindir", help="directory with interpd and sim-plant (release build)")
    ap.add_argument("--only", nargs="*", default=list(PROGRAMS))
    ap.add_argument("--machine", default=os.path.join(HERE, "family_machine.toml"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.only:
            r = run(os.path.abspath(a.bindir), name, os.path.abspath(a.machine), tmp)
            la = r["lookahead"] or {}
            print(f"{r['program']}: {r['moves']} moves, {r['state']}; loaded in {r['load_s']:.1f} s, ran {r['run_wall_s']:.1f} s; "
                  f"underruns {r['underruns']}; look-ahead longest step {la.get('step_max_ms')} ms, least queued "
                  f"{la.get('queue_min_s')} s; daemon peak memory {r['peak_rss_mb']:.1f} MB"
                  + (f"; last error {r['last_error']}" if r["last_error"] else ""))
            print(json.dumps(r))


if __name__ == "__main__":
    main()
