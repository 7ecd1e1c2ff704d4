#!/usr/bin/env python3
"""Names every panic call left in a Cortex-M image (the no-panic proof's diagnostics).

Usage: nopanic-report.py ELF

The image must be linked with an ordinary panic handler (`nopanic --features find-panics`). A
function *panics* if it is the panic handler, lives in `core::panicking`, or calls one that
panics and does nothing else of note (the `*_fail` helpers of slices, `unwrap_failed`, ...).
Every call from a non-panicking function into a panicking one is reported with its source
line and the chain of inlined callers (llvm-addr2line -i). Exit 0 when there is none.
"""
import re
import subprocess
import sys
from collections import defaultdict

elf = sys.argv[1]
dis = subprocess.run(["llvm-objdump", "-d", "--no-show-raw-insn", "-C", elf], capture_output=True, text=True, check=True).stdout

func_re = re.compile(r"^([0-9a-f]+) <(.*)>:$")
call_re = re.compile(r"^\s*([0-9a-f]+):\s+(bl|b\.w|b|blx|bne\.w|beq\.w|bhi\.w|bls\.w|bhs\.w|blo\.w|bcs\.w|bcc\.w|bgt\.w|blt\.w|bge\.w|ble\.w|bmi\.w|bpl\.w|bvs\.w|bvc\.w|b[a-z]{2})\s+0x([0-9a-f]+) <([^>+]*)(\+0x[0-9a-f]+)?>")

calls = defaultdict(list)  # caller -> [(addr, callee)]
funcs = []
cur = None
for line in dis.splitlines():
    m = func_re.match(line)
    if m:
        # ARM mapping symbols ($t, $d, $a) mark code or data inside a function, not a new one.
        if not m.group(2).startswith("$"):
            cur = m.group(2)
            if cur not in calls:
                funcs.append(cur)
                calls[cur] = []
        continue
    m = call_re.match(line)
    if m and cur is not None:
        callee = m.group(4)
        if callee != cur:
            calls[cur].append((int(m.group(1), 16), callee))

def seed(name):
    return (name.startswith("core::panicking::") or "rust_begin_unwind" in name or name == "panic"
            or name.endswith("::panic") or "panic_fmt" in name or "panic_bounds_check" in name
            or re.search(r"(slice_(start|end)_index_len_fail|slice_index_order_fail|unwrap_failed|expect_failed|panic_already_(mutably_)?borrowed|str_index_overflow_fail|slice_error_fail|len_mismatch_fail|copy_from_slice)", name) is not None)

panicking = {f for f in funcs if seed(f)}
# Helpers that do nothing but lead into a panic: their every call goes to a panicking function.
changed = True
while changed:
    changed = False
    for f in funcs:
        if f in panicking or not calls[f]:
            continue
        if all(c in panicking for _, c in calls[f]) and ("::panic" in f or "fail" in f or "panicking" in f or "assert" in f):
            panicking.add(f)
            changed = True

def demangle(n):
    for a, b in [("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$C$", ","), ("$RF$", "&"), ("$BP$", "*"), ("$u5b$", "["),
                 ("$u5d$", "]"), ("$u7b$", "{"), ("$u7d$", "}"), ("$u3b$", ";"), ("$u27$", "'"), ("..", "::")]:
        n = n.replace(a, b)
    return re.sub(r"::h[0-9a-f]{16}$", "", n.lstrip("_"))

def short(path):
    path = re.sub(r".*/registry/src/[^/]+/", "", path)
    path = re.sub(r"^/rustc/[0-9a-f]+/library/", "", path)
    return re.sub(r"^.*/(detector-core|firmware|host-sim|tests)/", r"\1/", path)

sites = sorted({(a, caller, callee) for caller in funcs if caller not in panicking for a, callee in calls[caller] if callee in panicking})
if not sites:
    print("no panic call left")
    sys.exit(0)
for a, caller, callee in sites:
    loc = subprocess.run(["llvm-addr2line", "-f", "-i", "-C", "-e", elf, hex(a)], capture_output=True, text=True).stdout.strip().splitlines()
    frames = [(short(loc[i + 1]), demangle(loc[i])) for i in range(0, len(loc) - 1, 2)]
    # The innermost frame of our own code (or of the dependency that panics), then its callers.
    chain = "\n      <- ".join(f"{f} ({n})" for f, n in frames if not f.startswith("core/"))
    print(f"{a:#x}: {callee}\n      at {chain}")
print(f"{len(sites)} panic call(s) left", file=sys.stderr)
sys.exit(1)
