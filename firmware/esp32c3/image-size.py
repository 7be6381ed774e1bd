#!/usr/bin/env python3
"""Flash image and static RAM use of the firmware ELF, from `llvm-size -A` (section sizes).

Usage: python3 firmware/esp32c3/image-size.py [path/to/elf]
Default ELF: $CARGO_TARGET_DIR (or target)/riscv32imc-unknown-none-elf/release/puzzlebot-esp32c3
"""
import os
import subprocess
import sys

target = os.environ.get("CARGO_TARGET_DIR", "target")
elf = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    target, "riscv32imc-unknown-none-elf", "release", "puzzlebot-esp32c3")
out = subprocess.run(["llvm-size", "-A", elf], check=True, capture_output=True, text=True).stdout
sec = {}
for line in out.splitlines():
    parts = line.split()
    if len(parts) == 3 and parts[0].startswith(".") and parts[1].isdigit():
        sec[parts[0]] = int(parts[1])

def total(prefixes):
    return sum(v for k, v in sec.items() if any(k == p or k.startswith(p + ".") for p in prefixes))

# Sections whose bytes are stored in flash (code, read-only data, RAM code/data images).
flash = total([".text", ".rodata", ".rwtext", ".data", ".trap", ".flash.appdesc"])
iram = total([".rwtext", ".trap"])
dram_static = total([".data", ".bss"])
stack = sec.get(".stack", 0)
print(f"flash image (code + data stored in flash): {flash} B ({flash / 1048576:.3f} MiB)")
print(f"IRAM code: {iram} B; static DRAM (.data + .bss, includes the 36 KiB heap): {dram_static} B")
print(f"left for the stack: {stack} B ({stack / 1024:.0f} KiB); reclaimed-RAM heap: {sec.get('.dram2_uninit', 0)} B")
ok = flash <= 1048576 and stack >= 100 * 1024
print("budget (image <= 1 MiB, stack >= 100 KiB):", "met" if ok else "EXCEEDED")
sys.exit(0 if ok else 1)
