#!/usr/bin/env python3
"""Copies this Python interpreter with the `canopen` and `can` packages into an initramfs
staging directory, for the CAN tests' VM (scripts/vcan-vm.sh): the interpreter, the shared
libraries it and its extension modules load (as ldd lists them), the standard library without
the parts a headless test never imports, and the third-party packages `canopen` and `can`
import, each at the same absolute path, so the interpreter finds its prefix as on the host.
/bin/python3 in the stage points to it.

Usage: vcan-vm-python.py STAGE_DIR
Prints the number of files and bytes copied.
"""

import os
import shutil
import subprocess
import sys
import sysconfig

# What tests/python/canopen_drive.py imports, so that every module it needs is loaded here.
import argparse  # noqa: F401
import signal  # noqa: F401
import struct  # noqa: F401
import threading  # noqa: F401

import can  # noqa: F401
import can.interfaces.socketcan  # noqa: F401
import canopen  # noqa: F401

SKIP_STDLIB = {"test", "idlelib", "tkinter", "turtledemo", "ensurepip", "lib2to3", "pydoc_data",
               "site-packages", "dist-packages", "config-3.11-x86_64-linux-gnu", "venv"}


def main(stage):
    copied = [0, 0]

    def copy(path):
        dest = stage + path
        if os.path.exists(dest):
            return
        os.makedirs(os.path.dirname(dest), exist_ok=True)
        shutil.copy2(path, dest, follow_symlinks=True)
        copied[0] += 1
        copied[1] += os.path.getsize(dest)

    def libs_of(binary):
        out = subprocess.run(["ldd", binary], capture_output=True, text=True).stdout
        for line in out.splitlines():
            parts = line.split()
            if "=>" in parts and len(parts) > parts.index("=>") + 1 and parts[parts.index("=>") + 1].startswith("/"):
                yield parts[parts.index("=>") + 1]
            elif parts and parts[0].startswith("/"):
                yield parts[0]

    exe = os.path.realpath(sys.executable)
    copy(exe)
    binaries = [exe]
    # The standard library's sources (without the byte code: the compiled form of what is
    # imported follows below) and, of its extension modules, those loaded now.
    stdlib = sysconfig.get_paths()["stdlib"]
    for root, dirs, files in os.walk(stdlib):
        rel = os.path.relpath(root, stdlib)
        if rel == ".":
            dirs[:] = [d for d in dirs if d not in SKIP_STDLIB]
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in files:
            if f.endswith(".py"):
                copy(os.path.join(root, f))
    for m in list(sys.modules.values()):
        f = getattr(m, "__file__", None) or ""
        if f.endswith(".so"):
            copy(f)
            binaries.append(f)
        cached = getattr(m, "__cached__", None)
        if cached and os.path.exists(cached):
            copy(cached)
    # Third-party packages: the top-level directories of the modules imported above.
    site = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    site |= {p for p in sys.path if p.endswith(("site-packages", "dist-packages"))}
    tops = set()
    for m in list(sys.modules.values()):
        f = getattr(m, "__file__", None)
        if not f:
            continue
        for s in site:
            if f.startswith(s + os.sep):
                tops.add(os.path.join(s, os.path.relpath(f, s).split(os.sep)[0]))
    for top in sorted(tops):
        if os.path.isdir(top):
            for root, _, files in os.walk(top):
                for f in files:
                    p = os.path.join(root, f)
                    copy(p)
                    if f.endswith(".so"):
                        binaries.append(p)
        else:
            copy(top)
    for b in binaries:
        for lib in libs_of(b):
            copy(lib)
            real = os.path.realpath(lib)
            if real != lib:
                copy(real)
    os.makedirs(os.path.join(stage, "bin"), exist_ok=True)
    link = os.path.join(stage, "bin", "python3")
    if os.path.lexists(link):
        os.remove(link)
    os.symlink(exe, link)
    print(f"python {sys.version.split()[0]} ({exe}) with canopen {canopen.__version__}: {copied[0]} files, "
          f"{copied[1] / 1e6:.1f} MB; packages: {', '.join(os.path.basename(t) for t in sorted(tops))}")


if __name__ == "__main__":
    main(sys.argv[1].rstrip("/"))
